"""Identification from files or from arrays in memory: ``identify`` (the library call) and
``run_identify`` (the one driver, which ``minparam identify`` calls too), ``run_consistency``
(``identify --consistency``), and the model file's ``load_model``/``save_model``/``predict``.

Both front ends build one ``api.options.identify.IdentifyOptions`` (its checks, its messages) and call
``run_identify``: it loads the chain, runs the stage (``identify.stage.identify``), adds the payload
and the scale note, makes the model and writes the files asked for.  Data held in memory are
registered under a name (``<data>``, ``<validate>``, ``<test1>``...) for the call and read by the
readers as a file would be (``measured.arrays``): no file is written, and pandas is imported only by
whoever made the DataFrame.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterable, Sequence, cast

from minparam_cli.api.common import ProgressArg, close, progress_callback, robot_path
from minparam_cli.api.identified import Identification, Model
from minparam_cli.api.options.identify import IdentifyOptions
from minparam_cli.api.results import Robot
from minparam_cli.errors import InputError

if TYPE_CHECKING:

    from minparam_cli.identify.consistency import ConsistencyResult


def _sources(data: Any, validate: Any, tests: tuple[Any, ...]) -> tuple[Any, Any, tuple[Any, ...], list]:
    """Paths as they are; records held in memory registered under <data>, <validate>, <test1>..."""
    from minparam_cli.measured.arrays import as_record, is_in_memory

    records = []

    def one(x: Any, name: str, required: bool = False) -> Any:
        if x is None and not required:
            return None
        if is_in_memory(x):
            records.append(as_record(x, name))
            return name
        if isinstance(x, (str, Path)):
            return str(x)
        raise InputError(f"{name.strip('<>')}: expected a file path, a mapping of arrays or a pandas DataFrame, "
                         f"got {type(x).__name__}")

    return (one(data, "<data>", required=True), one(validate, "<validate>"),
            tuple(one(t, f"<test{k + 1}>") for k, t in enumerate(tests)), records)


def load_identify_chain(opts: IdentifyOptions, robot: Path | None = None):
    """The chain identify fits (``robot``: another file than ``opts.robot``, a batch's manifest row):
    loaded with the declared extras, a fixed base, nominal inertias checked for --prior nominal (before
    any data are read), Coulomb smoothing set."""
    from minparam_cli.robot import DeriveOptions, load_chain, require_fixed_base

    path = opts.robot if robot is None else Path(robot)
    from minparam_cli.loops.coupling import with_loops

    desc, chain = load_chain(path, DeriveOptions(friction=opts.friction, rotor_inertia=opts.rotor_inertia,
                                                 gravity=opts.gravity, mimic=opts.mimic), loops=True)
    chain = with_loops(desc, chain)  # a closed chain: the actuated joints, the loops as the coupling
    require_fixed_base(chain, "identify")
    if opts.export_urdf is not None and chain.layout.massless:  # before any data are read
        raise InputError(f"--export-urdf: {path} has bodies with several joints (MJCF), whose massless frames the URDF export "
                         "does not write yet")
    if opts.nominal_prior or (opts.physical and opts.prior == "auto"):
        from minparam_cli.dynamics.bodies import nominal_problems, nominal_problems_text

        if nominal_problems(chain):
            raise InputError(f"--prior {opts.prior}: " + nominal_problems_text(str(path), nominal_problems(chain))
                             + ("; or give --prior none" if opts.prior == "auto" else ""))
    return chain.with_coulomb_smoothing(opts.coulomb_smoothing)


def stage_options(opts: IdentifyOptions, chain, motor_side, validate: str | None, tests: tuple[str, ...]):
    """The stage's options (``identify.stage.IdentifyOptions``) for this chain and these data names."""
    from minparam_cli.identify.diagnosis.diagnose import DiagnosisOptions
    from minparam_cli.identify.stage import IdentifyOptions as StageOptions
    from minparam_cli.measured.records import DataOptions
    from minparam_cli.measured.rosbag import coordinate_names

    physical = opts.physical_options(chain) if opts.physical else None
    return StageOptions(
        data=DataOptions(columns=dict(opts.columns), cutoff_hz=opts.cutoff, force_filter=opts.force_filter,
                         decimate=opts.decimate, step_s=(1.0 / opts.rate if opts.rate else None),
                         trim_still_s=opts.trim_still, still_speed=opts.still_speed,
                         rest_below_still=bool(opts.rest_below_still), time_unit=opts.time_unit, topic=opts.topic,
                         joint_names=coordinate_names(chain), motor_side=motor_side),
        split=opts.split, validate=validate, tests=tests, weighted=not opts.ols, diagnose=opts.diagnose,
        diagnosis=DiagnosisOptions(effects=opts.effects, min_gain=opts.min_gain, weighted=not opts.ols),
        seed=opts.seed, physical=physical, uncertainty=opts.uncertainty(),
        essential=opts.essential_bound if opts.essential else None,
    )


def run_identify(opts: IdentifyOptions, data: Any, progress: Any = None, robot: Path | None = None,
                 chain: Any = None) -> Identification:
    """The one driver of ``minparam identify`` and ``minparam.identify``: fit on the fit data, choose
    effects on the selection data, report on the test data; the payload with --payload-data; the model
    and the files of --save-model, --export-urdf, --export-yaml.  ``progress``: a callable (done, total)
    or None; ``robot``/``chain``: another robot file than ``opts.robot`` (a batch) or its chain."""
    from minparam_cli.api.model_file import read_robot_bytes, write_identify_outputs
    from minparam_cli.dynamics.transmission import motor_side_spec
    from minparam_cli.identify.stage import identify as run
    from minparam_cli.measured.arrays import as_record, is_in_memory, registered
    from minparam_cli.model.file import saved_model

    path = opts.robot if robot is None else Path(robot)
    chain = load_identify_chain(opts, path) if chain is None else chain
    if opts.export_mjcf is not None:  # before the fit: a chain the MJCF writer cannot write
        from minparam_cli.model.export_mjcf import check_mjcf_chain

        check_mjcf_chain(chain)
    if opts.export_urdf is not None or opts.export_yaml is not None:
        from minparam_cli.model.export_robot import check_loop_exports

        check_loop_exports(chain, path, opts.export_urdf is not None, opts.export_yaml is not None)
    motor_side, scale_note = motor_side_spec(chain, opts.side, opts.current, opts.drive_gains)
    payload = opts.payload_spec()
    data_name, validate_name, test_names, records = _sources(data, opts.validate, opts.test)
    payload_name = None
    if payload is not None:
        if is_in_memory(opts.payload_data):
            records.append(as_record(opts.payload_data, "<payload>"))
            payload_name = "<payload>"
        else:
            payload_name = str(opts.payload_data)
    sopts = stage_options(opts, chain, motor_side, validate_name, test_names)
    with registered(records):
        result, art = run(chain, data_name, sopts, progress=progress)
        if payload is not None:  # identify/physical/payload.py: the second recording, with a known payload
            from minparam_cli.identify.physical.payload import payload_report

            gains_unknown = scale_note is not None
            motor = _current_matrix(chain.dof) if opts.side == "joint" else None  # joint-side currents: N = I
            result = replace(result, payload=payload_report(art.design, data_name, payload_name, sopts.data, payload,
                                                            gains_unknown, motor))
            scale_note = None if gains_unknown else scale_note  # the known mass fixed the scale
    if scale_note:  # the nominal values are in N·m, the fit in the currents' unit: no comparison to make
        result = replace(result, flags=result.flags + (scale_note,), nominal_notes=())
    if opts.current:
        result = replace(result, current=_current_section(opts, motor_side, scale_note, result.payload))
    robot_bytes = read_robot_bytes(path)
    saved = saved_model(str(path), robot_bytes, opts.load_settings(), sopts.data, sopts.seed, art, result)
    assert art.design is not None  # the stage always sets the final design
    if any(p is not None for p in (opts.export_urdf, opts.export_yaml, opts.export_mjcf)):
        from minparam_cli.api.model_file import check_exportable

        check_exportable(result.physical, chain, opts.prior)  # before anything is written
    if any(p is not None for p in (opts.save_model, opts.export_urdf, opts.export_yaml, opts.export_mjcf)):
        side_notes = write_identify_outputs(path, chain, robot_bytes, saved, result.data,
                                            None if art.physical is None else art.physical.phi,
                                            opts.save_model, opts.export_urdf, opts.export_yaml, opts.export_mjcf,
                                            _identified_gains(result))
        result = replace(result, flags=result.flags + side_notes)
    model = Model(saved=saved, design=art.design, robot=str(path), names=tuple(saved.names))
    return Identification(result=result, model=model, artifacts=art)


def _identified_gains(result) -> list[float] | None:
    """The drive gains ``--payload-data`` identified (one per motor), or None."""
    gains = None if result.payload is None else result.payload.drive_gains
    return None if gains is None else [float(e.value) for e in gains.values()]


def _current_matrix(n: int):
    import numpy as np

    return np.eye(n)


def _current_section(opts: IdentifyOptions, motor_side, scale_note, payload) -> dict[str, Any]:
    """The JSON's ``current`` section: which side, the gains the currents were read with and where they
    came from, and whether the torque unit is arbitrary (no gains, no payload to fix the scale)."""
    gains = None if motor_side is None else motor_side[2]
    if gains is not None:
        source = "--drive-gains" if opts.drive_gains is not None else (
            "drive_gains" if opts.side == "joint" else "transmission.drive_gains")
    elif payload is not None and payload.drive_gains is not None:
        source = "payload"  # identified: payload.drive_gains
    else:
        source = None
    return {"side": opts.side, "drive_gains": None if gains is None else list(gains), "gains_source": source,
            "torque_unit_arbitrary": scale_note is not None}


def run_consistency(opts: IdentifyOptions, paths: Sequence[Path], progress: Any = None,
                    requested: bool = True) -> ConsistencyResult:
    """``identify A B C --consistency``: every recording fitted alone with the declared model, and all
    together; where they disagree beyond their σ (``identify.consistency``).  ``requested``: whether
    --consistency was given (several data files without it are refused)."""
    from minparam_cli.dynamics.transmission import motor_side_spec
    from minparam_cli.identify.consistency import consistency

    chain = load_identify_chain(opts)
    motor_side, _ = motor_side_spec(chain, opts.side, opts.current, opts.drive_gains)
    if not requested:
        raise InputError(f"{len(paths)} data files given: compare several recordings with --consistency, "
                         "or give selection and test data with --validate and --test")
    for flag, value in (("--validate", opts.validate), ("--test", opts.test), ("--physical", opts.physical),
                        ("--save-model", opts.save_model)):
        if value:
            raise InputError(f"--consistency does not combine with {flag}: every recording is split into fit, "
                             "selection and test data by --split and fitted with the declared model")
    result, _ = consistency(chain, [Path(p) for p in paths], stage_options(opts, chain, motor_side, None, ()), progress)
    return replace(result, robot=chain.name)


def identify(robot: Robot | str | Path, data: Any, *, validate: Any = None, test: Any = None,
             split: Sequence[float] = (0.6, 0.2, 0.2), columns: str | dict[str, str] | None = None,
             time_unit: str = "s", topic: str | None = None, cutoff: float = 5.0, filter: bool = False,
             rate: float | None = None, decimate: int | None = None, trim_still: float | None = None,
             still_speed: float = 0.01, rest_below_still: bool = True, friction: str | Iterable[str] | None = None, rotor_inertia: bool | None = None,
             coulomb_smoothing: float | None = None, gravity: Any = None, effects: str | Iterable[str] | None = None,
             diagnose: bool = True, min_gain: float = 0.02, physical: bool = False, prior: str = "auto",
             prior_weight: float = 1e-2, geometry: str = "auto", mass_bounds: Any = None,
             total_mass: float | None = None, ols: bool = False, seed: int = 0, mimic: str | None = None,
             sigma: str = "hac", block_length: float | None = None, replicates: int = 200,
             essential: float | None = None, side: str = "joint", current: bool = False,
             drive_gains: Sequence[float] | None = None, payload_data: Any = None,
             payload_mass: float | None = None, payload_com: Sequence[float] | None = None,
             payload_inertia: Sequence[float] | None = None, progress: ProgressArg = False) -> Identification:
    """Identify the base parameters from measured joint data (``minparam identify``).

    ``data``, ``validate`` and each ``test``: a data file (CSV, .npz, ROS bag), a mapping of arrays
    ``{"t": (N,), "q": (N, dof), "dq": ..., "ddq": ..., "tau": (N, dof)}`` (dq, ddq optional: derived
    by filtering as for a file), a mapping of CSV-style columns (``t, q1.., tau1..``) or a pandas
    DataFrame with such columns.  The options are the CLI's (same names, same defaults, same checks and
    messages: ``api.options.identify.IdentifyOptions``).  The diagnosis adds the effects the selection
    data ask for; ``result.test`` is measured on data that chose nothing.  ``sigma``: "hac" (default),
    "bootstrap" or "textbook" (docs/methods/uncertainty.md), over time blocks of ``block_length`` s;
    ``essential``: the bound (%) of the essential-parameter reduction (the CLI's ``--essential
    --essential-bound``), None for none.  ``side="motor"``: the data are motor angles and torques
    (``current=True``: currents), converted with the robot's transmission; joint-side currents
    (``current=True`` alone) are scaled by per-joint gains, tau_j = k_j i_j (the robot's ``drive_gains:``
    or ``drive_gains``; none: unit gains, the torque unit arbitrary, flagged); ``payload_data`` (a second
    recording with a known payload on the last link, ``payload_mass`` kg, optionally ``payload_com``
    and ``payload_inertia``) adds the payload's identification (docs/methods/transmission.md).
    """
    path = robot_path(robot)
    base = robot.options if isinstance(robot, Robot) else None
    # cast(Any, ...): raw values (text, sequences, mappings) that the record normalises on construction (its fields: the stored types)
    opts = IdentifyOptions(
        robot=path, validate=validate, test=test, split=cast(Any, tuple(split)), columns=cast(Any, columns), time_unit=time_unit,
        topic=topic, cutoff=cutoff, force_filter=filter, rate=rate, decimate=decimate, trim_still=trim_still,
        still_speed=still_speed, rest_below_still=rest_below_still,
        friction=cast(Any, friction if friction is not None else (base.friction if base else ())),
        rotor_inertia=bool(rotor_inertia) if rotor_inertia is not None else (base.rotor_inertia if base else False),
        coulomb_smoothing=float(coulomb_smoothing) if coulomb_smoothing is not None else (base.coulomb_smoothing if base else 0.0),
        gravity=gravity if gravity is not None else (base.gravity if base else None),
        effects=cast(Any, effects), diagnose=diagnose, min_gain=min_gain, physical=physical, prior=prior,
        prior_weight=prior_weight, geometry=geometry, mass_bounds=mass_bounds, total_mass=total_mass, sigma=sigma, block_length=block_length, replicates=replicates,
        essential=essential is not None, essential_bound=10.0 if essential is None else float(essential),
        ols=ols, seed=seed, mimic=mimic if mimic is not None else (base.mimic if base else "coupled"),
        side=side, current=bool(current), drive_gains=cast(Any, drive_gains), payload_data=payload_data, payload_mass=payload_mass,
        payload_com=cast(Any, payload_com), payload_inertia=cast(Any, payload_inertia),
    )
    bar = progress_callback(progress, 1, "diagnosis")
    try:
        return run_identify(opts, data, progress=bar)
    finally:
        close(bar)


