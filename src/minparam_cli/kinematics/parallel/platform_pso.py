"""Numerical forward kinematics: the paper's particle swarm, random multistart, and the local polish.

Dang (2013) solves the forward problem as min sum (l_ij - l*_ij)^2 over the
pose (eq. 7) with a particle swarm (eq. 8-10): velocity update
Delta_i = w Delta_{i-1} + U[0, c1] (x) (X* - X) + U[0, c2] (x) (X** - X),
w = 0.7298, c1 = c2 = 1.49618, 50 particles, 50 iterations, 30 restarts.

Choices the paper leaves open, made here: the neighbourhood of every particle
is its whole swarm (global best); velocities start at zero; particles start
uniformly in :func:`search_box` and are clipped to it (the clipped velocity
component is zeroed).  Each restart's best particle is then polished by
Levenberg-Marquardt on the six length residuals (scipy's MINPACK wrapper),
which the swarm itself cannot do to better than about 1e-3 of a length.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from minparam_cli.kinematics.parallel.platform import EPS, PlatformModel, canonical_pose, leg_jacobian, leg_lengths


@dataclass(frozen=True)
class PSOSettings:
    """Particle-swarm parameters; the defaults are the paper's."""

    particles: int = 50
    iterations: int = 50
    restarts: int = 30
    inertia: float = 0.7298
    cognitive: float = 1.49618
    social: float = 1.49618


def search_box(model: PlatformModel, target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pose box that holds every assembly: |x|, |y|, |z| <= max|B| + max l* + max|p|; full angle ranges.

    A platform node lies within max l* of some base node, and the platform
    origin within max|p| of that node, so no solution lies outside.
    """
    reach = np.linalg.norm(model.base, axis=1).max() + float(np.max(target))
    reach += np.linalg.norm(model.platform, axis=1).max()
    lo = np.array([-reach, -reach, -reach, -math.pi, -math.pi / 2, -math.pi])
    hi = -lo
    return lo, hi


def pso_search(
    model: PlatformModel,
    target: np.ndarray,
    rng: np.random.Generator,
    settings: PSOSettings = PSOSettings(),
    progress: Callable[[int, int], None] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Run ``settings.restarts`` independent swarms side by side, Dang (2013) eq. (7)-(10).

    Returns the best pose of each swarm (restarts, 6) and its objective value.
    """
    lo, hi = search_box(model, target)
    shape = (settings.restarts, settings.particles, 6)
    X = lo + (hi - lo) * rng.random(shape)
    V = np.zeros(shape)
    f = _objective(model, X, target)
    pbest, pval = X.copy(), f.copy()
    for it in range(settings.iterations):
        g = np.argmin(pval, axis=1)
        gbest = pbest[np.arange(settings.restarts), g][:, None, :]
        V = (
            settings.inertia * V
            + settings.cognitive * rng.random(shape) * (pbest - X)
            + settings.social * rng.random(shape) * (gbest - X)
        )
        X = X + V
        clipped = (X < lo) | (X > hi)
        X = np.clip(X, lo, hi)
        V[clipped] = 0.0
        f = _objective(model, X, target)
        better = f < pval
        pbest[better], pval[better] = X[better], f[better]
        if progress is not None:
            progress(it + 1, settings.iterations)
    g = np.argmin(pval, axis=1)
    idx = np.arange(settings.restarts)
    return pbest[idx, g], pval[idx, g]


def random_starts(model: PlatformModel, target: np.ndarray, rng: np.random.Generator, n: int) -> np.ndarray:
    """``n`` poses drawn uniformly from :func:`search_box`."""
    lo, hi = search_box(model, target)
    return lo + (hi - lo) * rng.random((n, 6))


def _objective(model, X, target):
    """Eq. (7): sum over the legs of (l - l*)^2, vectorised over (..., 6) poses."""
    return np.sum((leg_lengths(model, X) - target) ** 2, axis=-1)


def polish(model: PlatformModel, target: np.ndarray, x0: np.ndarray) -> tuple[np.ndarray, float]:
    """Levenberg-Marquardt on the length residuals, then Gauss-Newton to round-off.

    Returns the pose (angles as :func:`canonical_pose` gives them) and max |l - l*|.
    """
    from scipy.optimize import least_squares

    def fun(x):
        return leg_lengths(model, x) - target

    def jac(x):
        return leg_jacobian(model, x)

    x = np.asarray(x0, dtype=float)
    try:
        sol = least_squares(fun, x, jac=jac, method="lm", xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=400)
        x = sol.x
    except (ValueError, np.linalg.LinAlgError):
        pass
    x = newton_polish(model, target, canonical_pose(x))
    return x, float(np.max(np.abs(fun(x))))


def newton_polish(model: PlatformModel, target: np.ndarray, x: np.ndarray, steps: int = 4) -> np.ndarray:
    """A few Gauss-Newton steps on the length residuals; stops when they no longer help."""
    x = np.array(x, dtype=float)
    r = leg_lengths(model, x) - target
    best = np.max(np.abs(r))
    for _ in range(steps):
        J = leg_jacobian(model, x)
        step, *_ = np.linalg.lstsq(J, r, rcond=None)
        trial = x - step
        rt = leg_lengths(model, trial) - target
        if not np.max(np.abs(rt)) < best:
            break
        x, r, best = trial, rt, np.max(np.abs(rt))
        if best <= 4 * EPS * np.max(np.abs(target)):
            break
    return x
