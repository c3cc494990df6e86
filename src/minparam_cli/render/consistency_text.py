"""Terminal report of `minparam identify A B C --consistency` (pure: ConsistencyResult -> text)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from minparam_cli.render.columns import columns

if TYPE_CHECKING:
    from minparam_cli.identify.consistency import ConsistencyResult


def _pm(v: float, s: float) -> str:
    return f"{v:.4g} ± {s:.2g}"


def render_consistency(c: ConsistencyResult) -> str:
    R = len(c.recordings)
    out = [f"Consistency of {R} recordings (declared model, no diagnosis; σ: {c.sigma})"]
    out += [f"  r{i + 1}: {p}" for i, p in enumerate(c.recordings)]
    out.append("")
    rows = []
    for p in c.parameters:
        rows.append((p.parameter, *[_pm(r.value, r.std) for r in p.recordings], _pm(p.joint.value, p.joint.std),
                     f"{p.spread_over_sigma:.2g}", f"{p.spread_over_sigma_textbook:.2g}", "DISAGREE" if p.disagree else ""))
    hdr = ("parameter", *[f"r{i + 1} value ± σ" for i in range(R)], "all together", "spread/σ", "spread/σ textbook", "flag")
    out.append(columns(rows, hdr, right=tuple(range(1, R + 4))))
    out.append("")
    out.append("spread/σ = sqrt(χ²/(R−1)), χ² = Σ_r (θ_r − θ̄)²/σ_r²: about 1 when the recordings differ as their σ say; "
               f"DISAGREE: χ² > {c.chi2_limit:.3g} (the {100 * c.level:g} % quantile, {R - 1} degrees of freedom), "
               "the parameter is dominated by model error rather than noise")
    out.append(f"median spread/σ: {c.median_spread_over_sigma:.2g} ({c.sigma} σ), "
               f"{c.median_spread_over_sigma_textbook:.2g} (textbook σ); "
               f"{len(c.disagree)} of {len(c.parameters)} parameters disagree"
               + (f": {', '.join(c.disagree)}" if c.disagree else ""))
    out.append(f"joint fit: condition number {c.joint_condition_number:.4g}; seed {c.seed}")
    return "\n".join(out)
