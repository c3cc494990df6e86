"""Figures of `minparam identify` (pure: data and models in, matplotlib figures out)."""

from __future__ import annotations

import numpy as np


def _grid(n: int):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cols = 2 if n > 1 else 1
    rows = int(np.ceil(n / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(10, 2.4 * rows), squeeze=False)
    for k in range(n, rows * cols):
        axes.flat[k].set_visible(False)
    return fig, axes.flat


def residual_vs_velocity(hold, before, after, title: str):
    """Residual τ − τ̂ against q̇, per joint, for two models (label, design, theta)."""
    n = hold.q.shape[1]
    fig, axes = _grid(n)
    for (label, design, theta), colour in ((before, "0.6"), (after, "tab:blue")):
        res = hold.tau - design.columns(hold) @ theta
        for j in range(n):
            axes[j].plot(hold.dq[:, j], res[:, j], ".", ms=2, color=colour, label=label)
    for j in range(n):
        axes[j].set_xlabel(f"q̇{j + 1}")
        axes[j].set_ylabel(f"residual τ{j + 1}")
        axes[j].axhline(0, color="k", lw=0.5)
    axes[0].legend(loc="upper left", fontsize=7, markerscale=4)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return fig


def measured_vs_predicted(hold, model, title: str):
    """Measured and predicted torque over time on the held-out samples."""
    label, design, theta = model
    pred = design.columns(hold) @ theta
    n = hold.q.shape[1]
    fig, axes = _grid(n)
    for j in range(n):
        axes[j].plot(hold.t, hold.tau[:, j], color="0.3", lw=1, label="measured")
        axes[j].plot(hold.t, pred[:, j], color="tab:orange", lw=1, label=f"predicted ({label})")
        axes[j].set_ylabel(f"τ{j + 1}")
        axes[j].set_xlabel("t (s)")
    axes[0].legend(loc="upper left", fontsize=7)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return fig
