"""Figure of `identify --consistency`: one row per base parameter, each recording's value with ±2σ error bars."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from minparam_cli.identify.consistency import ConsistencyResult


def consistency_plot(c: ConsistencyResult, title: str):
    """Values relative to the joint fit, (θ_r − θ_all) / scale with scale = max(|θ_all|, largest 2σ_r): every
    row then fits the same axis; the shaded band is the joint fit's ±2σ."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    params = c.parameters
    R = len(c.recordings)
    fig, ax = plt.subplots(figsize=(8, 0.35 * len(params) + 1.5))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for k, p in enumerate(params):
        y = len(params) - 1 - k
        ref, sj = p.joint.value, p.joint.std
        scale = max(abs(ref), max(2 * r.std for r in p.recordings), 1e-300)
        ax.fill_between([-2 * sj / scale, 2 * sj / scale], y - 0.4, y + 0.4, color="0.85", lw=0)
        for i, r in enumerate(p.recordings):
            dy = (i - (R - 1) / 2) * 0.6 / max(R, 1)
            ax.errorbar((r.value - ref) / scale, y + dy, xerr=2 * r.std / scale, fmt="o", ms=3,
                        color=colours[i % len(colours)], label=f"r{i + 1}" if k == 0 else None, capsize=2)
    ax.set_yticks(range(len(params)))
    ax.set_yticklabels([p.parameter + (" *" if p.disagree else "") for p in reversed(params)], fontsize=7)
    ax.axvline(0, color="k", lw=0.5)
    ax.set_xlabel("(θ_r − θ_all) / max(|θ_all|, 2σ_r); bars ±2σ; grey: joint fit ±2σ; * recordings disagree")
    ax.legend(fontsize=7, loc="lower right")
    ax.set_title(title, fontsize=10)
    fig.tight_layout()
    return fig
