"""Robots and their base parameters: ``load_robot``, ``check``, ``derive``, ``regressor``."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterable, cast

from minparam_cli.api.common import ProgressArg, choice, close, friction_kinds, gravity3, progress_callback, robot_path, warn
from minparam_cli.api.check_result import CheckResult
from minparam_cli.api.results import BaseSet, LoadOptions, Robot
from minparam_cli.errors import InputError
from minparam_cli.describe.records import MIMIC_MODES

if TYPE_CHECKING:
    import numpy as np



def load_options(robot: Any, friction: str | Iterable[str] | None = None, rotor_inertia: bool | None = None,
                 gravity: Any = None, mimic: str | None = None, floating_base: bool | None = None) -> LoadOptions:
    """A Robot's own load options with the given ones replacing them (None: keep)."""
    from minparam_cli.api.results import Robot

    base = robot.options if isinstance(robot, Robot) else LoadOptions()
    return LoadOptions(
        friction=friction_kinds(friction) if friction is not None else base.friction,
        rotor_inertia=bool(rotor_inertia) if rotor_inertia is not None else base.rotor_inertia,
        gravity=gravity3(gravity) if gravity is not None else base.gravity,
        mimic=choice(mimic, MIMIC_MODES, "mimic") if mimic is not None else base.mimic,
        floating_base=bool(floating_base) if floating_base is not None else base.floating_base,
        coulomb_smoothing=base.coulomb_smoothing,
    )


def derive_options(opts: LoadOptions, **kw: Any):
    from minparam_cli.robot import DeriveOptions

    return DeriveOptions(friction=opts.friction, rotor_inertia=opts.rotor_inertia, gravity=opts.gravity,
                         mimic=opts.mimic, floating_base=opts.floating_base, **kw)


def load_robot(path: str | Path, *, friction: str | Iterable[str] | None = None, rotor_inertia: bool = False,
               gravity: Any = None, mimic: str = "coupled", floating_base: bool = False,
               coulomb_smoothing: float = 0.0) -> Robot:
    """Load a robot description (YAML DH/MDH or URDF) into a :class:`Robot`.

    ``friction`` ("coulomb", "viscous", "offset"; a list or "coulomb,viscous") and ``rotor_inertia``
    add per-joint columns; ``gravity`` (three numbers, m/s²) overrides the file's.  Raises
    ``DescriptionError`` (an ``InputError``) with the CLI's message for a bad file.
    """
    import math

    from minparam_cli.robot import load_chain

    if not (math.isfinite(coulomb_smoothing) and coulomb_smoothing >= 0):
        raise InputError(f"coulomb_smoothing: must be a finite velocity >= 0 (0: sign), got {coulomb_smoothing!r}")
    path = robot_path(path)
    opts = load_options(None, friction, rotor_inertia, gravity, mimic, floating_base)
    opts = LoadOptions(opts.friction, opts.rotor_inertia, opts.gravity, opts.mimic, opts.floating_base, float(coulomb_smoothing))
    desc, chain = load_chain(Path(path), derive_options(opts))
    chain = chain.with_coulomb_smoothing(opts.coulomb_smoothing)
    return Robot(path=Path(path), name=chain.name, dof=chain.dof, joint_names=tuple(chain.joint_names),
                 joint_types=tuple(chain.types), standard_names=tuple(chain.layout.names), options=opts, chain=chain,
                 description=desc)


def check(path: str | Path) -> CheckResult:
    """Validate a robot file (``minparam check --json``); raises ``DescriptionError`` when it is invalid."""
    from minparam_cli.api.derivation import check_file

    return check_file(robot_path(path))


def derive(robot: Robot | str | Path, *, method: str = "qr", friction: str | Iterable[str] | None = None,
           rotor_inertia: bool | None = None, symbolic: bool = False, gravity: Any = None, samples: int = 100,
           seed: int = 0, snap_angles: float | None = None, mimic: str | None = None,
           floating_base: bool | None = None, progress: ProgressArg = False, symbolic_numbers: bool = False) -> BaseSet:
    """Base parameters of a robot (``minparam derive``): which are identifiable and how the others regroup.

    ``method``: "qr" (``samples`` random states from ``seed``, pivoted QR) or "projection" (Krutikov's
    recursive projection).  ``symbolic=True`` writes the regrouping coefficients in the geometry
    symbols; ``symbolic_numbers=True`` does so with the file's lengths (and axes with rational
    components) as exact numbers (``--symbolic-numbers``).  A Robot's own friction, rotor inertia and gravity apply unless given here.
    """
    from minparam_cli.api.derivation import derive_file
    from minparam_cli.api.options.derive import DeriveOptions

    own = robot.options if isinstance(robot, Robot) else LoadOptions()
    # cast(Any, ...): raw values (text, sequences, mappings) that the record normalises on construction (its fields: the stored types)
    opts = DeriveOptions(
        method=method, friction=cast(Any, friction if friction is not None else own.friction),
        rotor_inertia=rotor_inertia if rotor_inertia is not None else own.rotor_inertia,
        gravity=gravity if gravity is not None else own.gravity, samples=samples, seed=seed, symbolic=symbolic,
        symbolic_numbers=symbolic_numbers, snap_angles=snap_angles, mimic=mimic if mimic is not None else own.mimic,
        floating_base=floating_base if floating_base is not None else own.floating_base)
    path = robot_path(robot)
    bar = progress_callback(progress, 1, f"{opts.method} {path.name}")
    try:
        base = derive_file(path, opts, progress=bar)
    finally:
        close(bar)
    warn(base.warnings)
    return base


def regressor(robot: Robot | str | Path, q: Any, dq: Any, ddq: Any, base: bool | BaseSet = True, *,
              seed: int = 0) -> np.ndarray:
    """The dynamic regressor: ``tau = Y @ parameters``, vectorised over samples.

    q, dq, ddq: (N, dof) (or (dof,) for one sample) in rad, rad/s, rad/s² (m, m/s, m/s² for prismatic
    joints).  Returns (N, dof, P) (or (dof, P)).  ``base=True``: the columns of the base parameters
    (those ``derive(robot, seed=seed)`` keeps, method "qr"), so that ``tau = Y @ beta_base``; a
    :class:`BaseSet` picks its own base columns; ``base=False``: every standard parameter
    (``robot.standard_names``).
    """
    import numpy as np

    from minparam_cli.dynamics.regressor import regressor as full_regressor

    rob = robot if isinstance(robot, Robot) else load_robot(robot)
    chain = rob.chain
    arrays = [np.asarray(x, dtype=float) for x in (q, dq, ddq)]
    single = arrays[0].ndim == 1
    arrays = [np.atleast_2d(x) for x in arrays]
    for name, x in zip(("q", "dq", "ddq"), arrays, strict=True):
        if x.ndim != 2 or x.shape[1] != chain.dof or x.shape != arrays[0].shape:
            raise InputError(f"{name}: expected shape (N, {chain.dof}) like q, got {x.shape}")
        if not np.all(np.isfinite(x)):
            raise InputError(f"{name}: expected finite numbers")
    Y = full_regressor(chain, arrays[0], arrays[1], arrays[2])
    if base is not False:
        if isinstance(base, BaseSet):
            if tuple(base.standard_names) != tuple(chain.layout.names):
                raise InputError(f"base: the BaseSet of {base.robot} has other standard parameters than {rob.name}")
            cols = list(base.kept)
        else:
            from minparam_cli.base.qr import derive_qr

            cols = list(derive_qr(chain, seed=seed).kept)
        Y = Y[:, :, cols]
    return Y[0] if single else Y
