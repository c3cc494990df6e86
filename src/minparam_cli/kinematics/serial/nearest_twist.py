"""The control step at a singular position (Glazunov 1985): the nearest feasible twist and its joint rates.

The paper replaces the operator's twist dφ + ω dS by one reciprocal to the
screw(s) H the arm cannot move along: dφ is projected on the polar plane Q of
H through the tool point O_c (perpendicular to the moment of H about O_c),
dS on the plane P perpendicular to h.  Each part is then reciprocal to H on
its own, and the projection is the unique twist with that property that
minimises both |δφ| and |δS| (the paper's sense of "nearest").  Least squares
(nearest in |δw|² + |δv|²/L² over every feasible twist) and damped least
squares are computed beside it for comparison.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from minparam_cli.chain import Chain
from minparam_cli.errors import InputError
from minparam_cli.kinematics.serial.plucker import (
    ReciprocalScrew,
    ZERO_COMPONENT,
    column_scale,
    normalised_matrices,
    rows_at_point,
    to_nd,
)


@dataclass(frozen=True, eq=False)
class TwistSolution:
    """The operator's twist and the feasible twists that replace it, all at O_c."""

    requested: np.ndarray  # (6,)
    nearest: np.ndarray  # the paper's projection
    least_squares: np.ndarray
    damped: np.ndarray
    joint_rates: np.ndarray  # realise ``nearest``; held joints are exactly zero
    least_squares_rates: np.ndarray
    damped_rates: np.ndarray
    damping: float  # λ / σ_max
    reciprocity_residual: float  # max |h·v_O + h0·w| over the reciprocal screws
    reproduction_residual: float  # ‖J·rates - nearest‖ (weighted, dimensionless)


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def _span_basis(vectors: list[np.ndarray]) -> np.ndarray:
    """Orthonormal basis (3, m) of the span of unit-scale 3-vectors, zero parts ignored."""
    if not vectors:
        return np.zeros((3, 0))
    A = np.column_stack(vectors)
    U, s, _ = np.linalg.svd(A, full_matrices=False)
    return U[:, s > ZERO_COMPONENT]


def paper_projection(twist: np.ndarray, screws: tuple[ReciprocalScrew, ...]) -> np.ndarray:
    """Glazunov's nearest twist: dφ onto the polar plane(s) Q of H through O_c, dS onto the plane(s) P ⟂ h.

    With several reciprocal screws the angular part is projected onto the
    orthogonal complement of all their moments about O_c, the linear part onto
    that of all their axis vectors; the result is reciprocal to each H.
    """
    w, v = np.asarray(twist[:3], float), np.asarray(twist[3:], float)
    A = _span_basis([_unit(s.moment_at_tool) for s in screws if np.any(s.moment_at_tool != 0)])
    B = _span_basis([_unit(s.plucker[:3]) for s in screws if np.any(s.plucker[:3] != 0)])
    return np.concatenate([w - A @ (A.T @ w), v - B @ (B.T @ v)])


def reciprocal_product(twist_at_tool: np.ndarray, screw: ReciprocalScrew, c: np.ndarray) -> float:
    """h·v_O + h0·w for a twist given at O_c (v_O = v_c + r_c × w)."""
    w, v = twist_at_tool[:3], twist_at_tool[3:]
    vO = v + np.cross(c, w)
    return float(screw.plucker[:3] @ vO + screw.plucker[3:] @ w)


def twist_distances(requested: np.ndarray, other: np.ndarray, L: float) -> tuple[float, float, float]:
    """(|δw| rad/s, |δv| m/s at O_c, weighted sqrt(|δw|² + |δv|²/L²))."""
    dw = float(np.linalg.norm(requested[:3] - other[:3]))
    dv = float(np.linalg.norm(requested[3:] - other[3:]))
    return dw, dv, float(np.hypot(dw, dv / L))


def solve_twist(chain, J0, Jn, c, L, U, s, Vt, rank, kept, use_basis, screws, T, damping) -> TwistSolution:
    """The paper's twist and the rates of the kept joints, with least squares and damped least squares.

    J0: matrix (3); Jn: its normalised form with SVD (U, s, Vt) and numerical
    ``rank``; ``kept``: the columns not held; ``use_basis``: False for a
    redundant arm at full rank, where every twist is feasible and the rates
    are the minimum-norm ones.
    """
    Jc = rows_at_point(J0, c)
    cs = column_scale(chain, L)
    n = Jn.shape[1]
    if use_basis:
        nearest = paper_projection(T, screws)
        rates = np.zeros(n)
        sol, *_ = np.linalg.lstsq(Jn[:, kept], to_nd(nearest, L), rcond=None)
        rates[kept] = sol * cs[kept]
    else:  # redundant arm at full rank: every twist is feasible, minimum-norm rates
        nearest = T.copy()
        rates = (Vt[:rank].T @ ((U[:, :rank].T @ to_nd(T, L)) / s[:rank])) * cs
    residual = float(np.linalg.norm(to_nd(Jc @ rates - nearest, L)))
    recip = max((abs(reciprocal_product(nearest, h, c)) for h in screws), default=0.0)

    Tn = to_nd(T, L)
    ls_rates = (Vt[:rank].T @ ((U[:, :rank].T @ Tn) / s[:rank])) * cs
    lam = damping * s[0]
    k = s.size
    d_rates = (Vt[:k].T @ ((U[:, :k].T @ Tn) * s / (s**2 + lam**2))) * cs
    return TwistSolution(
        requested=T,
        nearest=nearest,
        least_squares=Jc @ ls_rates,
        damped=Jc @ d_rates,
        joint_rates=rates,
        least_squares_rates=ls_rates,
        damped_rates=d_rates,
        damping=damping,
        reciprocity_residual=recip,
        reproduction_residual=residual,
    )


# --- a seeded brute-force check of "nearest" ---------------------------------------------------


@dataclass(frozen=True)
class NearestCheck:
    """Random feasible twists compared with the returned ones (seeded)."""

    samples: int
    paper_set_closer: int  # twists in the paper's set closer in |δw| or |δv| than the projection
    full_set_closer_than_lsq: int  # feasible twists closer than least squares in the weighted metric
    full_set_closer_than_paper: int  # feasible twists closer than the projection in the weighted metric


def check_nearest(report, chain: Chain, rng: np.random.Generator, samples: int = 2000) -> NearestCheck:
    """Draw feasible twists around the answers and count those that are closer.

    Paper's set: twists with w ⟂ every moment of H about O_c and v ⟂ every h
    (drawn as projected random vectors).  Full set: J·rates of the kept joints
    (every twist reciprocal to H).  Candidates are scattered around the answers
    at several scales, so a closer twist, if any, would be found.
    """
    sol = report.twist
    if sol is None:
        raise InputError("check_nearest needs a report computed with a twist")
    L = report.length_scale
    T = sol.requested
    d_paper = twist_distances(T, sol.nearest, L)
    d_lsq = twist_distances(T, sol.least_squares, L)
    tol = 1e-12 * (1.0 + np.linalg.norm(to_nd(T, L)))
    scales = np.geomspace(1e-6, 1.0, 7) * (1.0 + np.linalg.norm(to_nd(T, L)))
    kept = [j for j in range(len(report.types)) if j not in report.held_joints]
    Jn = normalised_matrices(chain, report.plucker, report.tool_point, L)[:, kept]
    Tn = to_nd(T, L)
    x_lsq = np.linalg.lstsq(Jn, to_nd(sol.least_squares, L), rcond=None)[0]
    per = max(samples // (2 * scales.size), 1)
    paper_closer = full_lsq = full_paper = 0
    for scale in scales:
        raw = sol.nearest + scale * rng.standard_normal((per, 6))
        cand = np.array([paper_projection(x, report.reciprocal) for x in raw])
        dw = np.linalg.norm(cand[:, :3] - T[:3], axis=1)
        dv = np.linalg.norm(cand[:, 3:] - T[3:], axis=1)
        paper_closer += int(np.sum((dw < d_paper[0] - tol) | (dv < d_paper[1] - tol)))
        x = x_lsq + scale * rng.standard_normal((per, len(kept)))
        dist = np.linalg.norm(x @ Jn.T - Tn, axis=1)
        full_lsq += int(np.sum(dist < d_lsq[2] - tol))
        full_paper += int(np.sum(dist < d_paper[2] - tol))
    return NearestCheck(
        samples=per * scales.size * 2,
        paper_set_closer=paper_closer,
        full_set_closer_than_lsq=full_lsq,
        full_set_closer_than_paper=full_paper,
    )
