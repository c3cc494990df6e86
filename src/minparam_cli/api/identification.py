"""Identification from files or from arrays in memory, the model file, and its evaluation:
``identify``, ``Model.load/save/predict``, ``evaluate``.

``identify`` builds the same ``IdentifyOptions`` as ``minparam identify`` and calls the same stage
(``identify.stage.identify``); data held in memory are registered under a name (``<data>``,
``<validate>``, ``<test1>``...) for the call and read by the readers as a file would be
(``measured.arrays``): no file is written, and pandas is imported only by whoever made the DataFrame.
``evaluate`` shares ``open_model``, ``evaluation_setup`` and ``evaluation_report`` with the CLI.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterable, Sequence

from minparam_cli.api.common import ProgressArg, choice, close, friction_kinds, gravity3, progress_callback, robot_path
from minparam_cli.api.model_file import open_model
from minparam_cli.api.results import Errors, Evaluation, Identification, Model, Robot
from minparam_cli.errors import InputError

if TYPE_CHECKING:
    import numpy as np

    from minparam_cli.measured.records import DataOptions
    from minparam_cli.identify.passes.design import Design
    from minparam_cli.model.file import SavedModel

TIME_UNITS = ("s", "ms", "us", "ns")
PRIORS = ("none", "nominal")


def _positive(value: float | None, what: str, message: str = "must be positive") -> None:
    if value is not None and not (math.isfinite(value) and value > 0):
        raise InputError(f"{what}: {message}, got {value!r}")


def _columns(columns: str | dict[str, str] | None) -> dict[str, str]:
    from minparam_cli.measured.columns import parse_columns, spec_problem

    if columns is None:
        return {}
    if isinstance(columns, str):
        try:
            return parse_columns(columns)
        except ValueError as e:
            raise InputError(f"columns: {e}") from None
    out = {str(k): str(v) for k, v in columns.items()}
    for k, v in out.items():
        problem = spec_problem(k, v)
        if problem:
            raise InputError(f"columns: {problem}")
    return out


def _sources(data: Any, validate: Any, test: Any) -> tuple[Any, Any, tuple[Any, ...], list]:
    """Paths as they are; records held in memory registered under <data>, <validate>, <test1>..."""
    from minparam_cli.measured.arrays import as_record, is_in_memory

    records = []

    def one(x: Any, name: str) -> Any:
        if x is None:
            return None
        if is_in_memory(x):
            records.append(as_record(x, name))
            return name
        if isinstance(x, (str, Path)):
            return str(x)
        raise InputError(f"{name.strip('<>')}: expected a file path, a mapping of arrays or a pandas DataFrame, "
                         f"got {type(x).__name__}")

    tests = [test] if test is not None and (isinstance(test, (str, Path)) or is_in_memory(test)) else list(test or ())
    return (one(data, "<data>"), one(validate, "<validate>"),
            tuple(one(t, f"<test{k + 1}>") for k, t in enumerate(tests)), records)


def _payload(data: Any, mass: float | None, com: Sequence[float] | None, inertia: Sequence[float] | None):
    """The known payload of ``payload_data`` (None without it); the CLI's one-line refusals."""
    if data is None:
        if any(v is not None for v in (mass, com, inertia)):
            raise InputError("--payload-mass, --payload-com and --payload-inertia need --payload-data")
        return None
    from minparam_cli.identify.physical.payload import PayloadSpec, check_spec

    def floats(values, count: int, what: str):
        if values is None:
            return None
        out = tuple(float(v) for v in values)
        if len(out) != count or not all(math.isfinite(v) for v in out):
            raise InputError(f"{what}: expected {count} finite numbers, got {list(values)!r}")
        return out

    spec = PayloadSpec(None if mass is None else float(mass), floats(com, 3, "payload_com"),
                       floats(inertia, 6, "payload_inertia"))
    check_spec(spec)
    return spec


def identify(robot: Robot | str | Path, data: Any, *, validate: Any = None, test: Any = None,
             split: Sequence[float] = (0.6, 0.2, 0.2), columns: str | dict[str, str] | None = None,
             time_unit: str = "s", topic: str | None = None, cutoff: float = 5.0, filter: bool = False,
             rate: float | None = None, decimate: int | None = None, trim_still: float | None = None,
             still_speed: float = 0.01, rest_below_still: bool = True, friction: str | Iterable[str] | None = None, rotor_inertia: bool | None = None,
             coulomb_smoothing: float | None = None, gravity: Any = None, effects: str | Iterable[str] | None = None,
             diagnose: bool = True, min_gain: float = 0.02, physical: bool = False, prior: str = "none",
             prior_weight: float = 1e-3, ols: bool = False, seed: int = 0, mimic: str | None = None,
             sigma: str = "hac", block_length: float | None = None, replicates: int = 200,
             essential: float | None = None, side: str = "joint", current: bool = False, payload_data: Any = None,
             payload_mass: float | None = None, payload_com: Sequence[float] | None = None,
             payload_inertia: Sequence[float] | None = None, progress: ProgressArg = False) -> Identification:
    """Identify the base parameters from measured joint data (``minparam identify``).

    ``data``, ``validate`` and each ``test``: a data file (CSV, .npz, ROS bag), a mapping of arrays
    ``{"t": (N,), "q": (N, dof), "dq": ..., "ddq": ..., "tau": (N, dof)}`` (dq, ddq optional: derived
    by filtering as for a file), a mapping of CSV-style columns (``t, q1.., tau1..``) or a pandas
    DataFrame with such columns.  The options are the CLI's (same names, same defaults).  The
    diagnosis adds the effects the selection data ask for; ``result.test`` is measured on data that
    chose nothing.  ``sigma``: "hac" (default), "bootstrap" or "textbook" (docs/methods/uncertainty.md),
    over time blocks of ``block_length`` s; ``essential``: the bound (%) of the essential-parameter
    reduction (the CLI's ``--essential --essential-bound``), None for none.  ``side="motor"``: the data
    are motor angles and torques (``current=True``: currents), converted with the robot's transmission;
    ``payload_data`` (a second recording with a known payload on the last link, ``payload_mass`` kg,
    optionally ``payload_com`` and ``payload_inertia``) adds the payload's identification
    (docs/methods/transmission.md).
    """
    from minparam_cli.measured.records import DataOptions
    from minparam_cli.identify.assess.uncertainty import UncertaintyOptions, check_options
    from minparam_cli.identify.diagnosis.diagnose import DiagnosisOptions
    from minparam_cli.dynamics.effects import EFFECT_IDS
    from minparam_cli.model.file import LoadSettings, saved_model
    from minparam_cli.identify.stage import IdentifyOptions, identify as run
    from minparam_cli.measured.arrays import registered
    from minparam_cli.measured.rosbag import coordinate_names
    from minparam_cli.robot import DeriveOptions, load_chain, require_fixed_base

    path = robot_path(robot)
    base = robot.options if isinstance(robot, Robot) else None
    kinds = friction_kinds(friction) if friction is not None else (base.friction if base else ())
    rotor = bool(rotor_inertia) if rotor_inertia is not None else (base.rotor_inertia if base else False)
    g = gravity3(gravity) if gravity is not None else (base.gravity if base else None)
    smoothing = float(coulomb_smoothing) if coulomb_smoothing is not None else (base.coulomb_smoothing if base else 0.0)
    mimic_mode = choice(mimic, ("coupled", "fixed"), "mimic") if mimic is not None else (base.mimic if base else "coupled")
    ids = (tuple(k.strip() for k in (effects.split(",") if isinstance(effects, str) else effects) if k.strip())
           if effects is not None else ()) or EFFECT_IDS
    for k in ids:
        if k not in EFFECT_IDS:
            raise InputError(f"effects: unknown effect {k!r}; expected any of {','.join(EFFECT_IDS)}")
    shares = tuple(float(x) for x in split)
    if (len(shares) != 3 or any(not (math.isfinite(v) and 0 <= v <= 1) for v in shares) or shares[0] <= 0
            or sum(shares) <= 0):
        raise InputError("split: three shares FIT,SELECTION,TEST in [0, 1], FIT > 0")
    _positive(cutoff, "cutoff")
    _positive(rate, "rate")
    _positive(trim_still, "trim_still", "must be a positive number of seconds")
    _positive(still_speed, "still_speed", "must be a positive speed")
    _positive(prior_weight, "prior_weight", "must be a positive number")
    if decimate is not None and decimate < 1:
        raise InputError(f"decimate: must be >= 1, got {decimate}")
    if not 0 <= min_gain < 1:
        raise InputError(f"min_gain: must be in [0, 1), got {min_gain!r}")
    if not (math.isfinite(smoothing) and smoothing >= 0):
        raise InputError("coulomb_smoothing: must be a finite velocity >= 0 (0: sign)")
    if seed < 0:
        raise InputError(f"seed: must be >= 0, got {seed}")
    unit = choice(time_unit, TIME_UNITS, "time_unit")
    uncertainty = UncertaintyOptions(kind=choice(sigma, ("hac", "bootstrap", "textbook"), "sigma"),
                                     block_s=None if block_length is None else float(block_length),
                                     replicates=int(replicates), seed=seed)
    check_options(uncertainty)
    if essential is not None and not (math.isfinite(essential) and essential > 0):
        raise InputError(f"essential: {essential}: expected a positive percentage")
    prior = choice(prior, PRIORS, "prior")
    if prior != "none" and not physical:
        raise InputError("prior: a prior needs physical=True")
    column_map = _columns(columns)
    physical_opts = None
    if physical:
        from minparam_cli.identify.physical.convex import PhysicalOptions

        physical_opts = PhysicalOptions(prior=prior, prior_weight=prior_weight)
    _, chain = load_chain(path, DeriveOptions(friction=kinds, rotor_inertia=rotor, gravity=g, mimic=mimic_mode))
    require_fixed_base(chain, "identify")
    if physical and prior == "nominal":
        from minparam_cli.dynamics.bodies import nominal_problems, nominal_problems_text

        if nominal_problems(chain):
            raise InputError("--prior nominal: " + nominal_problems_text(str(path), nominal_problems(chain)))
    chain = chain.with_coulomb_smoothing(smoothing)
    from minparam_cli.dynamics.transmission import motor_side_spec

    from minparam_cli.measured.arrays import as_record, is_in_memory

    motor_side, scale_note = motor_side_spec(chain, choice(side, ("joint", "motor"), "side"), bool(current))
    payload = _payload(payload_data, payload_mass, payload_com, payload_inertia)
    data_name, validate_name, test_names, records = _sources(data, validate, test)
    payload_name = None
    if payload is not None:
        if is_in_memory(payload_data):
            records.append(as_record(payload_data, "<payload>"))
            payload_name = "<payload>"
        else:
            payload_name = str(payload_data)
    opts = IdentifyOptions(
        data=DataOptions(columns=column_map, cutoff_hz=cutoff, force_filter=filter, decimate=decimate,
                         step_s=(1.0 / rate if rate else None), trim_still_s=trim_still, still_speed=still_speed,
                         rest_below_still=bool(rest_below_still),
                         time_unit=unit, topic=topic, joint_names=coordinate_names(chain), motor_side=motor_side),
        split=(shares[0], shares[1], shares[2]),
        validate=validate_name,
        tests=test_names,
        weighted=not ols,
        diagnose=diagnose,
        diagnosis=DiagnosisOptions(effects=ids, min_gain=min_gain, weighted=not ols),
        seed=seed,
        physical=physical_opts,
        uncertainty=uncertainty,
        essential=None if essential is None else float(essential),
    )
    bar = progress_callback(progress, 1, "diagnosis")
    try:
        with registered(records):
            report, art = run(chain, data_name, opts, progress=bar)
            if payload is not None:  # identify/physical/payload.py: the second recording, with a known payload
                from minparam_cli.identify.physical.payload import payload_report

                gains_unknown = scale_note is not None
                report["payload"] = payload_report(art.design, data_name, payload_name, opts.data, payload, gains_unknown)
                scale_note = None if gains_unknown else scale_note  # the known mass fixed the scale
    finally:
        close(bar)
    if scale_note:
        report.setdefault("flags", []).append(scale_note)
    from minparam_cli.safety import read_bounded  # the robot file's bytes, for its hash

    load = LoadSettings(friction=kinds, rotor_inertia=rotor, gravity=g, coulomb_smoothing=smoothing, mimic=mimic_mode)
    saved = saved_model(str(path), read_bounded(Path(path)), load, opts.data, opts.seed, art, report)
    assert art.design is not None  # the stage always sets the final design
    model = Model(saved=saved, design=art.design, robot=str(path), names=tuple(saved.names))
    test_doc = report["test"]
    return Identification(
        robot=report["robot"], names=tuple(saved.names), theta=saved.theta.copy(), std_percent=saved.std_percent,
        before=Errors.from_dict(report["before"]), after=Errors.from_dict(report["after"]),
        test=Errors.from_dict(test_doc.get("final")), test_rigid=Errors.from_dict(test_doc.get("rigid")),
        effects=tuple(report["effects"]), flags=tuple(report["flags"]), model=model, _report=report,
    )


# --- evaluate -----------------------------------------------------------------------------------------


@dataclass(frozen=True)
class EvaluationSetup:
    """What ``evaluate`` reads the data with: the model, its design and parameters, the data options."""

    model_file: str
    robot: str
    saved: SavedModel
    design: Design
    kind: str
    theta: np.ndarray
    data: DataOptions


def evaluation_setup(model_file: str, saved: SavedModel, robot_file: str, design: Design, which: str | None,
                     time_unit: str = "s", topic: str | None = None) -> EvaluationSetup:
    """The parameters to use (the physical fit by default when the model has one) and the model's data
    settings with these files' time unit, a bag's topic and the robot's joint names."""
    from minparam_cli.measured.rosbag import coordinate_names

    kind = which if which is not None else ("physical" if saved.physical is not None else "fit")
    theta = saved.fit_theta(kind)
    data = replace(saved.data, time_unit=time_unit, topic=topic, joint_names=coordinate_names(design.chain))
    return EvaluationSetup(model_file, robot_file, saved, design, kind, theta, data)


def evaluation_report(setup: EvaluationSetup, result: Any) -> dict:
    """The JSON report of ``minparam evaluate``."""
    m, kind = setup.saved, setup.kind
    report = {"model_file": setup.model_file, "robot": setup.robot, "parameters": len(setup.theta), **result.to_dict()}
    ident = ((m.figures.get("physical") or {}).get("test") if kind == "physical" else None)
    test = m.figures.get("test") or {}
    if kind == "fit" and test.get("final"):
        report["identify_test"] = test["final"]
    elif kind == "physical" and ident and len(ident) == 1:
        report["identify_test"] = next(iter(ident.values()))
    return report


def evaluate(model: Model | str | Path, data: Any, *, which: str | None = None, robot: str | Path | None = None,
             time_unit: str = "s", topic: str | None = None) -> Evaluation:
    """Errors of a saved model on data (``minparam evaluate``): per file and pooled.

    ``model``: a :class:`Model` or a model file; ``data``: one data set or a list of them (files,
    mappings of arrays, DataFrames), read with the model's settings.  ``which``: "physical" or "fit"
    (default: physical when the model has one).
    """
    from minparam_cli.model.evaluation import evaluate as run
    from minparam_cli.measured.arrays import as_record, is_in_memory, registered

    if isinstance(model, Model):
        saved, robot_file, design, source = model.saved, model.robot, model.design, "<model>"
    else:
        saved, robot_path_, design = open_model(model, robot)
        robot_file, source = str(robot_path_), str(model)
    if which is not None:
        which = choice(which, ("physical", "fit"), "which")
    items = [data] if isinstance(data, (str, Path)) or is_in_memory(data) else list(data)
    names, records = [], []
    for k, x in enumerate(items):
        if is_in_memory(x):
            records.append(as_record(x, f"<data{k + 1}>"))
            names.append(f"<data{k + 1}>")
        else:
            check_data_file(Path(x))
            names.append(str(x))
    setup = evaluation_setup(source, saved, robot_file, design, which, choice(time_unit, TIME_UNITS, "time_unit"), topic)
    with registered(records):
        result = run(setup.design, setup.theta, names, setup.data, setup.kind)
    report = evaluation_report(setup, result)
    return Evaluation(which=setup.kind, pooled=Errors.from_dict(report["pooled"]), files=tuple(names), _report=report)


def check_data_file(p: Path) -> None:
    """A data file must exist (a ROS bag may be a folder)."""
    from minparam_cli.measured.rosbag import is_bag

    if not p.is_file() and not (p.is_dir() and is_bag(p)):
        raise InputError(f"{p}: data file not found")
