"""States on the constraint manifold: random actuated coordinates, the loops closed by Newton on the
passive joints, then q̇ = G q̇_a and q̈ = G q̈_a + g (``model.ClosedModel.tangent``)."""

from __future__ import annotations

import numpy as np

from minparam_cli.chain import REVOLUTE
from minparam_cli.errors import ComputationError
from minparam_cli.loops.model import CLOSED_RTOL, ClosedModel

# the actuated coordinates are drawn within this much of the reference (rad; prismatic: of the robot's size)
SPREAD_REVOLUTE = 0.6
SPREAD_PRISMATIC = 0.15
# a state is refused where J_p is this badly conditioned (close to a singularity of the loops)
MAX_CONDITION = 1e7


def actuated_box(model: ClosedModel) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper bounds of the actuated coordinates the sampler draws from: the reference ± the
    spread, within the joints' limits."""
    chain = model.chain
    lo, hi = [], []
    for j in model.actuated:
        r = model.reference[j]
        s = SPREAD_REVOLUTE if chain.types[j] == REVOLUTE else SPREAD_PRISMATIC * chain.length_scale
        a, b = r - s, r + s
        lim = chain.limits[j] if chain.limits else None
        if lim is not None:
            a, b = max(a, lim[0]), min(b, lim[1])
        lo.append(a)
        hi.append(b)
    return np.array(lo), np.array(hi)


def within_limits(model: ClosedModel, q: np.ndarray) -> np.ndarray:
    """(N,) whether every joint, passive ones included, is within its limits."""
    ok = np.ones(len(q), dtype=bool)
    for j, lim in enumerate(model.chain.limits):
        if lim is not None:
            ok &= (q[:, j] >= lim[0]) & (q[:, j] <= lim[1])
    return ok


def passive_extremes(model: ClosedModel, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(σ_low, σ_max) (N,) of the loops' passive Jacobian at the configurations q (N, n): σ_low its
    closure_rank-th singular value (σ_max itself without closure equations); their ratio falls to 0 at a
    singularity of the loops."""
    J, _ = model.jacobian(q)
    sv = np.linalg.svd(J[:, :, list(model.passive)], compute_uv=False)
    top = sv[:, 0]
    return (sv[:, model.closure_rank - 1] if model.closure_rank else top), top


def assemble(model: ClosedModel, q_a: np.ndarray, min_ratio: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Configurations (N, n) with the actuated joints at ``q_a`` and the loops closed in the reference's
    assembly mode (continuation), and whether each one closed, within the limits and away from a singularity
    (σ_low / σ_max above 1 / MAX_CONDITION, and at least ``min_ratio``: ``passive_extremes``)."""
    q, err = model.close_from_reference(q_a)
    ok = (err < CLOSED_RTOL * model.chain.length_scale) & within_limits(model, q)
    if ok.any():
        low, top = passive_extremes(model, q)
        ok &= low > top / MAX_CONDITION
        if min_ratio > 0.0 and model.closure_rank:
            ok &= low >= min_ratio * top
    return q, ok


def manifold_states(model: ClosedModel, samples: int, seed: int):
    """(q, q̇, q̈) of every tree joint (samples, n), on the manifold, and the actuated rates (q̇_a, q̈_a)."""
    rng = np.random.default_rng(seed)
    lo, hi = actuated_box(model)
    found: list[np.ndarray] = []
    tries = 0
    while sum(len(x) for x in found) < samples:
        tries += 1
        if tries > 20:
            raise ComputationError(f"{model.chain.source}: could not place {samples} states on the loops' manifold near "
                                   "the reference (the loops do not close, or the limits exclude them)")
        q_a = lo + (hi - lo) * rng.random((2 * samples, len(lo)))
        q, ok = assemble(model, q_a)
        found.append(q[ok])
    q = np.concatenate(found)[:samples]
    f = len(model.actuated)
    qd_a, qdd_a = rng.standard_normal((samples, f)), rng.standard_normal((samples, f))
    G, _ = model.tangent(q)
    qd = np.einsum("snf,sf->sn", G, qd_a)
    _, g = model.tangent(q, qd)
    qdd = np.einsum("snf,sf->sn", G, qdd_a) + g
    return q, qd, qdd, G
