"""SLSQP in rounds with a step bound: the design's optimiser when collision shapes or closed loops constrain it.

SLSQP has no trust region: its first step (identity Hessian) can cross a whole joint range, and with the
collision distances, which are far from linear, it then lands deep inside an overlap that the linearised
constraint did not foresee, and rarely finds its way out.  Here each round runs at most ROUND_ITERATIONS
SLSQP iterations with the coefficients bounded to x_r ± ρ (x_r: where the round starts; ρ: STEP_FRACTION of
the joint's margin-shrunk range over 1 + 2H for q0_j, the same amplitude for a_jl and b_jl, i.e. times
ω·l: no joint moves by more than STEP_FRACTION of its range in a round).  A round
whose end meets every constraint on the grid (``feasible``) and lowers the criterion is kept and the next
starts there (with ρ doubled, up to MAX_SCALE·ρ, when the round ended on the bound); otherwise ρ is halved
and the round repeated from x_r.  The rounds share the iteration budget.  A closed chain's loops close only
inside its workspace, which SLSQP's first steps leave as easily: a round that tries a state where they do
not close is refused the same way.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

ROUND_ITERATIONS = 15
STEP_FRACTION = 0.05
MIN_STEP_FRACTION = 0.002  # below this the rounds stop
MAX_SCALE = 4.0  # the bound grows (doubles) after a kept round that reached it, up to this times ρ


@dataclass(frozen=True)
class RoundsResult:
    x: np.ndarray
    nit: int
    message: str


def step_bound(span: np.ndarray, harmonics: int, base_frequency: float) -> np.ndarray:
    """ρ for x = X.ravel() (rows (q0_j, a_j1..a_jH, b_j1..b_jH)): STEP_FRACTION·span_j / (1 + 2H), times ω·l
    for a, b, so that no joint's motion changes by more than STEP_FRACTION of its range in a round."""
    wl = 2.0 * np.pi * base_frequency * np.arange(1, harmonics + 1)
    per = np.concatenate([[1.0], wl, wl]) / (1 + 2 * harmonics)
    return (STEP_FRACTION * np.asarray(span, dtype=float)[:, None] * per[None, :]).ravel()


def minimize_in_rounds(fun, x0: np.ndarray, constraints, feasible, radius: np.ndarray, max_iterations: int,
                       callback=None, recoverable: tuple[type[BaseException], ...] = ()) -> RoundsResult:
    """The rounds of the module docstring from a grid-feasible x0; ``fun(x)`` -> (value, gradient).
    ``recoverable``: errors of ``fun`` or the constraints at a point (a closed chain's loops that do not
    close there) that refuse the round, as a round ending outside the constraints does."""
    from scipy.optimize import minimize

    x, value, used, scale, message = x0, fun(x0)[0], 0, 1.0, "no round run"
    while used < max_iterations and scale * STEP_FRACTION >= MIN_STEP_FRACTION:
        rho = scale * radius
        try:
            res = minimize(fun, x, jac=True, method="SLSQP", bounds=list(zip(x - rho, x + rho, strict=True)),
                           constraints=constraints, callback=callback,
                           options={"maxiter": min(ROUND_ITERATIONS, max_iterations - used), "ftol": 1e-7})
            end = np.asarray(res.x)
            better = feasible(end) and fun(end)[0] < value
        except recoverable as e:
            used += 1
            scale /= 2.0
            message = f"{e} (round refused: step bound halved)"
            continue
        used += max(int(res.nit), 1)
        if better:
            start, x, value, message = x, end, fun(end)[0], str(res.message)
            at_bound = bool(np.any(np.abs(end - start) >= rho * (1 - 1e-6)))
            if res.status == 0 and not at_bound:
                break  # converged away from the step bound: a local optimum
            if at_bound:
                scale = min(2.0 * scale, MAX_SCALE)
        else:
            scale /= 2.0
            message = f"{res.message} (round refused: step bound halved)"
    return RoundsResult(x, used, message)
