"""Limits of an excitation trajectory: as optimiser constraints, as a dense check, and a repair.

Every limit is a set of inequalities at the samples of one period (the
``grid``; the motion is periodic, so one period covers all time):

* joint position, lo_j + m·(hi_j − lo_j) ≤ q_j ≤ hi_j − m·(hi_j − lo_j),
  |q̇_j| ≤ (1 − m)·v_j and |q̈_j| ≤ (1 − m)·a_j: linear in the coefficients
  (``trajectory.basis``), so they go to the optimiser as linear constraints with
  their exact Jacobian;
* torque, |τ_j| ≤ (1 − m)·e_j with τ = Y(q, q̇, q̈)·φ_nominal (only when the
  description gives every link's inertial values and an effort limit);
* a Cartesian box for a point on the last link: lo_c ≤ p_c(q) ≤ hi_c;
* a floor (``--floor``): every link frame's origin and the tool point at least that high against
  gravity, h_p(q) ≥ floor (points, not the links' volumes);
* the collision shapes (``--collisions``): signed distances d_k(q) ≥ clearance (``collisions``).

m is the margin (a fraction).  Between grid points a motion can exceed what
the grid saw, so the result is checked again afterwards:

* positions, speeds and accelerations by bounds that hold at every instant
  (as in ``experiment.trajectory``: extremes on a grid of
  BOUND_POINTS_PER_HARMONIC points per period of the highest harmonic,
  widened by the next derivative's bound Σ_l (ω l)^k √(a_jl² + b_jl²) times
  half a step), against the same margin-shrunk limits; a joint
  that fails is scaled about its mean, x_j(t) → q0_j + s_j·(x_j(t) − q0_j),
  s_j < 1 computed in closed form (all three bounds are proportional to s_j,
  and the shrunk range is convex and contains q0_j, the mean of q_j);
* torques, the box, the floor and the collision shapes on a dense grid (the output samples and
  DENSE_POINTS_PER_HARMONIC points per period of the highest harmonic),
  against the limits themselves; a failure shrinks every joint's series by
  REPAIR_FACTOR, up to REPAIR_STEPS times, and then gives up.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from minparam_cli.chain import Chain, forward_kinematics
from minparam_cli.errors import ComputationError
from minparam_cli.experiment.trajectory import FourierTrajectory

DENSE_POINTS_PER_HARMONIC = 256
BOUND_POINTS_PER_HARMONIC = 1024  # grid of the all-instant bounds
REPAIR_FACTOR = 0.97
ON_BOUND = 1e-12  # relative to a joint's range: a mean position this far past the range's end is on it (rounding)
REPAIR_STEPS = 30
BOX_Q_STEP = 1e-6  # rad or m: central-difference step for ∂p/∂q


@dataclass(frozen=True, eq=False)
class Limits:
    """Per independent coordinate (SI; NaN where none), the margin, and the optional box."""

    lower: np.ndarray  # (n,)
    upper: np.ndarray  # (n,)
    velocity: np.ndarray  # (n,) NaN: no limit
    acceleration: np.ndarray
    effort: np.ndarray
    margin: float
    defaulted: tuple[int, ...] = ()  # 0-based joints whose position range is a default
    box: np.ndarray | None = None  # (3, 2) lower, upper per axis (NaN: free), base frame, m
    point: np.ndarray | None = None  # (3,) on the last link, in its frame, m
    floor: float | None = None  # --floor: every link origin and the tool point at least this high (m, against gravity)
    collisions: Any = None  # --collisions: a collisions.Collisions (distances between the file's collision shapes)

    @property
    def n(self) -> int:
        return self.lower.size

    def shrunk_range(self) -> tuple[np.ndarray, np.ndarray]:
        span = self.upper - self.lower
        return self.lower + self.margin * span, self.upper - self.margin * span

    def shrunk(self, values: np.ndarray) -> np.ndarray:
        return (1.0 - self.margin) * values


def _kron_rows(B: np.ndarray, n: int, joints) -> np.ndarray:
    """Rows (joint-major) of the map x = X.ravel() -> B @ X[j] for the given joints."""
    m = B.shape[1]
    out = np.zeros((len(joints) * B.shape[0], n * m))
    for r, j in enumerate(joints):
        out[r * B.shape[0]:(r + 1) * B.shape[0], j * m:(j + 1) * m] = B
    return out


def linear_constraints(limits: Limits, Bq: np.ndarray, Bv: np.ndarray, Ba: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A, b with A·x ≤ b for the position, speed and acceleration limits on the grid (x = X.ravel())."""
    n, N = limits.n, Bq.shape[0]
    lo, hi = limits.shrunk_range()
    blocks_A, blocks_b = [], []
    Aq = _kron_rows(Bq, n, range(n))
    blocks_A += [Aq, -Aq]
    blocks_b += [np.repeat(hi, N), -np.repeat(lo, N)]
    for B, lim in ((Bv, limits.velocity), (Ba, limits.acceleration)):
        joints = [j for j in range(n) if np.isfinite(lim[j])]
        if joints:
            A = _kron_rows(B, n, joints)
            bound = np.repeat(limits.shrunk(lim[joints]), N)
            blocks_A += [A, -A]
            blocks_b += [bound, bound]
    return np.vstack(blocks_A), np.concatenate(blocks_b)


def state_jacobian(d_q: np.ndarray, d_v: np.ndarray, d_a: np.ndarray, Bq, Bv, Ba) -> np.ndarray:
    """∂y/∂x (rows y, columns x = X.ravel()) from per-sample ∂y[s, i]/∂(q, q̇, q̈)[s, k] (N, m_i, n)."""
    N, mi, n = d_q.shape
    J = (np.einsum("sik,sc->sikc", d_q, Bq) + np.einsum("sik,sc->sikc", d_v, Bv) + np.einsum("sik,sc->sikc", d_a, Ba))
    return J.reshape(N * mi, n * Bq.shape[1])


def joint_states(chain: Chain, q: np.ndarray) -> np.ndarray:
    """Positions of every joint (mimic joints included) from the independent coordinates."""
    if chain.coupling is None:
        return q
    return chain.coupling.joint_states(q, q, q)[0]


def box_point(chain: Chain, q: np.ndarray, point: np.ndarray) -> np.ndarray:
    """The point (last link frame) in the base frame at every sample: (N, 3)."""
    T, _, _ = forward_kinematics(chain, joint_states(chain, q))
    Tl = T[:, -1]
    return Tl[:, :3, :3] @ point + Tl[:, :3, 3]


def up_direction(chain: Chain) -> np.ndarray:
    """The unit vector against gravity in the base frame (z when the description has no gravity)."""
    g = np.asarray(chain.gravity, dtype=float)
    return -g / np.linalg.norm(g) if np.any(g) else np.array([0.0, 0.0, 1.0])


def heights(chain: Chain, q: np.ndarray) -> np.ndarray:
    """(N, links + 1): the height against gravity (base frame, m) of every link frame's origin and of the
    tool point (the file's ``tool:``, else the last link's origin) at every sample (``--floor``)."""
    T, _, _ = forward_kinematics(chain, joint_states(chain, q))
    tool = np.zeros(3) if chain.tool is None else np.asarray(chain.tool, dtype=float)
    points = np.concatenate([T[:, :, :3, 3], (T[:, -1, :3, :3] @ tool + T[:, -1, :3, 3])[:, None, :]], axis=1)
    return points @ up_direction(chain)


def _central_differences(f, q: np.ndarray) -> np.ndarray:
    """∂f/∂q_k at every sample, (N, m, n), by central differences of step BOX_Q_STEP; f: (N, n) -> (N, m)."""
    N, n = q.shape
    out = None
    for k in range(n):
        qp, qm = q.copy(), q.copy()
        qp[:, k] += BOX_Q_STEP
        qm[:, k] -= BOX_Q_STEP
        d = (f(qp) - f(qm)) / (2 * BOX_Q_STEP)
        if out is None:
            out = np.empty((N, d.shape[1], n))
        out[:, :, k] = d
    assert out is not None  # n >= 1: a chain has a joint
    return out


def heights_jacobian(chain: Chain, q: np.ndarray) -> np.ndarray:
    """∂h_p/∂q_k at every sample (N, points, n), central differences."""
    return _central_differences(lambda x: heights(chain, x), q)


def box_point_jacobian(chain: Chain, q: np.ndarray, point: np.ndarray) -> np.ndarray:
    """∂p_c/∂q_k at every sample (N, 3, n), central differences."""
    return _central_differences(lambda x: box_point(chain, x, point), q)


def floor_constraint(chain: Chain, floor: float, Bq: np.ndarray, n: int, m: int, margin: float) -> dict:
    """--floor as an SLSQP inequality: every link origin and the tool point ``margin`` (m) above the floor."""

    def fun(x):
        return (heights(chain, Bq @ x.reshape(n, m).T) - floor - margin).ravel(order="F")

    def jac(x):
        dh = heights_jacobian(chain, Bq @ x.reshape(n, m).T)  # (N, points, n)
        zero = np.zeros((dh.shape[0], 1, n))
        return np.vstack([state_jacobian(dh[:, p:p + 1], zero, zero, Bq, Bq, Bq) for p in range(dh.shape[1])])

    return {"type": "ineq", "fun": fun, "jac": jac}


def all_time_bounds(traj: FourierTrajectory) -> tuple[np.ndarray, ...]:
    """Per joint, bounds that hold at every instant: q_j − q0_j ∈ [x_lo, x_hi], |q̇_j| ≤ v, |q̈_j| ≤ a."""
    points = BOUND_POINTS_PER_HARMONIC * max(traj.harmonics, 4)
    step = 1.0 / traj.base_frequency / points
    q, dq, ddq = traj.evaluate(np.arange(points) * step)
    x = q - traj.q0[None, :]
    half = step / 2.0
    x_lo = x.min(axis=0) - traj.derivative_bound(1) * half
    x_hi = x.max(axis=0) + traj.derivative_bound(1) * half
    v = np.abs(dq).max(axis=0) + traj.derivative_bound(2) * half
    a = np.abs(ddq).max(axis=0) + traj.derivative_bound(3) * half
    return x_lo, x_hi, v, a


def rigorous_scale(traj: FourierTrajectory, limits: Limits) -> np.ndarray:
    """Per joint s_j ≤ 1 such that the all-instant bounds of joint j scaled by s_j meet the shrunk
    limits (module docstring); 1 where they already do."""
    lo, hi = limits.shrunk_range()
    x_lo, x_hi, speed, accel = all_time_bounds(traj)
    q0 = traj.q0
    s = np.ones(limits.n)
    # SLSQP's bounds hold to rounding: a mean position on the range's end may lie a few ulps outside it
    # (the Stanford arm's prismatic joint, seed 0: 1e-17 below); there it counts as on the end
    tol = ON_BOUND * np.maximum(np.abs(hi - lo), 1.0)
    room_hi = np.where((hi - q0 < 0) & (hi - q0 >= -tol), 0.0, hi - q0)
    room_lo = np.where((lo - q0 > 0) & (lo - q0 <= tol), 0.0, lo - q0)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratios = [
            np.where(x_hi > 0, room_hi / x_hi, np.inf),
            np.where(x_lo < 0, room_lo / x_lo, np.inf),
            np.where(np.isfinite(limits.velocity) & (speed > 0), limits.shrunk(limits.velocity) / speed, np.inf),
            np.where(np.isfinite(limits.acceleration) & (accel > 0), limits.shrunk(limits.acceleration) / accel, np.inf),
        ]
    for r in ratios:
        s = np.minimum(s, r)
    if np.any(s < 0):  # q0 outside the shrunk range: no scale helps
        j = int(np.argmin(s))
        raise ComputationError(f"joint {j + 1}: mean position {q0[j]:g} outside the range [{lo[j]:g}, {hi[j]:g}]")
    return s + 0.0  # no -0.0 (0 / a negative bound) in the reports


def scaled(traj: FourierTrajectory, s) -> FourierTrajectory:
    s = np.broadcast_to(np.asarray(s, dtype=float), traj.q0.shape)
    return FourierTrajectory(traj.base_frequency, traj.q0, traj.a * s[:, None], traj.b * s[:, None])


def dense_times(traj: FourierTrajectory, extra=None) -> np.ndarray:
    """DENSE_POINTS_PER_HARMONIC points per period of the highest harmonic over one period, plus ``extra``."""
    points = DENSE_POINTS_PER_HARMONIC * max(traj.harmonics, 4)
    t = np.arange(points + 1) * (1.0 / traj.base_frequency / points)
    if extra is not None:
        t = np.concatenate([t, np.asarray(extra, dtype=float) % (1.0 / traj.base_frequency)])
    return t


def nonlinear_violations(chain: Chain, traj: FourierTrajectory, limits: Limits, phi, t, shrunk: bool = False) -> list[str]:
    """Torque and box limits broken at times t (text per broken limit; empty: none); ``shrunk``: against
    the effort limits less the margin."""
    from minparam_cli.experiment.simulate import rigid_torque

    out = []
    q, dq, ddq = traj.evaluate(t)
    if phi is not None and np.isfinite(limits.effort).any():
        tau = np.abs(rigid_torque(chain, q, dq, ddq, phi)).max(axis=0)
        effort = limits.shrunk(limits.effort) if shrunk else limits.effort
        for j in np.flatnonzero(np.isfinite(effort)):
            if tau[j] > effort[j]:
                out.append(f"joint {j + 1}: max |tau| {tau[j]:.4g} > effort limit {effort[j]:.4g}")
    if limits.box is not None:
        assert limits.point is not None  # the box comes with its point (api.excitation.prepare_excite)
        p = box_point(chain, q, limits.point)
        for c, axis in enumerate("xyz"):
            lo, hi = limits.box[c]
            if np.isfinite(lo) and p[:, c].min() < lo:
                out.append(f"tool {axis} {p[:, c].min():.4g} m < box {lo:.4g} m")
            if np.isfinite(hi) and p[:, c].max() > hi:
                out.append(f"tool {axis} {p[:, c].max():.4g} m > box {hi:.4g} m")
    if limits.floor is not None:
        h = heights(chain, q).min(axis=0)
        for k in np.flatnonzero(h < limits.floor):
            what = "the tool point" if k == chain.n else f"link {k + 1}'s origin"
            out.append(f"{what} {h[k]:.4g} m < floor {limits.floor:.4g} m")
    if limits.collisions is not None:
        out += limits.collisions.violations(chain, q, t, strict=shrunk)
    return out


def grid_feasible(x, A, b, constraints, slack, rtol: float = 1e-6) -> bool:
    """Every constraint holds on the grid: the linear ones and the rest conditions up to rtol of their
    bound's size, the torque and box ones up to their ``slack`` (the limits themselves, not the
    optimiser's tighter targets)."""
    scale = max(1.0, float(np.abs(b).max()))
    if np.any(A @ x - b > rtol * scale):
        return False
    for c, sl in zip(constraints[1:], slack[1:], strict=True):
        v = c["fun"](x)
        if c["type"] == "eq" and np.any(np.abs(v) > rtol * scale):
            return False
        if c["type"] == "ineq" and np.any(v + sl < -rtol * max(1.0, float(np.abs(v).max()))):
            return False
    return True
