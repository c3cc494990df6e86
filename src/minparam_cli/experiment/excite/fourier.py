"""Swevers' finite Fourier series as a linear map of its coefficients, and the rest conditions.

Joint j follows (Swevers et al. 1997; the same series as ``identify.trajectory``)

    q_j(t)  = q0_j + Σ_{l=1..H}  a_jl/(ω l) sin(ω l t) − b_jl/(ω l) cos(ω l t)
    q̇_j(t)  =        Σ_{l=1..H}  a_jl cos(ω l t) + b_jl sin(ω l t)
    q̈_j(t)  =        Σ_{l=1..H} −a_jl ω l sin(ω l t) + b_jl ω l cos(ω l t)

with ω = 2π f_base.  Each line is linear in the joint's coefficient row
x_j = (q0_j, a_j1..a_jH, b_j1..b_jH), so for sample times t (N,)

    q = B_q(t) Xᵀ,   q̇ = B_v(t) Xᵀ,   q̈ = B_a(t) Xᵀ,     X = (x_1; …; x_n)  (n, 1 + 2H),

with the (N, 1 + 2H) basis matrices of :func:`basis`.  These are the exact
derivatives: the optimiser's gradients and the linear limit constraints use
them directly.

Start and end at rest.  The series is periodic, so q, q̇, q̈ at t = 0 equal
their values at t = k/f_base.  Two linear conditions per joint,

    q̇_j(0) = Σ_l a_jl = 0,          q̈_j(0) = ω Σ_l l b_jl = 0,

put every period boundary at rest (q̇ = q̈ = 0).  This is the role the
added fifth-order polynomial plays in Swevers' and Park's formulations; as
equality constraints on the coefficients the motion stays one Fourier series
(periodic, so periods can be repeated and averaged, and ``simulate`` and a
controller regenerate it from the same coefficients), and it needs H ≥ 2.
"""

from __future__ import annotations

import numpy as np

from minparam_cli.experiment.trajectory import FourierTrajectory


def basis(t, base_frequency: float, harmonics: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """B_q, B_v, B_a (N, 1 + 2H) at times t: q_j = B_q @ x_j and so on (module docstring)."""
    t = np.asarray(t, dtype=float).reshape(-1)
    w = 2.0 * np.pi * base_frequency * np.arange(1, harmonics + 1)
    ph = t[:, None] * w[None, :]
    s, c = np.sin(ph), np.cos(ph)
    N = t.size
    one, zero = np.ones((N, 1)), np.zeros((N, 1))
    Bq = np.hstack([one, s / w, -c / w])
    Bv = np.hstack([zero, c, s])
    Ba = np.hstack([zero, -s * w, c * w])
    return Bq, Bv, Ba


def to_trajectory(X: np.ndarray, base_frequency: float) -> FourierTrajectory:
    """The coefficient matrix X (n, 1 + 2H) as a FourierTrajectory."""
    X = np.asarray(X, dtype=float)
    H = (X.shape[1] - 1) // 2
    return FourierTrajectory(float(base_frequency), X[:, 0].copy(), X[:, 1:1 + H].copy(), X[:, 1 + H:].copy())


def from_trajectory(traj: FourierTrajectory) -> np.ndarray:
    """X (n, 1 + 2H) of a FourierTrajectory."""
    return np.hstack([traj.q0[:, None], traj.a, traj.b])


def rest_rows(harmonics: int) -> np.ndarray:
    """(2, 1 + 2H): row 0 · x_j = q̇_j(0), row 1 · x_j = q̈_j(0)/ω (module docstring)."""
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
