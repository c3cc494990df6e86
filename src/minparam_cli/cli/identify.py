"""`minparam identify`: fit the base parameters to measured data and trace the residual to missing effects."""

from __future__ import annotations

import json
import math
from enum import Enum
from pathlib import Path
from typing import List, Optional

import typer

from minparam_cli.cli.common import MimicMode, guarded, mimic_option, parse_floats, save_png
from minparam_cli.output import Progress, write_output
from minparam_cli.cli.executor import scheduler_option

HELP = (
    "Identify the base parameters from measured joint data (CSV with a header row, .npz, or a ROS bag), find what the "
    "residual says the model lacks (friction, rotor inertia, springs, cogging, offsets, ...), add it, and "
    "report the error before and after: effects are chosen on selection data, and the final figures come from "
    "test data that chose nothing."
)
EPILOG = """\b
Examples:
  minparam simulate robots/puma560_mdh.yaml --effects coulomb,viscous --noise 0.05 -o sim.csv
  minparam identify robots/puma560_mdh.yaml sim.csv
  minparam identify robots/panda.yaml ../shared/data/panda-gaz2019/panda_exciting_traj_1.csv --plot figs/
  minparam identify robots/panda.yaml run1.csv --validate run2.csv --test run3.csv --format json -o report.json
  minparam identify robots/ur5.yaml log.csv --columns q=pos,dq=vel,tau=effort --cutoff 8
  minparam identify robots/ur5.yaml log.csv --columns 't=stamp,q=pos_{},tau={}_effort' --time-unit ms
  minparam identify robots/ur5.urdf run.mcap --topic /joint_states    (needs the [ros] extra)
  minparam identify robots/panda.yaml run.csv --friction coulomb,viscous --no-diagnose --essential
  minparam identify robots/panda.yaml a.csv b.csv c.csv --friction coulomb,viscous --consistency --plot figs/
  minparam identify robots/panda.yaml fleet/ -o models/ --jobs 2       (every recording in fleet/)
  minparam identify robots/panda.yaml fleet.csv -o models/ --scheduler tcp://head:8786   (manifest: recording,robot)

\b
Data: columns t, q1..qn, dq1..dqn, optional ddq1..ddqn, tau1..taun (rad, m, N·m, N).
Missing dq or ddq come from a zero-phase Butterworth low-pass (--cutoff, default 5 Hz)
and differentiation, then decimation.  NaN rows, non-increasing times and repeated
(sample-and-hold) rows are dropped and counted.  ROS bags (.mcap, .db3, a rosbag2
folder, .bag): sensor_msgs/JointState, joints matched by name, header stamps, effort
as torque.

Exit codes: 0 success, 1 failed computation, 2 bad input.
"""


class Prior(str, Enum):
    none = "none"
    nominal = "nominal"


class Sigma(str, Enum):
    hac = "hac"
    bootstrap = "bootstrap"
    textbook = "textbook"


class Fmt(str, Enum):
    table = "table"
    json = "json"


def _columns(text: str) -> dict[str, str]:
    from minparam_cli.measured.columns import parse_columns

    try:
        return parse_columns(text)
    except ValueError as e:
        raise typer.BadParameter(str(e), param_hint="--columns") from None


class Side(str, Enum):
    joint = "joint"
    motor = "motor"


class TimeUnit(str, Enum):
    s = "s"
    ms = "ms"
    us = "us"
    ns = "ns"


def topic_option():
    return typer.Option(None, "--topic", help="ROS bag: the sensor_msgs/JointState topic (default: the bag's only one).")


def time_unit_option():
    return typer.Option(TimeUnit.s, "--time-unit", help="Unit of the time column of a CSV or .npz file (a bag's header stamps are always read as ns).")


def identify(
    robot: Path = typer.Argument(..., help="Robot description (YAML DH/MDH or URDF).", show_default=False),
    data: List[Path] = typer.Argument(..., help="Measured data: CSV with a header row, .npz, .parquet or a ROS bag (several recordings with --consistency); or one folder or manifest CSV (recording,robot) of recordings: a batch, with -o FOLDER.", show_default=False),
    validate: Optional[Path] = typer.Option(None, "--validate", help="Selection data (scores the candidate effects) in a second file, instead of a block of DATA."),
    test: List[Path] = typer.Option([], "--test", help="Test data file, touched only by the final report (repeatable); instead of the last block of DATA."),
    split: str = typer.Option("0.6,0.2,0.2", "--split", help="Shares of DATA's time span for fit, selection and test, in that order (shares given as files are dropped)."),
    columns: str = typer.Option("", "--columns", help="Columns: t=time,q=pos,tau=effort (q, dq, ddq, tau: a prefix before the joint number 1..n or 0..n-1, a pattern with {} for the number as tau={}_effort, or a list in joint order as q=a|b|c)."),
    time_unit: TimeUnit = time_unit_option(),
    topic: Optional[str] = topic_option(),
    cutoff: float = typer.Option(5.0, "--cutoff", help="Low-pass cut-off (Hz) when velocities or accelerations are derived."),
    force_filter: bool = typer.Option(False, "--filter", help="Filter and differentiate even when dq and ddq are given."),
    rate: Optional[float] = typer.Option(None, "--rate", help="Sampling rate (Hz) to resample to; default: the median step."),
    decimate: Optional[int] = typer.Option(None, "--decimate", min=1, help="Keep one sample in K (default: about 10x the cut-off)."),
    trim_still: Optional[float] = typer.Option(None, "--trim-still", help="Cut every segment longer than this many seconds in which all joints stand still (|dq| < --still-speed)."),
    still_speed: float = typer.Option(0.01, "--still-speed", help="Speed below which a joint counts as still (rad/s or m/s)."),
    rest_below_still: bool = typer.Option(True, "--rest-below-still/--keep-slow-velocity", help="A velocity derived by the filter below --still-speed is set to 0: the joint is at rest (sign(dq) of the noise would put its Coulomb friction at ±Fc). Velocities read from the file are never changed."),
    friction: str = typer.Option("", "--friction", help="Declare friction in the model: any of coulomb,viscous,offset."),
    rotor_inertia: bool = typer.Option(False, "--rotor-inertia", help="Declare rotor inertia in the model."),
    coulomb_smoothing: float = typer.Option(0.0, "--coulomb-smoothing", help="Smooth Coulomb friction: tanh(dq/V) for sign(dq), V in rad/s (m/s), in the declared Fc columns and the diagnosis' friction effects; 0: sign."),
    gravity: Optional[str] = typer.Option(None, "--gravity", help="Gravity X,Y,Z in m/s² (overrides the file)."),
    effects: str = typer.Option("", "--effects", help="Restrict the diagnosis to these effect ids (default: the whole library)."),
    no_diagnose: bool = typer.Option(False, "--no-diagnose", help="Fit the declared model only."),
    min_gain: float = typer.Option(0.02, "--min-gain", help="Smallest share of the selection residual energy an effect must remove."),
    physical: bool = typer.Option(False, "--physical", help="Also fit the full parameters as a convex program: every link a real body (pseudo-inertia ⪰ 0), friction and rotor inertia ≥ 0 (needs the [physical] extra)."),
    prior: Prior = typer.Option(Prior.none, "--prior", help="With --physical: pull the full parameters toward the description's nominal inertias (nominal) or not (none)."),
    prior_weight: float = typer.Option(1e-3, "--prior-weight", help="With --prior nominal: weight of the prior against the mean squared weighted residual."),
    sigma: Sigma = typer.Option(Sigma.hac, "--sigma", help="Which parameter σ the report shows: hac (Newey–West over time blocks, allows for correlated residuals; default), bootstrap (block bootstrap, seeded by --seed) or textbook (σ²(WᵀW)⁻¹, assumes white residuals). See docs/methods/uncertainty.md."),
    block_length: Optional[float] = typer.Option(None, "--block-length", help="Time block (s) of the hac and bootstrap σ; default max(1 s, 5 / cut-off)."),
    replicates: int = typer.Option(200, "--replicates", help="Bootstrap replicates (--sigma bootstrap)."),
    consistency: bool = typer.Option(False, "--consistency", help="Several recordings: fit each alone (declared model) and all together, and flag the parameters on which they disagree beyond their σ (table; --plot draws error bars per recording)."),
    essential: bool = typer.Option(False, "--essential", help="Also report the essential parameters: drop the base parameter with the largest relative σ and refit until every relative σ is below --essential-bound (Pham & Gautier 1991)."),
    essential_bound: float = typer.Option(10.0, "--essential-bound", help="With --essential: the largest relative σ (%) an essential parameter may have."),
    ols: bool = typer.Option(False, "--ols", help="Ordinary least squares instead of Gautier's per-joint weighting, in the diagnosis and the final fit."),
    fmt: Fmt = typer.Option(Fmt.table, "--format", "-f", help="Output format."),
    output: Optional[Path] = typer.Option(None, "--output", "-o", help="Write the report to this file (atomically)."),
    plot: Optional[Path] = typer.Option(None, "--plot", help="Folder for PNG figures (residual vs velocity, measured vs predicted)."),
    seed: int = typer.Option(0, "--seed", help="Seed of the base-set computation and of the bootstrap (reported)."),
    save_model: Optional[Path] = typer.Option(None, "--save-model", help="Write the identified model as JSON (robot file and its hash, base set, design, parameters, data settings) for 'minparam evaluate'."),
    export_urdf: Optional[Path] = typer.Option(None, "--export-urdf", help="With --physical: write the robot as URDF with the identified masses, centres of mass and inertias."),
    export_yaml: Optional[Path] = typer.Option(None, "--export-yaml", help="With --physical, for a YAML (DH/MDH) robot: write its YAML with the identified inertials."),
    mimic: MimicMode = mimic_option(),
    side: Side = typer.Option(Side.joint, "--side", help="Which side of the gears the q and tau columns were measured on: joint, or motor (converted with the robot's transmission: q = N⁻¹θ + zero, τ = Nᵀτ_m)."),
    current: bool = typer.Option(False, "--current", help="With --side motor: the tau columns are motor currents, scaled by the transmission's drive_gains (without them the torque unit is arbitrary)."),
    payload_data: Optional[Path] = typer.Option(None, "--payload-data", help="A second recording with a known payload on the last link: identify the payload (and, with --current and no drive_gains, the drive gains) from the difference."),
    payload_mass: Optional[float] = typer.Option(None, "--payload-mass", help="With --payload-data: the payload's mass, kg."),
    payload_com: Optional[str] = typer.Option(None, "--payload-com", help="With --payload-data: the payload's centre of mass X,Y,Z in the last link's frame, m (else identified)."),
    payload_inertia: Optional[str] = typer.Option(None, "--payload-inertia", help="With --payload-com: its inertia about the centre of mass IXX,IXY,IXZ,IYY,IYZ,IZZ, kg·m² (else identified)."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress bar."),
    jobs: int = typer.Option(1, "--jobs", "-j", min=1, help="Batch (DATA a folder or manifest of recordings): parallel worker processes."),
    scheduler: Optional[str] = scheduler_option(),
):
    _identify(**locals())


def _split(text: str) -> tuple[float, float, float]:
    values = parse_floats(text, 3, "--split")
    if any(not (math.isfinite(v) and 0 <= v <= 1) for v in values) or values[0] <= 0 or sum(values) <= 0:
        raise typer.BadParameter("three shares FIT,SELECTION,TEST in [0, 1], FIT > 0", param_hint="--split")
    return tuple(values)


@guarded
def _identify(robot, data, validate, test, split, columns, time_unit, topic, cutoff, force_filter, rate, decimate, trim_still, still_speed,
              rest_below_still,
              friction, rotor_inertia, coulomb_smoothing, gravity, effects, no_diagnose, min_gain, physical, prior,
              prior_weight, sigma, block_length, replicates, consistency, essential, essential_bound, ols, fmt, output, plot, seed, save_model, export_urdf, export_yaml, mimic, quiet, jobs=1, scheduler=None,
              side="joint", current=False, payload_data=None, payload_mass=None, payload_com=None, payload_inertia=None):
    from minparam_cli.measured.records import DataOptions
    from minparam_cli.identify.diagnosis.diagnose import DiagnosisOptions
    from minparam_cli.dynamics.effects import EFFECT_IDS
    from minparam_cli.identify.stage import IdentifyOptions, identify as run
    from minparam_cli.measured.rosbag import coordinate_names
    from minparam_cli.params import FRICTION_KINDS
    from minparam_cli.robot import DeriveOptions, load_chain, require_fixed_base

    kinds = tuple(k.strip() for k in friction.split(",") if k.strip())
    for k in kinds:
        if k not in FRICTION_KINDS:
            raise typer.BadParameter(f"unknown friction kind {k!r}", param_hint="--friction")
    ids = tuple(k.strip() for k in effects.split(",") if k.strip()) or EFFECT_IDS
    for k in ids:
        if k not in EFFECT_IDS:
            raise typer.BadParameter(f"unknown effect {k!r}; expected any of {','.join(EFFECT_IDS)}", param_hint="--effects")
    shares = _split(split)
    if cutoff <= 0:
        raise typer.BadParameter("must be positive", param_hint="--cutoff")
    if rate is not None and rate <= 0:
        raise typer.BadParameter("must be positive", param_hint="--rate")
    if trim_still is not None and not (math.isfinite(trim_still) and trim_still > 0):
        raise typer.BadParameter("must be a positive number of seconds", param_hint="--trim-still")
    if not (math.isfinite(still_speed) and still_speed > 0):
        raise typer.BadParameter("must be a positive speed", param_hint="--still-speed")
    if not 0 <= min_gain < 1:
        raise typer.BadParameter("must be in [0, 1)", param_hint="--min-gain")
    if not (math.isfinite(coulomb_smoothing) and coulomb_smoothing >= 0):
        raise typer.BadParameter("must be a finite velocity >= 0 (0: sign)", param_hint="--coulomb-smoothing")
    if plot is not None:
        from minparam_cli.output import output_folder

        output_folder(plot, "--plot")  # created when missing
    if not (math.isfinite(prior_weight) and prior_weight > 0):
        raise typer.BadParameter("must be a positive number", param_hint="--prior-weight")
    if prior != Prior.none and not physical:
        raise typer.BadParameter("a prior needs --physical", param_hint="--prior")
    _check_exports(robot, physical, export_urdf, export_yaml)
    physical_opts = None
    if physical:
        from minparam_cli.identify.physical.convex import PhysicalOptions

        physical_opts = PhysicalOptions(prior=prior.value, prior_weight=prior_weight)
    g = parse_floats(gravity, 3, "--gravity") if gravity is not None else None
    _, chain = load_chain(robot, DeriveOptions(friction=kinds, rotor_inertia=rotor_inertia, gravity=g,
                                               mimic=MimicMode(mimic).value))
    require_fixed_base(chain, "identify")
    if physical and prior == Prior.nominal:  # refused before any data are read
        from minparam_cli.dynamics.bodies import nominal_problems, nominal_problems_text
        from minparam_cli.errors import InputError

        if nominal_problems(chain):
            raise InputError("--prior nominal: " + nominal_problems_text(str(robot), nominal_problems(chain)))
    chain = chain.with_coulomb_smoothing(coulomb_smoothing)
    from minparam_cli.dynamics.transmission import motor_side_spec

    motor_side, scale_note = motor_side_spec(chain, Side(side).value, current)
    payload = _payload_spec(payload_data, payload_mass, payload_com, payload_inertia)
    opts = IdentifyOptions(
        data=DataOptions(columns=_columns(columns), cutoff_hz=cutoff, force_filter=force_filter,
                         decimate=decimate, step_s=(1.0 / rate if rate else None),
                         trim_still_s=trim_still, still_speed=still_speed, rest_below_still=rest_below_still,
                         time_unit=TimeUnit(time_unit).value,
                         topic=topic, joint_names=coordinate_names(chain), motor_side=motor_side),
        split=shares,
        validate=str(validate) if validate else None,
        tests=tuple(str(t) for t in test),
        weighted=not ols,
        diagnose=not no_diagnose,
        diagnosis=DiagnosisOptions(effects=ids, min_gain=min_gain, weighted=not ols),
        seed=seed,
        physical=physical_opts,
        uncertainty=_uncertainty(sigma, block_length, replicates, seed),
        essential=_essential(essential, essential_bound),
    )
    if len(data) == 1:
        from minparam_cli.cli.identify_batch import maybe_batch
        from minparam_cli.model.file import LoadSettings

        load = LoadSettings(friction=kinds, rotor_inertia=rotor_inertia, gravity=g, coulomb_smoothing=coulomb_smoothing, mimic=MimicMode(mimic).value)
        single = {"validate": validate, "test": test, "plot": plot, "save_model": save_model, "export_urdf": export_urdf, "export_yaml": export_yaml}
        if maybe_batch(robot, data[0], opts, load, physical and prior == Prior.nominal, single, fmt == Fmt.json, output, jobs, scheduler, quiet):
            return  # a folder or a manifest of recordings: cli/identify_batch.py
    if consistency or len(data) > 1:
        from minparam_cli.cli.identify_consistency import run_consistency

        return run_consistency(chain, data, opts, consistency, fmt.value, output, plot, quiet,
                               {"--validate": validate, "--test": test, "--physical": physical, "--save-model": save_model})
    data = data[0]
    bar = Progress(1, "diagnosis", quiet)
    try:
        report, art = run(chain, data, opts, progress=bar)
    finally:
        bar.close()
    if plot is not None and art.hold is not None and art.models:
        from minparam_cli.render.identify_plots import measured_vs_predicted, residual_vs_velocity

        for k in range(1, len(art.models)):
            fig = residual_vs_velocity(art.hold, art.models[k - 1], art.models[k], f"{chain.name}: step {k}, {art.models[k][0]} (selection data)")
            save_png(fig, plot / f"residual_vs_velocity_step{k}.png")
        if len(art.models) == 1:
            save_png(residual_vs_velocity(art.hold, art.models[0], art.models[0], f"{chain.name}: rigid-body residual (selection data)"), plot / "residual_vs_velocity_step0.png")
        save_png(measured_vs_predicted(art.hold, art.models[-1], f"{chain.name}: selection-data torque"), plot / "measured_vs_predicted.png")
    if payload is not None:  # identify/physical/payload.py: a second recording with a known payload
        from minparam_cli.identify.physical.payload import payload_report

        gains_unknown = scale_note is not None
        report["payload"] = payload_report(art.design, data, payload_data, opts.data, payload, gains_unknown)
        scale_note = None if gains_unknown else scale_note  # the known mass fixed the scale
    if scale_note:
        report.setdefault("flags", []).append(scale_note)
    if save_model is not None or export_urdf is not None or export_yaml is not None:
        from minparam_cli.cli.model_files import write_identify_outputs
        from minparam_cli.model.file import LoadSettings

        load = LoadSettings(friction=kinds, rotor_inertia=rotor_inertia, gravity=g, coulomb_smoothing=coulomb_smoothing,
                            mimic=MimicMode(mimic).value)
        write_identify_outputs(robot, chain, load, opts, report, art, save_model, export_urdf, export_yaml)
    if fmt == Fmt.json:
        text = json.dumps(report, indent=2, ensure_ascii=False)
    else:
        from minparam_cli.render.identify_text import render_identify

        text = render_identify(report)
        if "payload" in report:
            from minparam_cli.render.payload_text import render_payload

            text = text.rstrip("\n") + "\n\n" + render_payload(report["payload"])
    write_output(text, output)


def _uncertainty(sigma, block_length, replicates, seed):
    from minparam_cli.identify.assess.uncertainty import UncertaintyOptions, check_options

    u = UncertaintyOptions(kind=Sigma(sigma).value, block_s=block_length, replicates=replicates, seed=seed)
    check_options(u)
    return u


def _essential(essential: bool, bound: float):
    from minparam_cli.errors import InputError

    if not (math.isfinite(bound) and bound > 0):
        raise InputError(f"--essential-bound {bound}: expected a positive percentage")
    return bound if essential else None


def _payload_spec(payload_data, mass, com, inertia):
    """The known payload (None without --payload-data); one-line refusals of incomplete options."""
    from minparam_cli.errors import InputError

    if payload_data is None:
        if any(v is not None for v in (mass, com, inertia)):
            raise InputError("--payload-mass, --payload-com and --payload-inertia need --payload-data")
        return None
    from minparam_cli.identify.physical.payload import PayloadSpec, check_spec

    spec = PayloadSpec(None if mass is None else float(mass), parse_floats(com, 3, "--payload-com") if com is not None else None,
                       parse_floats(inertia, 6, "--payload-inertia") if inertia is not None else None)
    check_spec(spec)
    return spec


def _check_exports(robot: Path, physical: bool, export_urdf, export_yaml) -> None:
    """Refuse an export the run cannot make before the fit runs (one line, exit 2)."""
    from minparam_cli.errors import InputError

    for flag, path in (("--export-urdf", export_urdf), ("--export-yaml", export_yaml)):
        if path is not None and not physical:
            raise InputError(f"{flag} needs --physical: the exported inertias are the bodies of the physical fit")
    if export_yaml is not None and robot.suffix.lower() not in (".yaml", ".yml"):
        raise InputError(f"--export-yaml needs a YAML (DH/MDH) robot; {robot} is a URDF, whose joints are not DH rows "
                         "(use --export-urdf)")


def register(app: typer.Typer) -> None:
    app.command(name="identify", help=HELP, epilog=EPILOG)(identify)
