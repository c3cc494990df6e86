"""Workspace of a platform: poses sampled in a box, kept when every leg is within its limits.

Dang (2013) announces the workspace as the next step.  Here the reachable set
is estimated by Monte Carlo: poses are drawn uniformly (seeded) from a box in
(x, y, z, roll, pitch, yaw); an angle range of zero width fixes that angle (the
constant-orientation workspace).  The reachable volume of the position box is
fraction x box volume, with the binomial standard error.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from minparam_cli.kinematics.parallel.platform import POSE_NAMES, PlatformModel, leg_lengths


@dataclass(frozen=True)
class WorkspaceResult:
    box: tuple[tuple[float, float], ...]  # six (low, high) in POSE_NAMES order; angles in radians
    samples: int
    seed: int | None
    reachable: np.ndarray  # (k, 6) reachable poses
    too_short: np.ndarray  # (n_legs,) samples where the leg is below its lower limit
    too_long: np.ndarray  # (n_legs,) samples where the leg is above its upper limit

    @property
    def count(self) -> int:
        return int(len(self.reachable))

    @property
    def fraction(self) -> float:
        return self.count / self.samples if self.samples else 0.0

    @property
    def box_volume(self) -> float:
        """Volume of the position part of the box (length unit cubed)."""
        return float(np.prod([hi - lo for lo, hi in self.box[:3]]))

    @property
    def volume(self) -> tuple[float, float]:
        """Reachable position volume and its standard error (length unit cubed)."""
        p = self.fraction
        se = np.sqrt(p * (1 - p) / self.samples) if self.samples else 0.0
        return p * self.box_volume, float(se * self.box_volume)


def require_workspace(desc, source: str) -> None:
    """Refuse a platform whose workspace cannot be sampled (one line): a free truss has no base, and
    every leg needs its length limits."""
    from minparam_cli.errors import DescriptionError

    if desc.structure == "truss":
        raise DescriptionError("a free 12-leg truss has no base to measure a workspace from; "
                               "describe it with 'base' and 'platform'", source, "nodes")
    for k, leg in enumerate(desc.legs):
        if leg.limits is None:
            raise DescriptionError(f"leg {leg.name!r} has no length limits; the workspace needs them "
                                   "(give 'limits' or 'leg_limits')", source, f"legs[{k + 1}]")


def default_box(model: PlatformModel, given: dict[str, tuple[float, float]]) -> tuple[tuple[float, float], ...]:
    """The sampling box: the file's ranges where given; otherwise |x|, |y| <= R, 0 <= z <= R, angles fixed at 0.

    R = max |B| + max upper leg limit + max |p| bounds every reachable position.
    Only the half-space above the base plane is sampled by default; a planar
    platform's workspace below it is the mirror image.
    """
    R = float(np.linalg.norm(model.base, axis=1).max() + np.nanmax(model.limits[:, 1])
              + np.linalg.norm(model.platform, axis=1).max())
    defaults = {"x": (-R, R), "y": (-R, R), "z": (0.0, R), "roll": (0.0, 0.0), "pitch": (0.0, 0.0), "yaw": (0.0, 0.0)}

    def pair(k: str) -> tuple[float, float]:
        lo, hi = given.get(k, defaults[k])
        return float(lo), float(hi)

    return tuple(pair(k) for k in POSE_NAMES)


def sample_workspace(
    model: PlatformModel,
    box: tuple[tuple[float, float], ...],
    samples: int,
    rng: np.random.Generator,
    seed: int | None = None,
    chunk: int = 50_000,
    progress: Callable[[int, int], None] | None = None,
) -> WorkspaceResult:
    """Draw ``samples`` poses uniformly from ``box`` and keep those with every leg within its limits."""
    if np.any(~np.isfinite(model.limits)):
        raise ValueError("every leg needs length limits to sample a workspace")
    lo = np.array([b[0] for b in box], dtype=float)
    hi = np.array([b[1] for b in box], dtype=float)
    kept = []
    short = np.zeros(model.n_legs, dtype=np.int64)
    long_ = np.zeros(model.n_legs, dtype=np.int64)
    done = 0
    while done < samples:
        n = min(chunk, samples - done)
        q = lo + (hi - lo) * rng.random((n, 6))
        lengths = leg_lengths(model, q)
        below = lengths < model.limits[:, 0]
        above = lengths > model.limits[:, 1]
        short += below.sum(axis=0)
        long_ += above.sum(axis=0)
        ok = ~np.any(below | above, axis=1)
        kept.append(q[ok])
        done += n
        if progress is not None:
            progress(done, samples)
    reach = np.concatenate(kept, axis=0) if kept else np.zeros((0, 6))
    return WorkspaceResult(tuple(map(tuple, np.stack([lo, hi], axis=1))), int(samples), seed, reach, short, long_)


def workspace_figure(model: PlatformModel, result: WorkspaceResult, length_unit: str = "", max_points: int = 20_000):
    """Three projections of the reachable platform positions (a matplotlib Figure; pure, no I/O)."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    fig = Figure(figsize=(12.5, 4.4), layout="constrained")
    pts = result.reachable[:max_points, :3]
    unit = f" [{length_unit}]" if length_unit else ""
    axes = fig.subplots(1, 3)
    sc = None
    for ax, (i, j, depth) in zip(axes, ((0, 1, 2), (0, 2, 1), (1, 2, 0)), strict=True):
        if len(pts):
            order = np.argsort(pts[:, depth])  # draw the far points first
            sc = ax.scatter(pts[order, i], pts[order, j], c=pts[order, 2], s=2, cmap="viridis", linewidths=0,
                            vmin=pts[:, 2].min(), vmax=pts[:, 2].max())
        ring = np.vstack([model.base, model.base[:1]])
        ax.plot(ring[:, i], ring[:, j], "-o", color="tab:red", ms=4, lw=1, label="base nodes")
        ax.set_xlabel(f"{'xyz'[i]}{unit}")
        ax.set_ylabel(f"{'xyz'[j]}{unit}")
        ax.set_aspect("equal", adjustable="datalim")
        ax.grid(alpha=0.3)
    axes[0].set_title("top view", fontsize=9)
    axes[1].set_title("side view (y towards the viewer)", fontsize=9)
    axes[2].set_title("side view (x towards the viewer)", fontsize=9)
    axes[0].legend(loc="upper right", fontsize=8)
    if sc is not None:
        fig.colorbar(sc, ax=list(axes), label=f"z{unit}", shrink=0.85)
    vol, se = result.volume
    fig.suptitle(
        f"{model.name}: {result.count} of {result.samples} sampled poses reachable "
        f"({100 * result.fraction:.1f} %), volume {vol:.4g} ± {se:.2g}{' ' + length_unit + '³' if length_unit else ''}"
        f" (seed {result.seed})",
        fontsize=10,
    )
    return fig
