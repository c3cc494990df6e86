"""Text for the σ of identify: which kind the table shows, and the essential-parameter reduction (pure)."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from minparam_cli.identify.assess.essential import EssentialReport
    from minparam_cli.identify.estimate.records import SigmaSummary
    from minparam_cli.model.bands import BandCounts
    from minparam_cli.model.evaluation import EvaluateResult

WHAT = {
    "hac": "Newey–West over time blocks (allows for correlated residuals)",
    "bootstrap": "block bootstrap over time (allows for correlated residuals)",
    "textbook": "textbook σ²(WᵀW)⁻¹ (assumes white, independent residuals)",
}


def sigma_line(s: SigmaSummary | None) -> str:
    """One line: the kind of σ shown, its blocks, and how it compares with the textbook σ (None: the
    textbook σ, without blocks)."""
    kind = "textbook" if s is None else s.kind
    out = f"σ: {WHAT.get(kind, kind)}"
    if s is None:
        return out
    if s.blocks and kind != "textbook":
        out += f"; {s.blocks} blocks of {s.block_length_s:g} s"
    if kind == "bootstrap":
        out += f", {s.replicates} replicates, seed {s.seed}"
    if s.ratio_to_textbook_median is not None and kind != "textbook":
        out += f"; median {s.ratio_to_textbook_median:.2g}x the textbook σ"
    return out


def essential_lines(r: EssentialReport) -> list[str]:
    """The essential parameter set (Pham & Gautier 1991), what was dropped and why, and the cost in error."""
    from minparam_cli.render.columns import columns

    e = r.essential
    out = [(f"Essential parameters (every relative σ ≤ {e.bound:g} %): {len(e.names)} kept, "
            f"{len(e.dropped)} dropped; condition number {e.cond:.4g} (all: {e.cond_full:.4g})")]
    rows = [(k, f"{float(v):.6g}", f"{float(s):.3g}") for k, v, s in zip(e.names, e.theta, e.std_percent, strict=True)]
    out.append(columns(rows, ("essential", "value", "σ %"), right=(1, 2)))
    for d in e.dropped:
        out.append(f"dropped {d['parameter']} = {d['value']:.4g}: {d['why']}")
    b, a = r.error_before, r.error_after

    def rel(x):
        return "-" if x is None else f"{100 * x:.3g} %"

    out.append(f"error on {r.error_data}: rms {b['rms_total']:.4g} -> {a['rms_total']:.4g}, "
               f"‖r‖/‖τ‖ {rel(b['relative_error'])} -> {rel(a['relative_error'])} (all parameters -> essential set)")
    return out


def band_lines(r: EvaluateResult) -> list[str]:
    """evaluate --band: per file and joint, the share of samples inside the band and its mean half-width."""
    from minparam_cli.render.columns import columns

    ev = r.evaluation
    b = ev.band
    assert ev.bands is not None and b is not None  # called for an evaluation with a band only
    n = len(ev.pooled.rows)
    rows = []
    entries: list[tuple[str, BandCounts]] = [(f[0], c) for f, c in zip(ev.files, ev.bands, strict=True)]
    if len(ev.files) > 1:
        pooled = ev.pooled_band()
        assert pooled is not None  # ev.bands is not None
        entries.append(("pooled", pooled))
    for label, e in entries:
        rows.append((label, *[f"{100 * x:.1f} %" for x in e.inside_per_joint()],
                     *[f"{h:.3g} ({hp:.2g})" for h, hp in zip(e.half_width_per_joint(), e.parameter_half_width_per_joint(), strict=True)]))
    hdr = ("data", *[f"inside {j}" for j in range(1, n + 1)], *[f"± {j} (θ part)" for j in range(1, n + 1)])
    return [(f"Prediction band {100 * b.level:g} % (z = {b.z:.3g}; parameter covariance: {b.kind}, "
             "plus the fit's residual σ per joint): share of samples inside, mean half-width (N·m or N)"),
            columns(rows, hdr, right=tuple(range(1, 2 * n + 1)))]
