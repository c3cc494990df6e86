"""The ``minparam singular --plot`` map: log10(sigma_min/sigma_max) over two joints."""

from __future__ import annotations

import numpy as np

from minparam_cli.render.singular_text import joint_value_text


def render_map(smap, chain, angle: str, marker=None):
    """Figure of log10(sigma_min/sigma_max) over two joints (pure: returns a matplotlib Figure)."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    i, j = smap.joints

    def conv(k, v):
        return np.degrees(v) if (chain.types[k] == "revolute" and angle == "deg") else v

    def label(k):
        if chain.types[k] == "revolute":
            return f"q{k + 1} ({'deg' if angle == 'deg' else 'rad'})"
        return f"q{k + 1} (m)"

    x, y = conv(i, smap.x), conv(j, smap.y)
    fig = Figure(figsize=(6.4, 5.2), dpi=110)
    ax = fig.add_subplot(1, 1, 1)
    floor = 1e-6
    data = np.log10(np.maximum(smap.sigma, floor))
    mesh = ax.pcolormesh(x, y, data, shading="auto", cmap="viridis", vmin=np.log10(floor), vmax=0)
    fig.colorbar(mesh, ax=ax, label="log10(sigma_min / sigma_max)")
    if smap.det is not None and np.any(smap.det > 0) and np.any(smap.det < 0):
        ax.contour(x, y, smap.det, levels=[0.0], colors="white", linewidths=1.0)
    if smap.sigma.min() <= smap.epsilon <= smap.sigma.max():
        ax.contour(x, y, smap.sigma, levels=[smap.epsilon], colors="red", linewidths=0.8, linestyles="dashed")
    if marker is not None:
        ax.plot([conv(i, marker[i])], [conv(j, marker[j])], marker="x", color="red", markersize=8)
    ax.set_xlabel(label(i))
    ax.set_ylabel(label(j))
    others = [f"q{k + 1}={joint_value_text(chain.types, k, smap.q_fixed[k], angle)}" for k in range(chain.n) if k not in (i, j)]
    ax.set_title(f"{smap.robot}\n" + ", ".join(others), fontsize=9)
    fig.text(0.01, 0.01, "white: det = 0   red dashed: sigma_min/sigma_max = epsilon", fontsize=7)
    fig.tight_layout()
    return fig


def singular_map(result):
    """The --plot figure of a ``Singularity`` with a map."""
    return render_map(result.map.data, result.chain, "deg" if result.degrees else "rad", marker=result.q)
