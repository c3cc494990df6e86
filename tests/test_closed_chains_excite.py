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


def test_a_coupling_reuses_a_recent_closure_of_the_same_states_only(rrr):
    model = rrr.coupling.model
    centre = starts.loop_centre(model, _limits(rrr))
    t = np.linspace(0.0, 10.0, 40, endpoint=False)
    qa = centre + 0.05 * np.sin(np.outer(t, [0.6, 1.1, 1.7]))
    qd, qdd = np.ones_like(qa) * 0.1, np.ones_like(qa) * 0.2
    cold = rrr.coupling.tree_states(qa, qd, qdd)  # the first call: from the reference
    again = rrr.coupling.tree_states(qa, qd, qdd)
    for x, y in zip(cold, again, strict=True):
        assert np.array_equal(x, y)
    again[3][:] = 0.0  # a caller that changes what it got does not change the coupling's memory
    assert np.array_equal(rrr.coupling.tree_states(qa, qd, qdd)[3], cold[3])
    step = qa + 1e-6  # a near state closes from the reference, as on a first call
    fresh_q, _ = model.close_from_reference(step)
    assert np.array_equal(rrr.coupling.tree_states(step, qd, qdd)[0], fresh_q)


def _limits(chain):
    from minparam_cli.experiment.excite import constraints as cons

    lo = np.array([chain.limits[j][0] for j in chain.coupling.coordinates])
    hi = np.array([chain.limits[j][1] for j in chain.coupling.coordinates])
    none = np.full(len(lo), np.nan)
    return cons.Limits(lower=lo, upper=hi, velocity=none, acceleration=none, effort=none, margin=0.1)


@pytest.mark.parametrize("rotor", [False, True])
def test_the_gradient_of_a_closed_chain_with_friction_matches_finite_differences(rotor):
    """The Delta robot with viscous friction (and rotor inertia) on every joint of its tree, passive ones
    included: the criterion's derivatives of those columns go through the coupling (an IndexError before:
    joint k of the tree indexed the 3 coordinates). A passive joint's q̈ carries the loops' drift, quadratic
    in q̇: its rotor column's q̇-derivative too (missed by the first version of this change)."""
    desc, chain = load_chain("robots/delta.yaml", DeriveOptions(friction=("viscous",), rotor_inertia=rotor), loops=True)
    delta = with_loops(desc, chain)
    kept = derive_qr(delta, seed=0).kept
    model = delta.coupling.model
    centre = np.asarray(model.reference, dtype=float)[list(model.actuated)]
    Bq, Bv, Ba = basis(np.linspace(0, 10, 48, endpoint=False), 0.1, 3)
    rng = np.random.default_rng(3)
    X = np.zeros((3, 7))
    X[:, 0] = centre
    X[:, 1:] = 0.03 * rng.standard_normal((3, 6))

    def f(X):
        return criterion_value(base_regressor(delta, kept, Bq @ X.T, Bv @ X.T, Ba @ X.T), "cond")

    s = sensitivities(delta, kept, Bq @ X.T, Bv @ X.T, Ba @ X.T, "cond")
    grad = s.dq.T @ Bq + s.ddq_v.T @ Bv + s.ddq_a.T @ Ba
    for k in range(3):
        E = np.zeros_like(X)
        E[:, 1:] = rng.standard_normal((3, 6))
        h = 1e-7  # κ bends sharply here: at 1e-6 a central difference is still 7e-4 off
        fd = (f(X + h * E) - f(X - h * E)) / (2 * h)
        assert np.sum(grad * E) == pytest.approx(fd, rel=1e-4), k
    # the q̇ part alone: the rates at the grid moved, the positions and accelerations held
    qs, vs, acc = Bq @ X.T, Bv @ X.T, Ba @ X.T
    V = rng.standard_normal(vs.shape)

    def fv(v):
        return criterion_value(base_regressor(delta, kept, qs, v, acc), "cond")

    fd = (fv(vs + 1e-7 * V) - fv(vs - 1e-7 * V)) / 2e-7
    assert np.sum(s.ddq_v * V) == pytest.approx(fd, rel=1e-4)


def test_a_start_outside_the_workspace_is_moved_inside_it_and_shrunk(rrr):
    from minparam_cli.experiment.excite.design import ExciteOptions
    from minparam_cli.experiment.trajectory import FourierTrajectory

    model = rrr.coupling.model
    limits = _limits(rrr)
    t = np.linspace(0.0, 10.0, 80, endpoint=False)
    start = starts.random_start(limits, ExciteOptions(), np.random.default_rng(0))
    assert not starts.on_loops(model, start.evaluate(t)[0]).all()  # drawn in the joints' box: mostly outside
    a = list(model.actuated)
    lo, hi = (np.array([rrr.limits[j][k] for j in a]) for k in (0, 1))
    centre = (lo + (hi - lo) * np.random.default_rng(0).random((400, 3)))[279]  # closes (the test above)
    moved = starts.closing_start(model, start, limits, centre, t)
    assert isinstance(moved, FourierTrajectory) and np.array_equal(moved.q0, centre)
    assert starts.on_loops(model, moved.evaluate(t)[0], starts.START_CONDITION).all()
    assert 0 < np.abs(moved.a).max() < np.abs(start.a).max()  # shrunk, not stopped


def test_excite_refuses_loops_that_close_in_different_assembly_modes():
    """The 3-RRR's reference lies outside its joints' ranges: continued from it, the loops close in other
    assembly modes from one sample of a motion to the next (passive joints jump), so no design is
    offered (before: a one-line failure, the random starts outside the workspace): one line, exit 2."""
    from typer.testing import CliRunner

    from minparam_cli.cli.app import app

    r = CliRunner().invoke(app, ["excite", "robots/planar_3rrr.yaml", "--seed", "0", "--starts", "1",
                                 "--max-iterations", "5", "--harmonics", "3"])
    assert r.exit_code == 2, r.output
    errors = [line for line in r.output.splitlines() if line.startswith("minparam: error:")]
    assert len(errors) == 1 and "Traceback" not in r.output
    assert "different assembly modes" in errors[0] and "reference configuration" in errors[0]


def test_no_standing_position_inside_the_loops_is_one_line(rrr):
    """Joint ranges (less the margin) where the loops close nowhere: no standing position to design about."""
    from minparam_cli.errors import InputError

    limits = _limits(rrr)
    far = np.array([3.0, -1.1, -5.3])  # the corner of the 3-RRR's box: the loops do not close near it
    tight = type(limits)(lower=far - 1e-3, upper=far + 1e-3, velocity=limits.velocity, acceleration=limits.acceleration,
                         effort=limits.effort, margin=limits.margin)
    with pytest.raises(InputError, match="the loops close at none of 513 positions"):
        starts.loop_centre(rrr.coupling.model, tight)


def test_a_standing_position_that_does_not_close_is_one_line(rrr):
    """closing_start about a position where the loops do not close: shrinking cannot help, one line."""
    from minparam_cli.errors import InputError
    from minparam_cli.experiment.excite.design import ExciteOptions

    limits = _limits(rrr)
    t = np.linspace(0.0, 10.0, 80, endpoint=False)
    start = starts.random_start(limits, ExciteOptions(), np.random.default_rng(0))
    lo, hi = limits.shrunk_range()
    far = lo + 0.01 * (hi - lo)  # inside the ranges less the margin, where the loops do not close
    assert not starts.on_loops(rrr.coupling.model, far[None, :]).any()
    with pytest.raises(InputError, match="no motion about the standing position .* keeps the loops closed"):
        starts.closing_start(rrr.coupling.model, start, limits, far, t)


def test_excite_designs_the_delta_robot():
    """The Delta robot (3 actuated, 15 joints in its tree) took over 150 s without ending before; its design
    now lowers the criterion, and every output sample closes in one assembly mode."""
    import warnings

    import minparam

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # no velocity limits in the file: a note
        res = minparam.excite("robots/delta.yaml", seed=1, starts=2, max_iterations=15, harmonics=3)
    d = res.to_dict()
    assert all(s["end"] <= s["start"] for s in d["starts"])
    assert min(s["end"] for s in d["starts"]) < min(s["start"] for s in d["starts"])
    desc, chain = load_chain("robots/delta.yaml", DeriveOptions(), loops=True)
    model = with_loops(desc, chain).coupling.model
    assert starts.on_loops(model, res.q).all()
    assert starts.mode_jumps(model, res.q) == 0
