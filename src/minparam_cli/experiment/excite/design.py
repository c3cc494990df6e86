"""Design an excitation trajectory: seeded multi-start SLSQP on Swevers' Fourier coefficients.

Minimises the criterion of ``criterion`` (the base regressor's column-scaled
condition number by default) over X = (q0, a, b) of every joint, subject to
the limits of ``constraints`` on the grid of GRID_POINTS_PER_HARMONIC points
per period of the highest harmonic, and (``rest``) the two linear rest
conditions of ``trajectory``.  The optimiser is scipy.optimize's SLSQP (Kraft
1988): it takes the many linear limit constraints with their exact
Jacobians, the gradient of the criterion is semi-analytic (``criterion``),
and it needs no further dependency (with collision shapes it runs in step-bounded rounds, ``rounds``).

Starts: ``starts`` random series drawn exactly as ``simulate`` draws its
excitation (``experiment.trajectory.fourier_excitation``: standard normal
coefficients scaled into the margin-shrunk range and rate limits), one child
generator per start from the one seeded generator; with ``rest`` each start
is projected onto the rest conditions and scaled back into the limits.  The
starts race (``race``: after 40 and again after 100 iterations only the better half goes on).  The
best end point that passes the dense check wins, after its repair
(``constraints``), and the reported figures are computed on the output samples.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from minparam_cli.base.result import BaseSet
from minparam_cli.chain import Chain
from minparam_cli.errors import ComputationError, InputError
from minparam_cli.experiment.excite import constraints as cons
from minparam_cli.experiment.excite import race, rounds, starts
from minparam_cli.experiment.excite.criterion import CRITERIA, condition_number, criterion_value, sensitivities
from minparam_cli.experiment.trajectory import FourierTrajectory, basis, rest_rows
from minparam_cli.loops.coupling import LoopsNotClosed

GRID_POINTS_PER_HARMONIC = 16
BOX_GRID_POINTS_PER_HARMONIC = 64  # the box constraint is cheap (forward kinematics): a finer grid
# The optimiser keeps the point this far inside the --box (m); SQP ends can break a constraint by a hair,
# and an end point is accepted when it is at least half of this inside the box (and within the effort
# limits themselves) on the grid.
BOX_MARGIN = 0.005
REGRESSOR_CHUNK = 2048


@dataclass(frozen=True)
class ExciteOptions:
    harmonics: int = 5
    base_frequency: float = 0.1  # Hz
    rate: float = 200.0  # Hz, output samples
    periods: int = 1
    criterion: str = "cond"
    scaled: bool = False  # criterion of the base regressor in SI units (True: with unit-norm columns)
    starts: int = 4
    max_iterations: int = 150
    margin: float = 0.1
    rest: bool = False


@dataclass(frozen=True)
class StartRecord:
    start_criterion: float  # κ (cond) or the logdet criterion of the start, on the grid
    end_criterion: float
    iterations: int
    message: str


@dataclass(frozen=True, eq=False)
class ExciteResult:
    trajectory: FourierTrajectory
    options: ExciteOptions
    limits: cons.Limits
    criterion: float  # on the grid: κ for cond, f for logdet
    cond_output: float  # κ(W D⁻¹) of the base regressor on the output samples
    cond_output_si: float  # κ(W), W in SI units, on the output samples
    t: np.ndarray
    q: np.ndarray
    dq: np.ndarray
    ddq: np.ndarray
    tau: np.ndarray | None  # nominal rigid-body torque (None without inertial values)
    box_path: np.ndarray | None
    starts: tuple[StartRecord, ...]
    best_start: int
    repair_scale: tuple[float, ...]  # per joint, the factor of the final repair (1: none)
    base_names: tuple[str, ...]
    elapsed_s: float
    grid_points: int
    cpu_s: float = 0.0  # CPU time of this process (the one-core figure on a busy machine)
    extra: dict = field(default_factory=dict)
    lowest: np.ndarray | None = None  # --floor: per link origin (then the tool point), its lowest height, m
    collisions: dict | None = None  # --collisions: the dense check's record (collisions.Collisions.report)


def validate(options: ExciteOptions) -> None:
    o = options
    if o.harmonics < 1:
        raise InputError(f"--harmonics must be at least 1, got {o.harmonics}")
    for value, flag in ((o.base_frequency, "--base-frequency"), (o.rate, "--rate")):
        if not (math.isfinite(value) and value > 0):
            raise InputError(f"{flag} must be a positive number of Hz, got {value:g}")
    if o.harmonics * o.base_frequency >= o.rate / 2:
        raise InputError(f"the highest harmonic ({o.harmonics} x {o.base_frequency:g} Hz) must be below half the --rate ({o.rate / 2:g} Hz)")
    if o.rest and o.harmonics < 2:
        raise InputError("--rest needs at least 2 harmonics (with one, starting at rest means not moving)")
    if o.periods < 1:
        raise InputError(f"--periods must be at least 1, got {o.periods}")
    if o.starts < 1:
        raise InputError(f"--starts must be at least 1, got {o.starts}")
    if o.max_iterations < 1:
        raise InputError(f"--max-iterations must be at least 1, got {o.max_iterations}")
    if not 0 <= o.margin < 0.5:
        raise InputError(f"--margin must be in [0, 0.5), got {o.margin:g}")
    if o.criterion not in CRITERIA:
        raise InputError(f"--criterion must be one of {', '.join(CRITERIA)}, got {o.criterion!r}")


def chain_limits(chain: Chain, margin: float, box=None, point=None, floor: float | None = None) -> cons.Limits:
    """The description's limits for the independent coordinates (position defaults as simulate's)."""
    from minparam_cli.experiment.trajectory import joint_ranges

    coords = chain.coordinates
    given = [chain.limits[j] for j in coords] if chain.limits else [None] * len(coords)
    ranges = np.array(joint_ranges(chain.coordinate_types, given), dtype=float)
    defaulted = tuple(i for i, g in enumerate(given) if g is None)

    def per(values):
        if not values:
            return np.full(len(coords), np.nan)
        return np.array([np.nan if values[j] is None else float(values[j]) for j in coords])

    lim = cons.Limits(ranges[:, 0], ranges[:, 1], per(chain.velocity_limits), per(chain.acceleration_limits),
                      per(chain.effort_limits), float(margin), defaulted, box, point, floor)
    for j in range(lim.n):
        if not lim.upper[j] > lim.lower[j]:
            raise InputError(f"joint {j + 1}: empty position range [{lim.lower[j]:g}, {lim.upper[j]:g}]")
    return lim


def _report_value(f: float, kind: str) -> float:
    return float(np.exp(f)) if kind == "cond" else float(f)


def output_times(options: ExciteOptions) -> np.ndarray:
    samples = int(round(options.periods * options.rate / options.base_frequency))
    return np.arange(samples + (1 if options.rest else 0)) / options.rate


def base_regressor(chain: Chain, kept, q, dq, ddq) -> np.ndarray:
    """Stacked base regressor (N·n, p) at the samples, in chunks."""
    from minparam_cli.dynamics.regressor import regressor

    kept = list(kept)
    rows = []
    for s in range(0, q.shape[0], REGRESSOR_CHUNK):
        e = s + REGRESSOR_CHUNK
        Y = regressor(chain, q[s:e], dq[s:e], ddq[s:e])[:, :, kept]
        rows.append(Y.reshape(-1, len(kept)))
    return np.vstack(rows)


def design(chain: Chain, base: BaseSet, options: ExciteOptions, limits: cons.Limits, rng: np.random.Generator,
           phi=None, progress=None) -> ExciteResult:
    """The excitation trajectory of ``chain`` (module docstring).  ``phi``: nominal standard inertial
    parameters for the torque limits (None: no torque limits); ``progress(done, total)``."""
    from scipy.optimize import minimize

    validate(options)
    t0, c0 = time.perf_counter(), time.process_time()
    n, H, kind = chain.dof, options.harmonics, options.criterion
    m = 1 + 2 * H
    N = GRID_POINTS_PER_HARMONIC * max(H, 4)
    period = 1.0 / options.base_frequency
    tg = np.arange(N) * (period / N)
    Bq, Bv, Ba = basis(tg, options.base_frequency, H)
    A, b = cons.linear_constraints(limits, Bq, Bv, Ba)
    use_tau = phi is not None and bool(np.isfinite(limits.effort).any())
    tau_joints = np.flatnonzero(np.isfinite(limits.effort)) if use_tau else np.zeros(0, int)
    kept = list(base.kept)
    centre = starts.feasible_centre(chain, limits, phi if use_tau else None) if (use_tau or limits.box is not None
                                                                                  or limits.collisions is not None) else None
    loops = starts.loops_of(chain)  # a closed chain: every start inside the loops' workspace
    standing = centre  # where a closed chain's start that leaves the loops is moved (chosen when first needed)

    cache: dict = {}

    def evaluate(x):
        key = x.tobytes()
        if key not in cache:
            cache.clear()
            X = x.reshape(n, m)
            q, dq, ddq = Bq @ X.T, Bv @ X.T, Ba @ X.T
            sens = sensitivities(chain, kept, q, dq, ddq, kind, phi if use_tau else None, options.scaled)
            grad = sens.dq.T @ Bq + sens.ddq_v.T @ Bv + sens.ddq_a.T @ Ba
            cache[key] = (sens, grad.ravel(), q)
        return cache[key]

    def fun(x):
        sens, grad, _ = evaluate(x)
        return sens.value, grad

    minus_A = -A  # the linear limits' Jacobian: constant, built once
    constraints = [{"type": "ineq", "fun": lambda x: b - A @ x, "jac": lambda x: minus_A}]
    slack: list[float | np.ndarray] = [0.0]  # per constraint: how far below 0 its value may go with the limits themselves still met
    if options.rest:
        R = np.kron(np.eye(n), rest_rows(H))
        constraints.append({"type": "eq", "fun": lambda x: R @ x, "jac": lambda x: R})
        slack.append(0.0)
    if use_tau:
        e = limits.shrunk(limits.effort[tau_joints])

        def tau_fun(x):
            tau = evaluate(x)[0].tau[:, tau_joints]
            return np.concatenate([(e - tau).ravel(), (e + tau).ravel()])

        def tau_jac(x):
            s = evaluate(x)[0]
            J = cons.state_jacobian(s.tau_q[:, tau_joints], s.tau_v[:, tau_joints], s.tau_a[:, tau_joints], Bq, Bv, Ba)
            return np.vstack([-J, J])

        constraints.append({"type": "ineq", "fun": tau_fun, "jac": tau_jac})
        slack.append(np.tile(np.repeat(limits.margin * limits.effort[tau_joints][None, :], N, axis=0).ravel(), 2))
    if limits.box is not None:
        box, point = limits.box, limits.point
        assert point is not None  # the box comes with its point (api.excitation.prepare_excite)
        axes = [(c, side) for c in range(3) for side in (0, 1) if np.isfinite(box[c, side])]

        Bq_box = Bq_grid(options, H, period)

        def box_fun(x):
            p = cons.box_point(chain, Bq_box @ x.reshape(n, m).T, point)
            return np.concatenate([(p[:, c] - box[c, 0] - BOX_MARGIN) if side == 0 else (box[c, 1] - BOX_MARGIN - p[:, c])
                                   for c, side in axes])

        def box_jac(x):
            dp = cons.box_point_jacobian(chain, Bq_box @ x.reshape(n, m).T, point)  # (N_box, 3, n)
            rows = []
            for c, side in axes:
                d = dp[:, c:c + 1] * (1.0 if side == 0 else -1.0)
                rows.append(cons.state_jacobian(d, np.zeros_like(d), np.zeros_like(d), Bq_box, Bq_box, Bq_box))
            return np.vstack(rows)

        constraints.append({"type": "ineq", "fun": box_fun, "jac": box_jac})
        slack.append(BOX_MARGIN / 2)
    if limits.floor is not None:
        constraints.append(cons.floor_constraint(chain, limits.floor, Bq_grid(options, H, period), n, m, BOX_MARGIN))
        slack.append(BOX_MARGIN / 2)
    if limits.collisions is not None:
        constraints.append(limits.collisions.constraint(chain, Bq_grid(options, H, period, limits.collisions.per_harmonic), n, m))
        slack.append(0.5)  # (in units of the clearance) half of it

    margins = getattr(chain.coupling, "limit_margins", None)
    if margins is not None and getattr(chain.coupling, "limited_passive", None):  # a closed chain's passive joints
        def passive_fun(x):
            return margins(Bq @ x.reshape(n, m).T)[0].ravel()

        def passive_jac(x):
            d = margins(Bq @ x.reshape(n, m).T)[1]
            return cons.state_jacobian(d, np.zeros_like(d), np.zeros_like(d), Bq, Bq, Bq)

        constraints.append({"type": "ineq", "fun": passive_fun, "jac": passive_jac})
        slack.append(0.0)

    solvers, firsts = [], []

    # SLSQP in rounds (rounds.py) with --collisions, and for a closed chain whose starts had to be moved into
    # its workspace (a parallel platform: SLSQP's first steps would leave it)
    in_rounds = limits.collisions is not None

    def solver(x0: np.ndarray):
        def solve(callback):
            if not in_rounds:
                return minimize(fun, x0, jac=True, method="SLSQP", constraints=constraints, callback=callback,
                                options={"maxiter": options.max_iterations, "ftol": 1e-7})
            lo, hi = limits.shrunk_range()  # SLSQP with a step bound (rounds.py): distances far from linear, loops
            return rounds.minimize_in_rounds(fun, x0, constraints, lambda x: cons.grid_feasible(x, A, b, constraints, slack),
                                             rounds.step_bound(hi - lo, H, options.base_frequency), options.max_iterations,
                                             callback, (LoopsNotClosed,))

        return solve

    for child in _children(rng, options.starts):
        start = starts.random_start(limits, options, child)
        if loops is not None:
            closes = starts.on_loops(loops, start.evaluate(tg)[0], starts.START_CONDITION).all()
            if not closes or centre is not None:  # (feasible_start below moves it to the centre: closed there)
                if standing is None:
                    standing = starts.loop_centre(loops, limits)
                start, in_rounds = starts.closing_start(loops, start, limits, standing, tg), in_rounds or not closes
            starts.refuse_mode_jumps(loops, start, cons.dense_times(start))
        if centre is not None:
            start = starts.feasible_start(chain, start, limits, phi if use_tau else None, centre, tg)
        x0 = start.matrix().ravel()
        firsts.append((x0, fun(x0)[0]))
        solvers.append(solver(x0))
    # the starts race (race.py), except in rounds, whose several SLSQP calls the race cannot pause and stop as one run
    runs, _ = race.run_starts(solvers, options.max_iterations, progress, raced=not in_rounds,
                              recoverable=(LoopsNotClosed,), starts=firsts)
    records, ends = [], []
    for i, ((x0, f0), run) in enumerate(zip(firsts, runs, strict=True)):
        res = run.result
        x = np.asarray(res.x)
        feasible = cons.grid_feasible(x, A, b, constraints, slack)
        f = fun(x)[0] if feasible else np.inf
        if not feasible:  # SLSQP stopped outside the limits: keep the start's (feasible) value
            x = x0
            f = f0 if cons.grid_feasible(x0, A, b, constraints, slack) else np.inf
        # a start the race ended says so; one that ended by itself before a stage keeps SLSQP's message
        message = f"stopped after {res.nit} iterations (not among the best half)" if run.stopped else str(res.message)
        records.append(StartRecord(_report_value(f0, kind), _report_value(f, kind), int(res.nit), message))
        if np.isfinite(f):
            ends.append((f, i, x))
    if not ends:
        raise ComputationError("no start met the limits (torque limits or the Cartesian box may be infeasible)")

    t = output_times(options)
    failures = []
    # the best end point that passes the dense check (best: read after the loop)
    for _, best, best_x in sorted(ends, key=lambda e: e[0]):  # noqa: B007
        traj, scale, broken = _checked(chain, FourierTrajectory.from_matrix(best_x.reshape(n, m), options.base_frequency), limits,
                                       phi if use_tau else None, t)
        if margins is not None and getattr(chain.coupling, "limited_passive", None):  # passive joints, densely
            low = margins(traj.evaluate(cons.dense_times(traj, t))[0])[0].min(axis=0)
            names = chain.coupling.limited_passive  # type: ignore[union-attr]  # margins: a closed chain's coupling
            broken += [f"passive joint {names[k % len(names)]} leaves its limits" for k in np.flatnonzero(low < 0)]
        if loops is not None and not starts.on_loops(loops, traj.evaluate(cons.dense_times(traj, t))[0]).all():
            broken.append("the loops do not close everywhere (a state past the workspace or near a singularity of the loops)")
        elif loops is not None and starts.mode_jumps(loops, traj.evaluate(np.sort(cons.dense_times(traj)))[0]):
            broken.append("the loops close in different assembly modes along the motion")
        if not broken:
            break
        failures.append(broken)
    else:
        collided = any(f.startswith("collision:") for f in failures[0])  # an exit-2 refusal: the shapes leave no room
        raise (InputError if collided else ComputationError)(
            "the designed motion breaks a limit between grid points (" + "; ".join(failures[0])
            + ("); try a smaller --clearance, a larger --margin or another --seed" if collided else
               "); try a wider --box, a larger --margin or another --seed"))
    q, dq, ddq = traj.evaluate(t)
    W = base_regressor(chain, kept, q, dq, ddq)
    tau = None
    if phi is not None:
        from minparam_cli.experiment.simulate import rigid_torque

        tau = rigid_torque(chain, q, dq, ddq, phi)
    box_path = None
    if limits.box is not None:
        assert limits.point is not None  # the box comes with its point (api.excitation.prepare_excite)
        box_path = cons.box_point(chain, q, limits.point)
    lowest = None if limits.floor is None else cons.heights(chain, q).min(axis=0)
    collisions = None
    if limits.collisions is not None:
        dense = cons.dense_times(traj, t)
        collisions = limits.collisions.report(chain, traj.evaluate(dense)[0], dense, limits.collisions.per_harmonic * max(H, 4))
    qg, dqg, ddqg = traj.evaluate(tg)
    final = criterion_value(base_regressor(chain, kept, qg, dqg, ddqg), kind, options.scaled)
    return ExciteResult(
        trajectory=traj, options=options, limits=limits, criterion=_report_value(final, kind),
        cond_output=condition_number(W), cond_output_si=condition_number(W, scaled=False), t=t, q=q, dq=dq, ddq=ddq, tau=tau, box_path=box_path,
        starts=tuple(records), best_start=best, repair_scale=tuple(float(s) for s in scale),
        base_names=base.base_names, elapsed_s=time.perf_counter() - t0, grid_points=N,
        cpu_s=time.process_time() - c0, lowest=lowest, collisions=collisions,
    )


def Bq_grid(options: ExciteOptions, H: int, period: float, per_harmonic: int = BOX_GRID_POINTS_PER_HARMONIC) -> np.ndarray:
    """The position basis on the fine grid of the Cartesian constraints (box, floor; the collision shapes
    with their own ``per_harmonic``): per_harmonic · max(H, 4) points per period."""
    points = per_harmonic * max(H, 4)
    return basis(np.arange(points) * (period / points), options.base_frequency, H)[0]


def _checked(chain, traj: FourierTrajectory, limits: cons.Limits, phi, t):
    """``traj`` repaired and checked densely (``constraints``): the all-instant repair of positions and
    rates, then torques and the box, shrinking the motion about its mean while they fail (which lowers
    the dynamic torques; for the box it helps only when the mean lies well inside).  Returns the trajectory, the per-joint scale and
    the limits still broken (empty: none)."""
    scale = cons.rigorous_scale(traj, limits)
    traj = cons.scaled(traj, scale)
    if phi is None and limits.box is None and limits.floor is None and limits.collisions is None:
        return traj, scale, []
    check_t = cons.dense_times(traj, t)
    broken: list[str] = []
    for _ in range(cons.REPAIR_STEPS):
        broken = cons.nonlinear_violations(chain, traj, limits, phi, check_t)
        if not broken:
            break
        traj = cons.scaled(traj, cons.REPAIR_FACTOR)
        scale = scale * cons.REPAIR_FACTOR
    return traj, scale, broken


def _children(rng: np.random.Generator, count: int) -> list[np.random.Generator]:
    from minparam_cli.experiment.simulate import child_generators

    return child_generators(rng, count)
