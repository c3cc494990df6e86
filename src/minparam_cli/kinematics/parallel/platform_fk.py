"""Forward kinematics of a base + platform: every real assembly mode for six leg lengths.

Methods
-------
``exact``       the octahedral 3-3 pattern (Dang 2013's B_i P_j, i != j):
                elimination to a degree-16 polynomial (``platform_exact``),
                complete when all 16 roots verify; deterministic.
``pso``         the paper's particle swarm with multistart, each restart's best
                particle polished by Levenberg-Marquardt, then de-duplicated.
``multistart``  uniform random starts polished by Levenberg-Marquardt.
``auto``        ``exact`` when the legs form the octahedral pattern, else ``pso``.

A returned solution always reproduces the lengths to ``rtol * max(l*)``;
starts that end above it are counted as failed, not returned.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from minparam_cli.kinematics.defaults import PLATFORM_FK_METHODS
from minparam_cli.kinematics.parallel.platform import PlatformModel, leg_lengths, platform_points, pose_from_points
from minparam_cli.kinematics.parallel.platform_exact import BEZOUT_BOUND, solve_octahedral
from minparam_cli.kinematics.parallel.platform_pso import PSOSettings, newton_polish, polish, pso_search, random_starts

DEFAULT_RTOL = 1e-12  # accepted max |l - l*| relative to max l*
DEDUP_RTOL = 1e-6  # two modes are one when their platform nodes agree to this, relative to the size


@dataclass(frozen=True)
class Certificate:
    """What the elimination can vouch for (see ``platform_exact``)."""

    verified_roots: int
    bound: int
    imag_margin: float
    min_singular: float
    interpolation_error: float

    @property
    def complete(self) -> bool:
        return self.verified_roots == self.bound


@dataclass(frozen=True)
class Solution:
    """One assembly mode: pose (x, y, z, roll, pitch, yaw), max |l - l*|, and the starts that reached it."""

    pose: np.ndarray
    residual: float
    starts: int | None


@dataclass(frozen=True)
class FKResult:
    method: str
    target: np.ndarray
    solutions: tuple[Solution, ...]
    rtol: float
    tolerance: float  # absolute: rtol * max(target)
    seed: int | None = None
    starts: int | None = None  # starts run (pso restarts or multistart draws)
    failed_starts: int | None = None
    certificate: Certificate | None = None
    note: str = ""
    settings: dict = field(default_factory=dict)


def octahedral_pattern(model: PlatformModel):
    """(base order, top order, leg index matrix) if the legs form the 3-3 octahedral pattern, else None.

    Top node k is the platform node *not* joined to base node k; ``legs[i, k]``
    is the index of the leg joining base i to top k (-1 on the diagonal).
    """
    if len(model.base) != 3 or len(model.platform) != 3 or model.n_legs != 6:
        return None
    joined = np.zeros((3, 3), dtype=int)
    index = -np.ones((3, 3), dtype=int)
    for k, (b, p) in enumerate(zip(model.leg_base, model.leg_platform, strict=True)):
        joined[b, p] += 1
        index[b, p] = k
    if np.any(joined.sum(axis=0) != 2) or np.any(joined.sum(axis=1) != 2) or np.any(joined > 1):
        return None
    missing = [int(np.flatnonzero(joined[b] == 0)[0]) for b in range(3)]  # platform node not joined to base b
    top = np.array(missing)
    legs = index[:, top]
    return np.arange(3), top, legs


def forward_kinematics(
    model: PlatformModel,
    target,
    method: str = "auto",
    rng: np.random.Generator | None = None,
    seed: int | None = None,
    settings: PSOSettings = PSOSettings(),
    starts: int | None = None,
    rtol: float = DEFAULT_RTOL,
    side: str = "both",
    progress: Callable[[int, int], None] | None = None,
) -> FKResult:
    """All real assembly modes for the leg lengths ``target`` (one per leg, in leg order).

    ``rng`` drives ``pso`` and ``multistart`` (give ``seed`` too, so that the
    result records it).  ``side`` keeps "both" mirror images, or only the modes
    whose platform centroid is "above" or "below" the base plane.
    """
    target = np.asarray(target, dtype=float)
    if target.shape != (model.n_legs,):
        raise ValueError(f"expected {model.n_legs} lengths, got {target.size}")
    if method not in PLATFORM_FK_METHODS:
        raise ValueError(f"unknown method {method!r}; expected one of {', '.join(PLATFORM_FK_METHODS)}")
    pattern = octahedral_pattern(model)
    if method == "auto":
        method = "exact" if pattern is not None else "pso"
    if method == "exact" and pattern is None:
        raise ValueError("the exact enumeration needs the octahedral 3-3 pattern: 3 base and 3 platform nodes, "
                         "each joined to two nodes of the other side")
    tol = rtol * float(np.max(target))
    if method == "exact":
        result = _exact(model, target, pattern, tol, rtol)
    else:
        if rng is None:
            rng = np.random.default_rng(seed)
        result = _numerical(model, target, method, rng, seed, settings, starts, tol, rtol, progress)
    if side != "both":
        result = _keep_side(model, result, side)
    return result


def _exact(model, target, pattern, tol, rtol) -> FKResult:
    _, top, legs = pattern
    L = np.zeros((3, 3))
    for i in range(3):
        for k in range(3):
            if i != k:
                L[i, k] = target[legs[i, k]]
    P = model.platform[top]
    sides = np.linalg.norm(P[:, None, :] - P[None, :, :], axis=-1)
    sol = solve_octahedral(model.base, L, sides)
    inverse = np.argsort(top)  # platform node j is top node inverse[j]
    found = []
    poses = pose_from_points(model, sol.points[:, inverse]) if len(sol.points) else np.zeros((0, 6))
    residuals = np.max(np.abs(leg_lengths(model, poses) - target), axis=-1) if len(poses) else []
    for x, res in zip(poses, residuals, strict=True):
        if res > tol / 4:  # round-off from the frame fit: a few Gauss-Newton steps on the legs
            x = newton_polish(model, target, x)
            res = np.max(np.abs(leg_lengths(model, x) - target))
        if res <= tol:
            found.append(Solution(pose=x, residual=float(res), starts=None))
    note = ""
    if sol.empty_circle is not None:
        j = int(top[sol.empty_circle])
        names = [model.leg_names[legs[i, sol.empty_circle]] for i in range(3) if i != sol.empty_circle]
        note = (f"no real assembly: the spheres of legs {names[0]} and {names[1]} (platform node "
                f"{model.platform_names[j]}) do not meet")
    cert = Certificate(sol.n_complex, BEZOUT_BOUND, sol.imag_margin, sol.min_singular, sol.interpolation_error)
    ordered = sorted(found, key=lambda s: (-s.pose[2], s.pose[0], s.pose[1]))
    return FKResult("exact", target, tuple(ordered), rtol, tol, certificate=cert, note=note)


def _numerical(model, target, method, rng, seed, settings, starts, tol, rtol, progress) -> FKResult:
    if method == "pso":
        if starts is not None:
            settings = PSOSettings(**{**settings.__dict__, "restarts": int(starts)})
        x0, _ = pso_search(model, target, rng, settings,
                           progress=None if progress is None else (lambda i, n: progress(i, 2 * n)))
        n_starts = settings.restarts
        info = dict(settings.__dict__)
    else:
        n_starts = int(starts) if starts is not None else 200
        x0 = random_starts(model, target, rng, n_starts)
        info = {"starts": n_starts}
    scale = model.scale
    modes: list[list] = []  # [key, pose, residual, count]
    failed = 0
    for i, x in enumerate(x0):
        x, res = polish(model, target, x)
        if progress is not None:
            progress(len(x0) + i + 1 if method == "pso" else i + 1, 2 * len(x0) if method == "pso" else len(x0))
        if not res <= tol:
            failed += 1
            continue
        key = platform_points(model, x).ravel()
        for mode in modes:
            if np.max(np.abs(mode[0] - key)) <= DEDUP_RTOL * scale:
                mode[3] += 1
                if res < mode[2]:
                    mode[1], mode[2] = x, res
                break
        else:
            modes.append([key, x, res, 1])
    sols = sorted((Solution(m[1], m[2], m[3]) for m in modes), key=lambda s: (-s.pose[2], s.pose[0], s.pose[1]))
    return FKResult(method, target, tuple(sols), rtol, tol, seed=seed, starts=n_starts,
                    failed_starts=failed, settings=info)


def _keep_side(model, result: FKResult, side: str) -> FKResult:
    if side not in ("above", "below"):
        raise ValueError(f"unknown side {side!r}; expected both, above or below")
    B = model.base
    normal = np.cross(B[1] - B[0], B[2] - B[0]) if len(B) >= 3 else np.array([0.0, 0.0, 1.0])
    if normal[2] < 0 or (normal[2] == 0 and np.sum(normal) < 0):
        normal = -normal
    keep = []
    for s in result.solutions:
        height = (platform_points(model, s.pose).mean(axis=0) - B.mean(axis=0)) @ normal
        if (height > 0) == (side == "above"):
            keep.append(s)
    return FKResult(**{**result.__dict__, "solutions": tuple(keep)})
