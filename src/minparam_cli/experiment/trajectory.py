"""Finite Fourier series excitation trajectories (Swevers et al. 1997).

Swevers, Ganseman, Tükel, De Schutter and Van Brussel, "Optimal robot
excitation and identification", IEEE Trans. Robotics and Automation 13(5),
1997: joint j follows

    q_j(t)   = q0_j + Σ_{l=1..H}  a_jl/(ω_f l) sin(ω_f l t) − b_jl/(ω_f l) cos(ω_f l t)
    q̇_j(t)   =        Σ_{l=1..H}  a_jl cos(ω_f l t) + b_jl sin(ω_f l t)
    q̈_j(t)   =        Σ_{l=1..H} −a_jl ω_f l sin(ω_f l t) + b_jl ω_f l cos(ω_f l t)

with ω_f = 2π f_base.  The motion is periodic with period 1/f_base, so its
extremes over all time are its extremes over one period.

This module is the series' one implementation: its values
(``FourierTrajectory.evaluate``) and, for the excitation design (``excite``),
the same series as a linear map of each joint's coefficient row
x_j = (q0_j, a_j1..a_jH, b_j1..b_jH): for sample times t (N,)

    q = B_q(t) Xᵀ,   q̇ = B_v(t) Xᵀ,   q̈ = B_a(t) Xᵀ,     X = (x_1; …; x_n)  (n, 1 + 2H),

with the (N, 1 + 2H) basis matrices of :func:`basis`, the exact derivatives
the optimiser's gradients and linear limit constraints use.  Both share the
harmonics' frequencies and phases (:func:`harmonic_terms`); each keeps its own
order of floating-point operations, so that a trajectory's samples and the
design's grid values stay what they were.

Start and end at rest.  The series is periodic, so q, q̇, q̈ at t = 0 equal
their values at t = k/f_base.  Two linear conditions per joint,

    q̇_j(0) = Σ_l a_jl = 0,          q̈_j(0) = ω_f Σ_l l b_jl = 0,

put every period boundary at rest (q̇ = q̈ = 0) (:func:`rest_rows`,
:func:`project_to_rest`).  This is the role the added fifth-order polynomial
plays in Swevers' and Park's formulations; as equality constraints on the
coefficients the motion stays one Fourier series (periodic, so periods can be
repeated and averaged, and ``simulate`` and a controller regenerate it from the
same coefficients), and it needs H ≥ 2.

The random excitation (:func:`fourier_excitation`, ``simulate``'s and the
design's starts): the coefficients are random (seeded) and then scaled,
joint by joint, so that the whole motion stays inside the joint range shrunk
by a margin.
The scale uses a bound, not a sample: the extremes over a grid of one period
plus (largest possible speed) × (half the grid step), so no instant between
grid points can leave the range.

Where the description gives velocity or acceleration limits, each joint's
coefficients are then scaled down (never up) so that bounds on max |q̇_j| and
max |q̈_j| of the same kind (grid extremes widened by the next derivative's
bound × half a step) stay within (1 − margin) of the limits.  Scaling a_jl
and b_jl by s ≤ 1 scales q_j − q0_j, q̇_j and q̈_j by s: the positions stay
inside the range, since the excursion of a zero-mean series contains 0.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from minparam_cli.chain import PRISMATIC, REVOLUTE

# Joints whose file gives no limits move within these ranges (rad, m).
DEFAULT_REVOLUTE_RANGE = (-np.pi / 2, np.pi / 2)
DEFAULT_PRISMATIC_RANGE = (-0.1, 0.1)
# Fraction of each joint's range kept free at both ends.
LIMIT_MARGIN = 0.1
# Grid points per period of the highest harmonic when bounding the excursion.
POINTS_PER_HARMONIC_PERIOD = 64


@dataclass(frozen=True, eq=False)
class FourierTrajectory:
    """Coefficients of Swevers' series for n joints and H harmonics (SI units)."""

    base_frequency: float  # f_base in Hz; ω_f = 2π f_base
    q0: np.ndarray  # (n,) rad or m
    a: np.ndarray  # (n, H) rad/s or m/s
    b: np.ndarray  # (n, H)

    @property
    def harmonics(self) -> int:
        return self.a.shape[1]

    @property
    def omega(self) -> float:
        return 2.0 * np.pi * self.base_frequency

    @classmethod
    def from_matrix(cls, X: np.ndarray, base_frequency: float) -> FourierTrajectory:
        """The trajectory of the coefficient matrix X (n, 1 + 2H) (module docstring)."""
        X = np.asarray(X, dtype=float)
        H = (X.shape[1] - 1) // 2
        return cls(float(base_frequency), X[:, 0].copy(), X[:, 1:1 + H].copy(), X[:, 1 + H:].copy())

    def matrix(self) -> np.ndarray:
        """The coefficient matrix X (n, 1 + 2H): row j is (q0_j, a_j1..a_jH, b_j1..b_jH)."""
        return np.hstack([self.q0[:, None], self.a, self.b])

    def evaluate(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Exact q, q̇, q̈ at times t (N,), each (N, n), from Swevers' series."""
        w_l, s, c = harmonic_terms(t, self.base_frequency, self.harmonics)
        q = self.q0[None, :] + s @ (self.a / w_l).T - c @ (self.b / w_l).T
        dq = c @ self.a.T + s @ self.b.T
        ddq = -s @ (self.a * w_l).T + c @ (self.b * w_l).T
        return q, dq, ddq

    def speed_bound(self) -> np.ndarray:
        """Per joint, an upper bound on |q̇_j(t)| over all t: Σ_l √(a_jl² + b_jl²)."""
        return np.sqrt(self.a**2 + self.b**2).sum(axis=1)

    def derivative_bound(self, order: int) -> np.ndarray:
        """Per joint, an upper bound on |d^order q_j / dt^order| over all t (order >= 1):
        Σ_l (ω_f l)^(order−1) √(a_jl² + b_jl²)."""
        w_l = self.omega * np.arange(1, self.harmonics + 1)
        return (np.sqrt(self.a**2 + self.b**2) * w_l[None, :] ** (order - 1)).sum(axis=1)


def harmonic_terms(t, base_frequency: float, harmonics: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The series' terms at times t (N,): ω_f l (H,), and sin(ω_f l t), cos(ω_f l t) (N, H)."""
    t = np.asarray(t, dtype=float).reshape(-1)
    w_l = 2.0 * np.pi * base_frequency * np.arange(1, harmonics + 1)
    phase = t[:, None] * w_l[None, :]
    return w_l, np.sin(phase), np.cos(phase)


def basis(t, base_frequency: float, harmonics: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """B_q, B_v, B_a (N, 1 + 2H) at times t: q_j = B_q @ x_j and so on (module docstring)."""
    w, s, c = harmonic_terms(t, base_frequency, harmonics)
    N = s.shape[0]
    one, zero = np.ones((N, 1)), np.zeros((N, 1))
    Bq = np.hstack([one, s / w, -c / w])
    Bv = np.hstack([zero, c, s])
    Ba = np.hstack([zero, -s * w, c * w])
    return Bq, Bv, Ba


def rest_rows(harmonics: int) -> np.ndarray:
    """(2, 1 + 2H): row 0 · x_j = q̇_j(0), row 1 · x_j = q̈_j(0)/ω_f (module docstring)."""
    R = np.zeros((2, 1 + 2 * harmonics))
    R[0, 1:1 + harmonics] = 1.0
    R[1, 1 + harmonics:] = np.arange(1, harmonics + 1)
    return R


def project_to_rest(X: np.ndarray) -> np.ndarray:
    """The nearest coefficients (least change, per joint) that satisfy both rest conditions."""
    X = np.array(X, dtype=float)
    R = rest_rows((X.shape[1] - 1) // 2)
    # orthogonal projection onto the null space of R, row by row: x − Rᵀ (R Rᵀ)⁻¹ R x
    return X - (X @ R.T) @ np.linalg.solve(R @ R.T, R)


def joint_ranges(types, limits) -> tuple[tuple[float, float], ...]:
    """Limits per joint (rad or m), with the defaults where the file gives none."""
    out = []
    for kind, lim in zip(types, limits or (None,) * len(types), strict=True):
        if lim is not None:
            out.append((float(lim[0]), float(lim[1])))
        elif kind == PRISMATIC:
            out.append(DEFAULT_PRISMATIC_RANGE)
        elif kind == REVOLUTE:
            out.append(DEFAULT_REVOLUTE_RANGE)
        else:
            raise ValueError(f"unknown joint type {kind!r}")
    return tuple(out)


def excursion_bounds(traj: FourierTrajectory) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper bounds (n,) on q_j(t) − q0_j over all t.

    Extremes on a grid of one period, widened by speed_bound × (grid step / 2):
    every instant lies within half a step of a grid point, and q moves no
    faster than the speed bound.
    """
    t, step = _period_grid(traj)
    q, _, _ = traj.evaluate(t)
    x = q - traj.q0[None, :]
    slack = traj.speed_bound() * step / 2.0
    return x.min(axis=0) - slack, x.max(axis=0) + slack


def _period_grid(traj: FourierTrajectory) -> tuple[np.ndarray, float]:
    """One period of ``traj`` on POINTS_PER_HARMONIC_PERIOD points per period of its highest harmonic
    (at least 4 harmonics' worth), and the grid step."""
    points = POINTS_PER_HARMONIC_PERIOD * max(traj.harmonics, 4)
    period = 1.0 / traj.base_frequency
    return np.arange(points) * (period / points), period / points


def rate_bounds(traj: FourierTrajectory) -> tuple[np.ndarray, np.ndarray]:
    """Upper bounds (n,) on max |q̇_j(t)| and max |q̈_j(t)| over all t.

    Extremes on a grid of one period, widened by the bound on the next derivative × (grid step / 2).
    """
    t, step = _period_grid(traj)
    _, dq, ddq = traj.evaluate(t)
    speed = np.abs(dq).max(axis=0) + traj.derivative_bound(2) * step / 2.0
    accel = np.abs(ddq).max(axis=0) + traj.derivative_bound(3) * step / 2.0
    return speed, accel


def within_rates(traj: FourierTrajectory, max_velocity=None, max_acceleration=None, fraction: float = 1.0) -> FourierTrajectory:
    """``traj`` with each joint's coefficients scaled by s_j ≤ 1 so that the bounds of :func:`rate_bounds`
    stay within ``fraction`` × the limits (None entries, or None lists: no limit on that joint)."""
    n = traj.q0.size
    speed, accel = rate_bounds(traj)
    scale = np.ones(n)
    for limits, bound in ((max_velocity, speed), (max_acceleration, accel)):
        for j, lim in enumerate(limits or (None,) * n):
            if lim is not None and bound[j] > 0:
                scale[j] = min(scale[j], fraction * float(lim) / bound[j])
    if np.all(scale == 1.0):
        return traj
    return FourierTrajectory(traj.base_frequency, traj.q0, traj.a * scale[:, None], traj.b * scale[:, None])


def fourier_excitation(
    ranges,
    harmonics: int,
    base_frequency: float,
    rng: np.random.Generator,
    margin: float = LIMIT_MARGIN,
    max_velocity=None,
    max_acceleration=None,
) -> FourierTrajectory:
    """Random Fourier excitation (Swevers et al. 1997) that stays inside ``ranges``.

    Coefficients a_jl, b_jl are drawn standard normal, then every joint is
    scaled and centred so that the bound of :func:`excursion_bounds` fills the
    central ``1 − 2·margin`` of the joint's range [lo, hi].  Joints with a velocity or acceleration
    limit (SI, per joint, None for none) are then slowed by :func:`within_rates` to ``1 − margin``
    of their limits.
    """
    ranges = np.asarray(ranges, dtype=float).reshape(-1, 2)
    n = ranges.shape[0]
    if harmonics < 1:
        raise ValueError(f"harmonics must be at least 1, got {harmonics}")
    if not base_frequency > 0:
        raise ValueError(f"base frequency must be positive, got {base_frequency}")
    if not 0 <= margin < 0.5:
        raise ValueError(f"margin must be in [0, 0.5), got {margin}")
    a = rng.standard_normal((n, harmonics))
    b = rng.standard_normal((n, harmonics))
    raw = FourierTrajectory(float(base_frequency), np.zeros(n), a, b)
    lo_x, hi_x = excursion_bounds(raw)
    lo, hi = ranges[:, 0], ranges[:, 1]
    half = (hi - lo) / 2.0 * (1.0 - 2.0 * margin)
    scale = 2.0 * half / (hi_x - lo_x)
    q0 = (lo + hi) / 2.0 - scale * (hi_x + lo_x) / 2.0
    traj = FourierTrajectory(float(base_frequency), q0, a * scale[:, None], b * scale[:, None])
    return within_rates(traj, max_velocity, max_acceleration, 1.0 - margin)
