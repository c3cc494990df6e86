"""Excitation design (``minparam excite``): the option checks, the preparation of the chain and its
limits, the design and the JSON record, shared by the command and by ``minparam.excite``.

The command is a shell over these functions: it builds ``ExciteOptions``, calls ``prepare_excite``
and ``run_excite``, prints the notes and the summary, and writes the files.  ``excite`` below is the library call: the same functions, the notes
as ``MinparamWarning`` warnings, no output unless ``progress=True``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterable, cast

from minparam_cli.api.common import ProgressArg, close, progress_callback, robot_path, warn
from minparam_cli.api.excitation_result import Excitation
from minparam_cli.api.options.excite import ExciteOptions
from minparam_cli.api.results import Robot

if TYPE_CHECKING:
    import numpy as np

    from minparam_cli.base.result import BaseSet as StageBaseSet
    from minparam_cli.chain import Chain
    from minparam_cli.experiment.excite.constraints import Limits
    from minparam_cli.experiment.excite.design import ExciteOptions as DesignOptions



@dataclass(frozen=True)
class Prepared:
    """What the design needs: the chain with the declared extras, its limits, the nominal parameters
    (when torque limits can be enforced), the base set, and the notes to show before the design."""

    robot: str
    chain: Chain
    limits: Limits
    phi: np.ndarray | None
    base: StageBaseSet
    friction: tuple[str, ...]
    rotor_inertia: bool
    notes: tuple[str, ...]
    design: DesignOptions
    seed: int


def prepare_excite(robot: Path, opts: ExciteOptions) -> Prepared:
    """Load the chain with the declared extras, its limits (position defaults as simulate's), the
    nominal parameters when effort limits can be enforced, and derive's QR base set."""
    import numpy as np

    from minparam_cli.base.qr import derive_qr
    from minparam_cli.experiment.excite.design import chain_limits
    from minparam_cli.robot import DeriveOptions, load_chain, require_fixed_base

    design = opts.design()
    from minparam_cli.loops.coupling import with_loops

    desc, chain = load_chain(robot, DeriveOptions(friction=opts.friction, rotor_inertia=opts.rotor_inertia, mimic=opts.mimic),
                             loops=True)
    chain = with_loops(desc, chain)  # a closed chain: the actuated joints, the loops as the coupling
    require_fixed_base(chain, "excite")
    box = np.array(opts.box, dtype=float) if opts.box is not None else None
    point = np.array(opts.point, dtype=float) if opts.point is not None else None
    if box is not None and point is None:
        point = np.zeros(3) if chain.tool is None else np.asarray(chain.tool, dtype=float)
    limits = chain_limits(chain, design.margin, box, point, opts.floor)
    if opts.floor is not None:  # a point that stays below the floor wherever the joints go: no design exists
        from minparam_cli.errors import InputError
        from minparam_cli.experiment.excite.constraints import heights

        lo, hi = limits.shrunk_range()
        q = lo + (hi - lo) * np.random.default_rng(opts.seed).random((256, limits.n))
        top = heights(chain, q).max(axis=0)
        low = int(np.argmin(top - opts.floor))
        if top[low] < opts.floor:
            what = "the tool point" if low == chain.n else f"link {low + 1}'s origin"
            raise InputError(f"infeasible limits: --floor {opts.floor:g} m: {what} is at most {top[low]:.4g} m high "
                             "in 256 positions within the joint limits")
    notes = []
    if opts.collisions:
        from dataclasses import replace

        from minparam_cli.api.options.excite import DEFAULT_CLEARANCE
        from minparam_cli.experiment.excite.collision_model import load_collisions

        clearance = DEFAULT_CLEARANCE if opts.clearance is None else opts.clearance
        shapes, said = load_collisions(robot, chain, limits, clearance, opts.floor, np.random.default_rng(opts.seed))
        limits = replace(limits, collisions=shapes)
        notes += said
    if limits.defaulted:
        js = ", ".join(str(j + 1) for j in limits.defaulted)
        notes.append(f"{robot} gives no position limits for joint(s) {js}; using ±90° (revolute) or ±0.1 m "
                     "(prismatic), as simulate does")
    phi = None
    if chain.phi_nominal is not None and np.isfinite(limits.effort).any():
        phi = np.array(chain.phi_nominal, dtype=float)
    elif np.isfinite(limits.effort).any():
        notes.append(f"{robot} gives effort limits but not every link's inertial values; torque limits are not enforced")
    return Prepared(str(robot), chain, limits, phi, derive_qr(chain), opts.friction, opts.rotor_inertia, tuple(notes),
                    design, opts.seed)


def run_excite(prep: Prepared, progress: Any = None) -> Excitation:
    """The design stage, from one generator seeded with the options' seed: the excitation."""
    import numpy as np

    from minparam_cli.experiment.excite.design import design

    result = design(prep.chain, prep.base, prep.design, prep.limits, np.random.default_rng(prep.seed), phi=prep.phi,
                    progress=progress)
    traj = result.trajectory
    effects = {"friction": list(prep.friction), "rotor_inertia": prep.rotor_inertia, "columns": list(prep.chain.layout.names)}
    return Excitation(robot=prep.robot, robot_name=prep.chain.name, t=result.t, q=result.q, dq=result.dq, ddq=result.ddq,
                      tau=result.tau, q0=traj.q0, a=traj.a, b=traj.b, base_frequency=float(traj.base_frequency),
                      criterion=float(result.criterion), condition_number=float(result.cond_output),
                      condition_number_si=float(result.cond_output_si), base_names=tuple(result.base_names),
                      seed=prep.seed, effects=effects, design=result)


def after_notes(prep: Prepared, result: Excitation | None = None) -> list[str]:
    """The notes shown after the summary: joints the design leaves still, no rate limits at all."""
    import numpy as np

    out = []
    if result is not None:
        still = [j + 1 for j, s in enumerate(result.design.repair_scale) if s == 0.0]
        if still:
            out.append(f"joint(s) {', '.join(map(str, still))} do not move in this design: the optimiser's best end put "
                       "the mean position on the end of the allowed range, and keeping every instant inside it left no "
                       "motion (another --seed, more --starts or a smaller --margin may move them)")
    lim = prep.limits
    if not (np.isfinite(lim.velocity).any() or np.isfinite(lim.acceleration).any()):
        out.append(f"{prep.robot} gives no velocity or acceleration limits; only the position ranges and the period "
                   "bound the speeds (add velocity: and acceleration: to the joints, or lower --base-frequency)")
    return out


def excite(robot: Robot | str | Path, *, harmonics: int = 5, base_frequency: float = 0.1, rate: float = 200.0,
           periods: int = 1, criterion: str = "cond", scaling: str = "si", rest: bool = False, margin: float = 0.1,
           friction: str | Iterable[str] | None = None, rotor_inertia: bool | None = None, box: Any = None,
           point: Any = None, floor: float | None = None, collisions: bool = False, clearance: float | None = None, starts: int = 4, max_iterations: int = 150, seed: int = 0, mimic: str | None = None,
           progress: ProgressArg = False) -> Excitation:
    """Design an excitation trajectory (``minparam excite``): a finite Fourier series (Swevers et al.
    1997) that minimises the condition number (``criterion="cond"``) or −log det (``"logdet"``) of the
    base regressor, declared friction / rotor inertia included, within the joint position, velocity,
    acceleration and effort limits (``margin`` kept free) and, with ``box`` ([[XMIN, XMAX], [YMIN,
    YMAX], [ZMIN, ZMAX]] in m, None for a free side, or the CLI's "XMIN:XMAX,..." text), keeping
    ``point`` (the tool point by default) inside a Cartesian box; with ``floor`` (m) every link frame's
    origin and the tool point at least that high against gravity; with ``collisions`` the file's collision
    shapes (URDF ``<collision>``, MJCF geoms; the ``[mujoco]`` extra) ``clearance`` m apart (default 0.01),
    and off that floor.  ``starts`` random starts from one
    generator seeded with ``seed``.  A Robot's own friction, rotor inertia and mimic mode apply unless
    given here.  ``to_dict()`` is the ``--json`` record, ``to_csv()`` the CSV of ``-o``.
    """
    own = robot.options if isinstance(robot, Robot) else None
    # cast(Any, ...): raw values (text, sequences, mappings) that the record normalises on construction (its fields: the stored types)
    opts = ExciteOptions(harmonics=harmonics, base_frequency=base_frequency, rate=rate, periods=periods, criterion=criterion,
                         scaling=scaling, rest=rest, margin=margin,
                         friction=cast(Any, friction if friction is not None else (own.friction if own else ())),
                         rotor_inertia=bool(rotor_inertia) if rotor_inertia is not None else (own.rotor_inertia if own else False),
                         box=box, point=point, floor=floor, collisions=collisions, clearance=clearance, starts=starts, max_iterations=max_iterations, seed=seed,
                         mimic=mimic if mimic is not None else (own.mimic if own else "coupled"))
    prep = prepare_excite(robot_path(robot), opts)
    warn(prep.notes)
    bar = progress_callback(progress, opts.starts * opts.max_iterations, "excite")
    try:
        result = run_excite(prep, bar)
    finally:
        close(bar)
    warn(after_notes(prep, result))
    return result
