"""Starting points of the design: simulate's random series, moved and shrunk into torque and box limits.

``random_start`` draws a series exactly as ``simulate`` draws its excitation
(``experiment.trajectory.fourier_excitation``), projected onto the rest
conditions when asked and scaled into the all-instant limits.  With torque
limits, a box or collision shapes, ``feasible_centre`` picks a standing position that meets
them (the best of STATIC_SAMPLES fixed-seed positions; none: the limits are
refused as infeasible), and ``feasible_start`` moves a series there and
shrinks it until it meets them on the grid, so that SLSQP starts feasible.

A closed chain's actuated joints reach only part of their limits' box (a parallel platform's
workspace is a small part of it): ``closing_start`` moves a series that leaves it to a standing
position inside it (``loop_centre``) and shrinks it until the loops close, within the passive joints'
limits and away from a singularity of the loops, at every grid time; the standing positions
``feasible_centre`` tries are then states of the loops' manifold; ``refuse_mode_jumps`` refuses a
motion along which they close in different assembly modes.
"""

from __future__ import annotations

import numpy as np

from minparam_cli.chain import Chain
from minparam_cli.errors import InputError
from minparam_cli.experiment.excite import constraints as cons
from minparam_cli.experiment.trajectory import FourierTrajectory, fourier_excitation, project_to_rest


def random_start(limits: cons.Limits, options, rng: np.random.Generator) -> FourierTrajectory:
    """simulate's random series for ``options`` (harmonics, base_frequency, rest), inside ``limits``."""
    vel = [None if not np.isfinite(v) else float(v) for v in limits.velocity]
    acc = [None if not np.isfinite(v) else float(v) for v in limits.acceleration]
    ranges = np.column_stack([limits.lower, limits.upper])
    traj = fourier_excitation(ranges, options.harmonics, options.base_frequency, rng, limits.margin, vel, acc)
    if options.rest:
        traj = FourierTrajectory.from_matrix(project_to_rest(traj.matrix()), options.base_frequency)
    return cons.scaled(traj, cons.rigorous_scale(traj, limits))


STATIC_SAMPLES = 4096
COLLISION_SAMPLES = 1024  # --collisions: the positions tried (MuJoCo's distances cost ~0.5 ms each)
START_SHRINK = 0.7  # a start that breaks a torque or box limit is shrunk by this factor until it does not
START_SHRINK_STEPS = 20


def feasible_centre(chain: Chain, limits: cons.Limits, phi) -> np.ndarray:
    """A position that meets the torque limits standing still (margin included) and puts the point in
    the box: the best of STATIC_SAMPLES positions spread over the shrunk ranges (fixed-seed sampler,
    the centre first).  None there is: the limits are refused as infeasible (a necessary condition)."""
    from minparam_cli.experiment.simulate import rigid_torque

    lo, hi = limits.shrunk_range()
    model = loops_of(chain)
    if model is None:
        u = np.random.default_rng(0).uniform(size=(STATIC_SAMPLES, limits.n))
        q = np.vstack([(lo + hi) / 2.0, lo + u * (hi - lo)])
    else:  # states of the loops' manifold: the loops close at every position tried
        q = np.vstack([loop_centre(model, limits)[None, :], loop_states(model, lo, hi, STATIC_SAMPLES)[0]])
    badness = np.zeros(q.shape[0])
    if phi is not None:
        tau = np.abs(rigid_torque(chain, q, np.zeros_like(q), np.zeros_like(q), phi))
        e = limits.shrunk(limits.effort)
        has = np.isfinite(e)
        ratio = np.where(has, tau / np.where(has, e, 1.0), 0.0)
        worst = ratio.max(axis=1)
        if np.all(worst > 1.0):
            best = int(np.argmin(worst))
            j = int(np.argmax(ratio[best]))
            raise InputError(f"infeasible limits: standing still, joint {j + 1} needs at least {tau[best, j]:.4g} N·m (or N) "
                             f"against gravity in every position tried, above its effort limit less the margin ({e[j]:.4g})")
        badness = np.maximum(worst - 1.0, 0.0)
    if limits.box is not None:
        assert limits.point is not None  # the box comes with its point (api.excitation.prepare_excite)
        p = cons.box_point(chain, q, limits.point)
        with np.errstate(invalid="ignore"):
            out = np.nan_to_num(np.maximum(limits.box[:, 0] - p, 0.0)) + np.nan_to_num(np.maximum(p - limits.box[:, 1], 0.0))
        miss = out.sum(axis=1)
        if np.all(miss > 0):
            raise InputError("infeasible limits: the --box point lies outside the box in every position tried")
        badness = badness + 1e3 * miss
        # among the feasible positions, the one deepest inside the box
        depth = np.nan_to_num(np.minimum(p - limits.box[:, 0], limits.box[:, 1] - p), nan=np.inf).min(axis=1)
        badness = badness - 1e-3 * np.where(np.isfinite(depth), depth, 0.0)
    if limits.collisions is not None:  # among the first COLLISION_SAMPLES: shapes apart, the farthest apart
        q, badness = q[:COLLISION_SAMPLES], badness[:COLLISION_SAMPLES]
        gap = limits.collisions.distances(cons.joint_states(chain, q))[0].min(axis=1)
        if np.all(gap < 0):
            raise InputError("infeasible limits: --collisions: the collision shapes overlap in every position tried")
        badness = badness + 1e3 * np.maximum(limits.collisions.clearance - gap, 0.0) - 1e-3 * gap
    return q[int(np.argmin(badness))]


def feasible_start(chain, traj: FourierTrajectory, limits: cons.Limits, phi, centre, t) -> FourierTrajectory:
    """``traj`` moved to ``centre`` and shrunk until it meets the torque and box limits at times t."""
    traj = FourierTrajectory(traj.base_frequency, np.asarray(centre, dtype=float), traj.a, traj.b)
    traj = cons.scaled(traj, cons.rigorous_scale(traj, limits))
    for _ in range(START_SHRINK_STEPS):
        if not cons.nonlinear_violations(chain, traj, limits, phi, t, shrunk=True):
            break
        traj = cons.scaled(traj, START_SHRINK)
    return traj


def loops_of(chain: Chain):
    """The loops' model (``loops.model.ClosedModel``) when ``chain`` is a closed chain, else None."""
    from minparam_cli.loops.coupling import ClosedCoupling

    return chain.coupling.model if isinstance(chain.coupling, ClosedCoupling) else None


CENTRE_SAMPLES = 512  # states a closed chain's standing position is chosen from


def loop_states(model, lo, hi, count: int) -> tuple[np.ndarray, np.ndarray]:
    """States of the loops' manifold with the actuated joints in the box [lo, hi]: its centre and ``count``
    uniform draws (fixed seed), those where the loops close (``on_loops``), as (actuated coordinates,
    every joint's coordinates)."""
    from minparam_cli.loops.sample import assemble

    u = np.random.default_rng(0).uniform(size=(count, len(lo)))
    qa = np.vstack([(lo + hi) / 2.0, lo + u * (hi - lo)])
    q, ok = assemble(model, qa)
    return qa[ok], q[ok]


def loop_centre(model, limits: cons.Limits) -> np.ndarray:
    """Actuated coordinates of a standing position well inside the loops' workspace and the joints' ranges
    less the margin: of ``loop_states``, the one whose joints, passive ones included, are farthest from
    their limits (relative to each range) and whose loops are farthest from a singularity (σ_min / σ_max
    of the closure's passive Jacobian), by the smaller of the two; an InputError when none closes."""
    from minparam_cli.loops.sample import passive_extremes

    lo, hi = limits.shrunk_range()
    qa, q = loop_states(model, lo, hi, CENTRE_SAMPLES)
    if not len(qa):
        raise InputError(f"{model.chain.source}: the loops close at none of {CENTRE_SAMPLES + 1} positions of the actuated "
                         "joints inside their ranges less the margin: no standing position to design about")
    score = np.full(len(q), 0.5)
    for j, lim in enumerate(model.chain.limits or ()):
        if lim is not None and lim[1] > lim[0]:
            score = np.minimum(score, np.minimum(q[:, j] - lim[0], lim[1] - q[:, j]) / (lim[1] - lim[0]))
    if model.closure_rank:
        low, top = passive_extremes(model, q)
        score = np.minimum(score, low / top)
    return qa[int(np.argmax(score))]


def on_loops(model, q_actuated: np.ndarray, min_ratio: float = 0.0) -> np.ndarray:
    """(N,) whether the loops close at each row of actuated coordinates, with every passive joint within
    its limits and away from a singularity of the loops (``loops.sample.assemble``; with ``min_ratio``,
    σ_min / σ_max of the closure's passive Jacobian at least that)."""
    from minparam_cli.loops.sample import assemble

    return assemble(model, np.atleast_2d(q_actuated), min_ratio)[1]


CLOSING_SHRINK_STEPS = 40  # START_SHRINK ** 40: 6e-7 of the series' first size
# a start's states keep this σ_min / σ_max of the loops' passive Jacobian: well inside the workspace, where a
# rounding of the series cannot tip a state past its edge (the design's checks only ask that the loops close)
START_CONDITION = 1e-3


def closing_start(model, traj: FourierTrajectory, limits: cons.Limits, centre, t) -> FourierTrajectory:
    """``traj`` moved to ``centre``, scaled into the limits and shrunk about it until the loops of ``model``
    close at every time of t (``on_loops``); an InputError when even the smallest series leaves them."""
    traj = FourierTrajectory(traj.base_frequency, np.asarray(centre, dtype=float), traj.a, traj.b)
    traj = cons.scaled(traj, cons.rigorous_scale(traj, limits))
    for _ in range(CLOSING_SHRINK_STEPS):
        if on_loops(model, traj.evaluate(t)[0], START_CONDITION).all():
            return traj
        traj = cons.scaled(traj, START_SHRINK)
    raise InputError(f"{model.chain.source}: no motion about the standing position {np.round(centre, 4).tolist()} keeps the "
                     "loops closed (within the passive joints' limits, away from a singularity of the loops)")


# between two samples of a motion (the dense check's times), a passive joint may move this much (rad, or this
# fraction of the robot's size) beyond what the loops' tangent predicts; more: the two states closed in
# different assembly modes (continuation from a reference far from the motion, docs/methods/closed_chains.md)
MODE_JUMP = 0.1


def mode_jumps(model, q_actuated: np.ndarray) -> int:
    """Steps between consecutive rows of ``q_actuated`` (a motion, densely sampled; the loops closed at
    each) where a passive joint jumps (``MODE_JUMP``)."""
    from minparam_cli.chain import REVOLUTE

    q, _ = model.close_from_reference(np.atleast_2d(q_actuated))
    G, _ = model.tangent_map(q)
    p = list(model.passive)
    miss = (np.diff(q, axis=0) - np.einsum("snf,sf->sn", G[:-1], np.diff(q_actuated, axis=0)))[:, p]
    revolute = np.array([model.chain.types[j] == REVOLUTE for j in p])
    miss[:, revolute] = (miss[:, revolute] + np.pi) % (2 * np.pi) - np.pi
    scale = np.where(revolute, 1.0, model.chain.length_scale)
    return int(np.sum(np.any(np.abs(miss) > MODE_JUMP * scale, axis=1)))


def refuse_mode_jumps(model, traj: FourierTrajectory, t) -> None:
    """An InputError when the loops close in different assembly modes along ``traj`` (at times t)."""
    count = mode_jumps(model, traj.evaluate(t)[0])
    if count:
        raise InputError(f"{model.chain.source}: along a start's motion the loops close in different assembly modes "
                         f"({count} of {len(t) - 1} steps jump): they are closed by continuation from the description's "
                         "reference configuration, which should lie in the workspace the robot moves in")
