"""Excitation design (``minparam excite``): the option checks, the preparation of the chain and its
limits, the design and the JSON record, shared by the command and by ``minparam.excite``.

The command is a shell over these functions: it parses its options, calls ``excite_options``,
``parse_box``, ``prepare_excite``, ``run_design`` and ``excite_record``, prints the notes and the
summary, and writes the files.  ``excite`` below is the library call: the same functions, the notes
as ``MinparamWarning`` warnings, no output unless ``progress=True``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterable

from minparam_cli.api.common import OptionError, ProgressArg, choice, close, float_option, friction_option, progress_callback, robot_path, warn
from minparam_cli.api.results import Excitation, Robot
from minparam_cli.errors import InputError

if TYPE_CHECKING:
    import numpy as np

    from minparam_cli.base.result import BaseSet as StageBaseSet
    from minparam_cli.chain import Chain
    from minparam_cli.experiment.excite.constraints import Limits
    from minparam_cli.experiment.excite.design import ExciteOptions, ExciteResult

CRITERIA = ("cond", "logdet")
SCALINGS = ("si", "columns")


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


def parse_box(text: str) -> np.ndarray:
    """'XMIN:XMAX,YMIN:YMAX,ZMIN:ZMAX' (empty side: free) -> (3, 2) with NaN for free sides."""
    import numpy as np

    parts = text.split(",")
    if len(parts) != 3:
        raise OptionError("--box", f"expected XMIN:XMAX,YMIN:YMAX,ZMIN:ZMAX, got {text!r}")
    out = np.full((3, 2), np.nan)
    for c, part in enumerate(parts):
        sides = part.split(":")
        if len(sides) != 2:
            raise OptionError("--box", f"expected MIN:MAX for axis {'xyz'[c]}, got {part!r}")
        for k, v in enumerate(sides):
            if v.strip():
                try:
                    out[c, k] = float(v)
                except ValueError:
                    raise OptionError("--box", f"expected a number, got {v!r}") from None
                if not np.isfinite(out[c, k]):
                    raise OptionError("--box", f"expected a finite number, got {v!r}")
        if np.isfinite(out[c]).all() and not out[c, 0] < out[c, 1]:
            raise InputError(f"infeasible limits: --box axis {'xyz'[c]} is empty ({out[c, 0]:g} >= {out[c, 1]:g})")
    if not np.isfinite(out).any():
        raise OptionError("--box", "every side is free")
    return out


def box_option(box: Any) -> np.ndarray | None:
    """The box from the CLI's text or from a (3, 2) array-like (None or NaN: a free side)."""
    import numpy as np

    if box is None:
        return None
    if isinstance(box, str):
        return parse_box(box)
    try:
        arr = np.array([[np.nan if v is None else float(v) for v in row] for row in box], dtype=float)
    except (TypeError, ValueError):
        raise OptionError("--box", f"expected (3, 2) bounds [[XMIN, XMAX], [YMIN, YMAX], [ZMIN, ZMAX]], got {box!r}") from None
    if arr.shape != (3, 2) or np.isinf(arr).any():
        raise OptionError("--box", f"expected (3, 2) finite bounds [[XMIN, XMAX], [YMIN, YMAX], [ZMIN, ZMAX]], got {box!r}")
    return parse_box(",".join(":".join("" if np.isnan(v) else repr(float(v)) for v in row) for row in arr))


def excite_options(harmonics: int = 5, base_frequency: float = 0.1, rate: float = 200.0, periods: int = 1,
                   criterion: str = "cond", scaling: str = "si", rest: bool = False, margin: float = 0.1,
                   starts: int = 4, max_iterations: int = 150) -> ExciteOptions:
    """The design's options, checked with the CLI's messages."""
    from minparam_cli.experiment.excite.design import ExciteOptions, validate

    opts = ExciteOptions(harmonics=int(harmonics), base_frequency=float(base_frequency), rate=float(rate),
                         periods=int(periods), criterion=choice(criterion, CRITERIA, "--criterion"),
                         scaled=choice(scaling, SCALINGS, "--scaling") == "columns", starts=int(starts),
                         max_iterations=int(max_iterations), margin=float(margin), rest=bool(rest))
    validate(opts)
    return opts


def prepare_excite(robot: Path, opts: ExciteOptions, friction: tuple[str, ...], rotor_inertia: bool, mimic: str,
                   box: np.ndarray | None, point: np.ndarray | None) -> Prepared:
    """Load the chain with the declared extras, its limits (position defaults as simulate's), the
    nominal parameters when effort limits can be enforced, and derive's QR base set."""
    import numpy as np

    from minparam_cli.base.qr import derive_qr
    from minparam_cli.experiment.excite.design import chain_limits
    from minparam_cli.robot import DeriveOptions, load_chain, require_fixed_base

    _, chain = load_chain(robot, DeriveOptions(friction=friction, rotor_inertia=rotor_inertia, mimic=mimic))
    require_fixed_base(chain, "excite")
    if box is not None and point is None:
        point = np.zeros(3) if chain.tool is None else np.asarray(chain.tool, dtype=float)
    limits = chain_limits(chain, opts.margin, box, point)
    notes = []
    if limits.defaulted:
        js = ", ".join(str(j + 1) for j in limits.defaulted)
        notes.append(f"{robot} gives no position limits for joint(s) {js}; using ±90° (revolute) or ±0.1 m "
                     "(prismatic), as simulate does")
    phi = None
    if chain.phi_nominal is not None and np.isfinite(limits.effort).any():
        phi = np.array(chain.phi_nominal, dtype=float)
    elif np.isfinite(limits.effort).any():
        notes.append(f"{robot} gives effort limits but not every link's inertial values; torque limits are not enforced")
    return Prepared(str(robot), chain, limits, phi, derive_qr(chain), friction, bool(rotor_inertia), tuple(notes))


def run_design(prep: Prepared, opts: ExciteOptions, seed: int, progress: Any = None) -> ExciteResult:
    """The design stage, from one generator seeded with ``seed``."""
    import numpy as np

    from minparam_cli.experiment.excite.design import design

    return design(prep.chain, prep.base, opts, prep.limits, np.random.default_rng(seed), phi=prep.phi, progress=progress)


def excite_record(result: ExciteResult, prep: Prepared, seed: int) -> dict[str, Any]:
    """The JSON record of ``--json``: coefficients, criterion, starts, limits used, effects."""
    from minparam_cli.render.excite_text import json_record

    effects = {"friction": list(prep.friction), "rotor_inertia": prep.rotor_inertia, "columns": list(prep.chain.layout.names)}
    return json_record(result, prep.robot, prep.chain.name, seed, effects)


def after_notes(prep: Prepared) -> list[str]:
    """The note shown after the summary: no rate limits at all."""
    import numpy as np

    lim = prep.limits
    if np.isfinite(lim.velocity).any() or np.isfinite(lim.acceleration).any():
        return []
    return [f"{prep.robot} gives no velocity or acceleration limits; only the position ranges and the period "
            "bound the speeds (add velocity: and acceleration: to the joints, or lower --base-frequency)"]


def excite(robot: Robot | str | Path, *, harmonics: int = 5, base_frequency: float = 0.1, rate: float = 200.0,
           periods: int = 1, criterion: str = "cond", scaling: str = "si", rest: bool = False, margin: float = 0.1,
           friction: str | Iterable[str] | None = None, rotor_inertia: bool | None = None, box: Any = None,
           point: Any = None, starts: int = 4, max_iterations: int = 150, seed: int = 0, mimic: str | None = None,
           progress: ProgressArg = False) -> Excitation:
    """Design an excitation trajectory (``minparam excite``): a finite Fourier series (Swevers et al.
    1997) that minimises the condition number (``criterion="cond"``) or −log det (``"logdet"``) of the
    base regressor, declared friction / rotor inertia included, within the joint position, velocity,
    acceleration and effort limits (``margin`` kept free) and, with ``box`` ([[XMIN, XMAX], [YMIN,
    YMAX], [ZMIN, ZMAX]] in m, None for a free side, or the CLI's "XMIN:XMAX,..." text), keeping
    ``point`` (the tool point by default) inside a Cartesian box.  ``starts`` random starts from one
    generator seeded with ``seed``.  A Robot's own friction, rotor inertia and mimic mode apply unless
    given here.  ``to_dict()`` is the ``--json`` record, ``to_csv()`` the CSV of ``-o``.
    """
    if seed < 0:
        raise InputError(f"--seed must be >= 0, got {seed}")
    base = robot.options if isinstance(robot, Robot) else None
    kinds = friction_option(friction) if friction is not None else (base.friction if base else ())
    rotor = bool(rotor_inertia) if rotor_inertia is not None else (base.rotor_inertia if base else False)
    mode = choice(mimic, ("coupled", "fixed"), "--mimic") if mimic is not None else (base.mimic if base else "coupled")
    box_arr = box_option(box)
    import numpy as np

    point_arr = np.array(float_option(point, 3, "--point")) if point is not None else None
    opts = excite_options(harmonics, base_frequency, rate, periods, criterion, scaling, rest, margin, starts, max_iterations)
    prep = prepare_excite(robot_path(robot), opts, kinds, rotor, mode, box_arr, point_arr)
    warn(prep.notes)
    bar = progress_callback(progress, opts.starts * opts.max_iterations, "excite")
    try:
        result = run_design(prep, opts, seed, bar)
    finally:
        close(bar)
    warn(after_notes(prep))
    traj = result.trajectory
    return Excitation(robot=prep.robot, t=result.t, q=result.q, dq=result.dq, ddq=result.ddq, tau=result.tau,
                      q0=traj.q0, a=traj.a, b=traj.b, base_frequency=float(traj.base_frequency),
                      criterion=float(result.criterion), condition_number=float(result.cond_output),
                      condition_number_si=float(result.cond_output_si), base_names=tuple(result.base_names),
                      seed=seed, _design=result, _report=excite_record(result, prep, seed))
