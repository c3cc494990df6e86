"""Terminal report of `minparam evaluate` (pure: evaluation dict -> text)."""

from __future__ import annotations

from minparam_cli.render.columns import columns


def _pct(x) -> str:
    return "-" if x is None or x != x else f"{100 * x:.3g} %"


def render_evaluate(r: dict) -> str:
    """Per file and pooled: samples, RMS per joint, total RMS (N·m or N) and ‖r‖/‖τ‖."""
    n = len(r["pooled"]["rms_per_joint"])
    headers = ("data", "samples", *[f"RMS {j}" for j in range(1, n + 1)], "RMS total", "‖r‖/‖τ‖")
    rows = []

    def row(label, e):
        return (label, e["samples"], *[f"{x:.4g}" for x in e["rms_per_joint"]], f"{e['rms_total']:.4g}", _pct(e["relative_error"]))

    for f in r["files"]:
        rows.append(row(f["path"], f))
    if len(r["files"]) > 1:
        rows.append(row("pooled", r["pooled"]))
    out = [f"Model {r['model_file']} ({r['model']} parameters, {r['parameters']} of them) on {r['robot']}",
           columns(rows, headers, right=tuple(range(1, n + 4)))]
    if r.get("band"):
        from minparam_cli.render.uncertainty_text import band_lines

        out += band_lines(r)
    ident = r.get("identify_test")
    if ident:
        out.append(f"identify's test figure for this model: RMS total {ident['rms_total']:.4g}, ‖r‖/‖τ‖ {_pct(ident['relative_error'])}")
    return "\n".join(out) + "\n"
