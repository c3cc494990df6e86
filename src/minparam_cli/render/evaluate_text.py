"""Terminal report of `minparam evaluate` (pure: EvaluateResult -> text)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from minparam_cli.render.columns import columns

if TYPE_CHECKING:
    from minparam_cli.model.evaluation import EvaluateResult, Sums


def _pct(x) -> str:
    return "-" if x is None or x != x else f"{100 * x:.3g} %"


def render_evaluate(r: EvaluateResult) -> str:
    """Per file and pooled: samples, RMS per joint, total RMS (N·m or N) and ‖r‖/‖τ‖."""
    ev = r.evaluation
    n = len(ev.pooled.rows)
    headers = ("data", "samples", *[f"RMS {j}" for j in range(1, n + 1)], "RMS total", "‖r‖/‖τ‖")
    rows = []

    def row(label, s: Sums):
        e = s.errors()
        return (label, s.samples, *[f"{x:.4g}" for x in e.rms_per_joint], f"{e.rms_total:.4g}", _pct(e.relative_error))

    for path, sums, _ in ev.files:
        rows.append(row(path, sums))
    if len(ev.files) > 1:
        rows.append(row("pooled", ev.pooled))
    out = [f"Model {r.model_file} ({r.which} parameters, {r.parameters} of them) on {r.robot}",
           columns(rows, headers, right=tuple(range(1, n + 4)))]
    if ev.bands is not None:
        from minparam_cli.render.uncertainty_text import band_lines

        out += band_lines(r)
    ident = r.identify_test
    if ident:
        out.append(f"identify's test figure for this model: RMS total {ident['rms_total']:.4g}, ‖r‖/‖τ‖ {_pct(ident['relative_error'])}")
    return "\n".join(out) + "\n"
