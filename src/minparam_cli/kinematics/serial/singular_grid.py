"""Grids of Glazunov's global problem (``singular_scan``): the sweep range and grid of each joint,
matrix (3) over a Cartesian grid link by link, the relative smallest singular value σ_min/σ_max
(and det for six joints) at configurations, and ``sigma_map``: that quantity on a fine grid
over two joints, for a plot."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from minparam_cli.chain import REVOLUTE, Chain, motion
from minparam_cli.errors import InputError
from minparam_cli.kinematics.defaults import DEFAULT_EPSILON
from minparam_cli.kinematics.serial.plucker import normalised_matrices, plucker_matrices, require_serial


@dataclass(frozen=True, eq=False)
class ScanAxis:
    joint: int  # 0-based
    values: np.ndarray  # rad or m
    periodic: bool

    @property
    def step(self) -> float:
        return float(self.values[1] - self.values[0]) if self.values.size > 1 else 0.0


@dataclass(frozen=True, eq=False)
class SigmaMap:
    robot: str
    joints: tuple[int, int]
    x: np.ndarray
    y: np.ndarray
    sigma: np.ndarray  # (len(y), len(x)) σ_min/σ_max
    det: np.ndarray | None  # det of matrix (3), six joints only
    q_fixed: np.ndarray
    epsilon: float


# --- grids -------------------------------------------------------------------------


def joint_range(chain: Chain, j: int) -> tuple[float, float, bool]:
    """Sweep range of joint j: (lo, hi, periodic).

    Revolute: its limits clipped to one turn, or a full periodic turn without
    limits.  Prismatic: its limits, which the file must give.
    """
    lim = chain.limits[j] if j < len(chain.limits) else None
    if chain.types[j] == REVOLUTE:
        if lim is None or lim[1] - lim[0] >= 2 * np.pi - 1e-9:
            return -np.pi, np.pi, True
        return float(lim[0]), float(lim[1]), False
    if lim is None:
        raise InputError(
            f"joint {j + 1} ({chain.joint_names[j]}) is prismatic and has no limits; add limits to sweep it",
            chain.source,
        )
    return float(lim[0]), float(lim[1]), False


def axis_values(chain: Chain, j: int, step: float) -> ScanAxis:
    """Grid of one joint: ``step`` (rad) for revolute joints; prismatic joints get as many points as a turn."""
    lo, hi, periodic = joint_range(chain, j)
    per_turn = max(int(round(2 * np.pi / step)), 4)
    if chain.types[j] != REVOLUTE:
        return ScanAxis(j, np.linspace(lo, hi, per_turn + 1), False)
    if periodic:
        return ScanAxis(j, -np.pi + 2 * np.pi * np.arange(per_turn) / per_turn, True)
    count = max(int(np.ceil((hi - lo) / step - 1e-9)) + 1, 2)
    return ScanAxis(j, np.linspace(lo, hi, count), False)


def swept_joints(chain: Chain) -> tuple[int, ...]:
    """Joints 2 … n-1 (0-based 1 … n-2): the only ones that move the axes relative to each other."""
    return tuple(range(1, chain.n - 1))


def grid_plucker(chain: Chain, values: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Matrix (3) and O_c over a Cartesian grid (C order over the joints), link by link.

    Each link frame is computed once per combination of the joints before it,
    so the cost is set by the last joints only.
    """
    n = chain.n
    F = np.eye(4)[None]
    Z, O = [], []
    for j in range(n):
        A = F @ chain.pre[j]
        Z.append(A[:, :3, :3] @ chain.axes[j])
        O.append(A[:, :3, 3])
        M = motion(chain.types[j], chain.axes[j], np.asarray(values[j], float)) @ chain.post[j]
        F = (A[:, None] @ M[None]).reshape(-1, 4, 4)
    N = F.shape[0]
    tool = np.zeros(3) if chain.tool is None else np.asarray(chain.tool, float)
    c = F[:, :3, :3] @ tool + F[:, :3, 3]
    J = np.zeros((N, 6, n))
    for j in range(n):
        rep = N // Z[j].shape[0]
        z = np.repeat(Z[j], rep, axis=0)
        if chain.types[j] == REVOLUTE:
            J[:, :3, j] = z
            J[:, 3:, j] = np.cross(np.repeat(O[j], rep, axis=0), z)
        else:
            J[:, 3:, j] = z
    return J, c


def sigma_det(chain: Chain, J0: np.ndarray, c: np.ndarray):
    """(σ_min/σ_max, det of matrix (3) or None, normalised matrices, their singular values)."""
    Jn = normalised_matrices(chain, J0, c, chain.length_scale)
    s = np.linalg.svd(Jn, compute_uv=False)
    k = min(6, chain.n)
    with np.errstate(invalid="ignore", divide="ignore"):
        rel = np.where(s[:, 0] > 0, s[:, k - 1] / s[:, 0], 0.0)
    det = np.linalg.det(J0) if chain.n == 6 else None
    return rel, det, Jn, s


def evaluate_sigma(chain: Chain, Q: np.ndarray):
    """``sigma_det`` at the configurations Q (rows)."""
    J0, c = plucker_matrices(chain, Q)
    return sigma_det(chain, J0, c)


# --- the map --------------------------------------------------------------------------------


def sigma_map(chain: Chain, q_fixed, joints: tuple[int, int], points: int = 181, epsilon: float = DEFAULT_EPSILON) -> SigmaMap:
    """σ_min/σ_max (and det for six joints) over two joints, the others held at ``q_fixed``."""
    require_serial(chain)
    n = chain.n
    i, j = joints
    if i == j or not (0 <= i < n and 0 <= j < n):
        raise InputError(f"the map needs two different joints numbered 1..{n}, got {i + 1},{j + 1}")
    if points < 2:
        raise InputError("the map needs at least two points per axis")
    q_fixed = np.asarray(q_fixed, dtype=float).reshape(-1)
    if q_fixed.size != n:
        raise InputError(f"expected {n} joint values, got {q_fixed.size}")
    axes = []
    for k in (i, j):
        lo, hi, _ = joint_range(chain, k)
        axes.append(np.linspace(lo, hi, points))
    x, y = axes
    Q = np.tile(q_fixed, (points * points, 1))
    Y, X = np.meshgrid(y, x, indexing="ij")
    Q[:, i] = X.ravel()
    Q[:, j] = Y.ravel()
    rel, det, _, _ = evaluate_sigma(chain, Q)
    return SigmaMap(
        robot=chain.name,
        joints=(i, j),
        x=x,
        y=y,
        sigma=rel.reshape(points, points),
        det=None if det is None else det.reshape(points, points),
        q_fixed=q_fixed,
        epsilon=epsilon,
    )
