"""The ``excite --plot`` figure: every joint's q(t) with its limits (pure: returns a matplotlib Figure)."""

from __future__ import annotations

import numpy as np


def render_trajectory(result, types, angle: str = "deg"):
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    lim = result.limits
    n = lim.n
    lo_m, hi_m = lim.shrunk_range()
    fig = Figure(figsize=(7.0, 1.5 + 1.3 * n), dpi=110)
    axes = fig.subplots(n, 1, sharex=True, squeeze=False)[:, 0]
    for j, ax in enumerate(axes):
        f = np.degrees if (types[j] == "revolute" and angle == "deg") else (lambda v: v)
        unit = ("deg" if angle == "deg" else "rad") if types[j] == "revolute" else "m"
        ax.plot(result.t, f(result.q[:, j]), color="C0", linewidth=1.0)
        for v in (lim.lower[j], lim.upper[j]):
            ax.axhline(f(v), color="red", linewidth=1.0, linestyle="-" if j not in lim.defaulted else ":")
        for v in (lo_m[j], hi_m[j]):
            ax.axhline(f(v), color="red", linewidth=0.6, linestyle="--")
        ax.set_ylabel(f"q{j + 1} ({unit})")
    axes[-1].set_xlabel("t (s)")
    fig.suptitle(f"excitation: cond {result.cond_output_si:.3g} (base regressor, SI), {result.cond_output:.3g} column-scaled; "
                 "red: limits, dashed: margin",
                 fontsize=9)
    fig.tight_layout()
    return fig
