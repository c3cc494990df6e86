"""Finite Fourier series excitation trajectories (Swevers et al. 1997).

Swevers, Ganseman, Tükel, De Schutter and Van Brussel, "Optimal robot
excitation and identification", IEEE Trans. Robotics and Automation 13(5),
1997: joint j follows

    q_j(t)   = q0_j + Σ_{l=1..H}  a_jl/(ω_f l) sin(ω_f l t) − b_jl/(ω_f l) cos(ω_f l t)
    q̇_j(t)   =        Σ_{l=1..H}  a_jl cos(ω_f l t) + b_jl sin(ω_f l t)
    q̈_j(t)   =        Σ_{l=1..H} −a_jl ω_f l sin(ω_f l t) + b_jl ω_f l cos(ω_f l t)

with ω_f = 2π f_base.  The motion is periodic with period 1/f_base, so its
extremes over all time are its extremes over one period.

Here the coefficients are random (seeded) and then scaled, joint by joint,
so that the whole motion stays inside the joint range shrunk by a margin.
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

    def evaluate(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Exact q, q̇, q̈ at times t (N,), each (N, n), from Swevers' series."""
        t = np.asarray(t, dtype=float).reshape(-1)
        w_l = self.omega * np.arange(1, self.harmonics + 1)  # (H,)
        phase = t[:, None] * w_l[None, :]  # (N, H)
        s, c = np.sin(phase), np.cos(phase)
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


def joint_ranges(types, limits) -> tuple[tuple[float, float], ...]:
    """Limits per joint (rad or m), with the defaults where the file gives none."""
    out = []
    for kind, lim in zip(types, limits or (None,) * len(types)):
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
