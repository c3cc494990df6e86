"""excite on closed chains whose workspace is a small part of the actuated joints' box (a planar 3-RRR
parallel robot): starts moved inside it, the loops' closure continued from a neighbour where the straight
path from the reference meets a singularity, the coupled friction columns' gradient, and the closures a
coupling reuses."""

from __future__ import annotations

import numpy as np
import pytest

from minparam_cli.base.qr import derive_qr
from minparam_cli.experiment.excite import starts
from minparam_cli.experiment.excite.criterion import criterion_value, sensitivities
from minparam_cli.experiment.excite.design import base_regressor
from minparam_cli.experiment.trajectory import basis
from minparam_cli.loops.coupling import with_loops
from minparam_cli.loops.model import CLOSED_RTOL
from minparam_cli.robot import DeriveOptions, load_chain


@pytest.fixture(scope="module")
def rrr():
    desc, chain = load_chain("robots/planar_3rrr.yaml", DeriveOptions(), loops=True)
    return with_loops(desc, chain)


def _closed(model, err):
    return err < CLOSED_RTOL * model.chain.length_scale


def test_a_state_whose_straight_path_meets_a_singularity_closes_from_its_neighbour(rrr):
    """(Draws 397 and 279 of 400 uniform ones in the 3-RRR's box, seed 0: the straight path closes 31 of the
    400, the retry 2 more.)"""
    model = rrr.coupling.model
    a = list(model.actuated)
    lo, hi = (np.array([rrr.limits[j][k] for j in a]) for k in (0, 1))
    draws = lo + (hi - lo) * np.random.default_rng(0).random((400, 3))
    _, straight = model.continue_from(np.repeat(model.reference[None, :], 400, axis=0), draws, 8)
    assert not _closed(model, straight)[397] and _closed(model, straight)[279]
    q, err = model.close_from_reference(draws)
    assert _closed(model, err)[397] and _closed(model, err).sum() == _closed(model, straight).sum() + 2
    assert np.abs(model.residual(q[397:398])).max() < CLOSED_RTOL * model.chain.length_scale
    assert np.array_equal(q[:, a], draws)
    assert np.abs(q[397] - q[279]).max() < 1.0  # continued from its nearest neighbour: the same assembly, nearby


def test_a_coupling_reuses_its_recent_closures_to_the_closure_tolerance(rrr):
    model = rrr.coupling.model
    centre = starts.loop_centre(model, _limits(rrr))
    t = np.linspace(0.0, 10.0, 40, endpoint=False)
    qa = centre + 0.05 * np.sin(np.outer(t, [0.6, 1.1, 1.7]))
    qd, qdd = np.ones_like(qa) * 0.1, np.ones_like(qa) * 0.2
    cold = rrr.coupling.tree_states(qa, qd, qdd)  # the first call: from the reference
    again = rrr.coupling.tree_states(qa, qd, qdd)
    for x, y in zip(cold, again, strict=True):
        assert np.array_equal(x, y)
    step = qa + 1e-3 * np.cos(np.outer(t, [0.3, 0.5, 0.7]))
    warm = rrr.coupling.tree_states(step, qd, qdd)  # Newton from the recent closure
    fresh_q, fresh_err = model.close_from_reference(step)
    assert _closed(model, fresh_err).all()
    assert np.allclose(warm[0], fresh_q, rtol=0, atol=1e-9)
    G, _ = model.tangent(fresh_q)
    assert np.allclose(warm[3], G, rtol=0, atol=1e-8)


def _limits(chain):
    from minparam_cli.experiment.excite import constraints as cons

    lo = np.array([chain.limits[j][0] for j in chain.coupling.coordinates])
    hi = np.array([chain.limits[j][1] for j in chain.coupling.coordinates])
    none = np.full(len(lo), np.nan)
    return cons.Limits(lower=lo, upper=hi, velocity=none, acceleration=none, effort=none, margin=0.1)


def test_the_gradient_of_a_closed_chain_with_friction_matches_finite_differences(rrr):
    """The 3-RRR's viscous and Coulomb columns sit on its actuated joints 1, 3 and 5 of the tree (the
    coordinates 1, 2, 3): the criterion's derivatives go through the coupling (an IndexError before)."""
    kept = derive_qr(rrr, seed=0).kept
    centre = starts.loop_centre(rrr.coupling.model, _limits(rrr))
    Bq, Bv, Ba = basis(np.linspace(0, 10, 48, endpoint=False), 0.1, 3)
    rng = np.random.default_rng(3)
    X = np.zeros((3, 7))
    X[:, 0] = centre
    X[:, 1:] = 0.03 * rng.standard_normal((3, 6))

    def f(X):
        return criterion_value(base_regressor(rrr, kept, Bq @ X.T, Bv @ X.T, Ba @ X.T), "cond")

    s = sensitivities(rrr, kept, Bq @ X.T, Bv @ X.T, Ba @ X.T, "cond")
    grad = s.dq.T @ Bq + s.ddq_v.T @ Bv + s.ddq_a.T @ Ba
    for k in range(3):
        E = np.zeros_like(X)
        E[:, 1:] = rng.standard_normal((3, 6))
        # a step that moves no q̇ across 0 (sign q̇, the Coulomb column, jumps there)
        h = 0.01 * np.abs(Bv @ X.T).min() / np.abs(Bv @ E.T).max()
        fd = (f(X + h * E) - f(X - h * E)) / (2 * h)
        assert np.sum(grad * E) == pytest.approx(fd, rel=1e-3), k


def test_excite_designs_a_parallel_platform_inside_its_workspace(rrr):
    """The 3-RRR's random starts leave its workspace (before: the design failed in one line): moved to a
    standing position inside it and shrunk, each start closes, and the rounds lower the criterion."""
    import warnings

    import minparam

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # no velocity limits in the file: a note
        res = minparam.excite("robots/planar_3rrr.yaml", seed=1, starts=2, max_iterations=25, harmonics=3)
    d = res.to_dict()
    assert all(s["end"] <= s["start"] for s in d["starts"])
    assert min(s["end"] for s in d["starts"]) < min(s["start"] for s in d["starts"])
    model = rrr.coupling.model
    assert starts.on_loops(model, res.q).all()  # every output sample: closed, passive limits, away from singularities
    lo, hi = _limits(rrr).lower, _limits(rrr).upper
    assert np.all(res.q >= lo) and np.all(res.q <= hi)
