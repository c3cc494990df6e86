"""`minparam identify`: fit the base parameters to measured data and trace the residual to missing effects."""

from __future__ import annotations

import json
from enum import Enum
from pathlib import Path
from typing import List, Optional

import typer

from minparam_cli.cli.common import MimicMode, guarded, mimic_option, option_errors, save_png
from minparam_cli.output import Progress, staged_folder, write_output
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
    auto = "auto"
    nominal = "nominal"
    none = "none"


class Geometry(str, Enum):
    auto = "auto"
    on = "on"
    none = "none"


class Sigma(str, Enum):
    hac = "hac"
    bootstrap = "bootstrap"
    textbook = "textbook"


class Fmt(str, Enum):
    table = "table"
    json = "json"


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
    robot: Path = typer.Argument(..., help="Robot description (YAML DH/MDH, URDF or MJCF .xml).", show_default=False),
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
    prior: Prior = typer.Option(Prior.auto, "--prior", help="With --physical: pull the full parameters toward the description's nominal inertials (nominal), or not (none); auto: nominal when the description has inertials."),
    prior_weight: float = typer.Option(1e-2, "--prior-weight", help="With a prior: its weight against the mean squared weighted residual (docs/methods/physical.md)."),
    geometry: Geometry = typer.Option(Geometry.auto, "--geometry", help="With --physical: keep each link's mass inside its ellipsoid (URDF collision/visual shapes; DH/MDH: around the link's segment): on, none, or auto (on when there is no prior)."),
    mass_bounds: Optional[str] = typer.Option(None, "--mass-bounds", help="With --physical: link masses in kg, LO,HI for every link or LO:HI,LO:HI,... one per link."),
    total_mass: Optional[float] = typer.Option(None, "--total-mass", help="With --physical: the moving links' masses sum to this (kg)."),
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
    export_mjcf: Optional[Path] = typer.Option(None, "--export-mjcf", help="With --physical: write the robot as a MuJoCo MJCF model (identified bodies, armature, damping, frictionloss, gravity, motors); what MJCF cannot express goes into FILE.extra.yaml."),
    mimic: MimicMode = mimic_option(),
    side: Side = typer.Option(Side.joint, "--side", help="Which side of the gears the q and tau columns were measured on: joint, or motor (converted with the robot's transmission: q = N⁻¹θ + zero, τ = Nᵀτ_m)."),
    current: bool = typer.Option(False, "--current", help="The tau columns are currents: with --side motor motor currents scaled by the transmission's drive_gains; on the joint side τ_j = k_j i_j with the robot's drive_gains or --drive-gains (without gains the torque unit is arbitrary)."),
    drive_gains: Optional[str] = typer.Option(None, "--drive-gains", help="With --current on the joint side: the drive gains k1,k2,... (τ_j = k_j i_j), instead of the robot file's drive_gains."),
    payload_data: Optional[Path] = typer.Option(None, "--payload-data", help="A second recording with a known payload on the last link: identify the payload (and, with --current and no drive_gains, the drive gains) from the difference."),
    payload_mass: Optional[float] = typer.Option(None, "--payload-mass", help="With --payload-data: the payload's mass, kg."),
    payload_com: Optional[str] = typer.Option(None, "--payload-com", help="With --payload-data: the payload's centre of mass X,Y,Z in the last link's frame, m (else identified)."),
    payload_inertia: Optional[str] = typer.Option(None, "--payload-inertia", help="With --payload-com: its inertia about the centre of mass IXX,IXY,IXZ,IYY,IYZ,IZZ, kg·m² (else identified)."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress bar."),
    jobs: int = typer.Option(1, "--jobs", "-j", min=1, help="Batch (DATA a folder or manifest of recordings): parallel worker processes."),
    scheduler: Optional[str] = scheduler_option(),
):
    _identify(**locals())


@guarded
def _identify(robot, data, validate, test, split, columns, time_unit, topic, cutoff, force_filter, rate, decimate, trim_still, still_speed,
              rest_below_still,
              friction, rotor_inertia, coulomb_smoothing, gravity, effects, no_diagnose, min_gain, physical, prior,
              prior_weight, sigma, block_length, replicates, consistency, essential, essential_bound, ols, fmt, output, plot, seed, save_model, export_urdf, export_yaml, mimic, quiet, jobs=1, scheduler=None,
              side="joint", export_mjcf=None, current=False, payload_data=None, payload_mass=None, payload_com=None, payload_inertia=None,
              drive_gains=None, geometry="auto", mass_bounds=None, total_mass=None):
    """Parse, call the API (``api.identification``), render, write."""
    from minparam_cli.api.options.identify import IdentifyOptions

    with option_errors():
        opts = IdentifyOptions(
            robot=robot, validate=validate, test=tuple(test), split=split, columns=columns, time_unit=TimeUnit(time_unit).value,
            topic=topic, cutoff=cutoff, force_filter=force_filter, rate=rate, decimate=decimate, trim_still=trim_still,
            still_speed=still_speed, rest_below_still=rest_below_still, friction=friction, rotor_inertia=rotor_inertia,
            coulomb_smoothing=coulomb_smoothing, gravity=gravity, effects=effects, diagnose=not no_diagnose,
            min_gain=min_gain, physical=physical, prior=Prior(prior).value, prior_weight=prior_weight,
            geometry=Geometry(geometry).value, mass_bounds=mass_bounds, total_mass=total_mass,
            sigma=Sigma(sigma).value, block_length=block_length, replicates=replicates, essential=essential,
            essential_bound=essential_bound, ols=ols, seed=seed, mimic=MimicMode(mimic).value, side=Side(side).value,
            current=current, drive_gains=drive_gains, payload_data=payload_data, payload_mass=payload_mass, payload_com=payload_com,
            payload_inertia=payload_inertia, save_model=save_model, export_urdf=export_urdf, export_yaml=export_yaml,
            export_mjcf=export_mjcf,
        )
        opts.check_report_path(output)
    if plot is not None:
        from minparam_cli.output import output_folder

        output_folder(plot, "--plot")  # created when missing
    if len(data) == 1:
        from minparam_cli.cli.identify_batch import maybe_batch

        single = {"validate": validate, "test": test, "plot": plot, "save_model": save_model, "export_urdf": export_urdf, "export_yaml": export_yaml,
                  "export_mjcf": export_mjcf}
        if maybe_batch(opts, data[0], single, fmt == Fmt.json, output, jobs, scheduler, quiet):
            return  # a folder or a manifest of recordings: cli/identify_batch.py
    if consistency or len(data) > 1:
        from minparam_cli.cli.identify_consistency import run_consistency

        return run_consistency(opts, data, consistency, fmt.value, output, plot, quiet)
    from minparam_cli.api.identification import run_identify

    bar = Progress(1, "diagnosis", quiet)
    try:
        ident = run_identify(opts, data[0], progress=bar)
    finally:
        bar.close()
    with staged_folder(plot) as stage:  # the figures go into --plot's folder only once all is written
        if stage is not None:
            _plots(ident, stage)
        if fmt == Fmt.json:
            text = json.dumps(ident.to_dict(), indent=2, ensure_ascii=False)
        else:
            from minparam_cli.render.identify_text import render_identify

            text = render_identify(ident.result)
        write_output(text, output)


def _plots(ident, plot: Path) -> None:
    """The figures of --plot: the residual against the velocity at every step, measured against predicted."""
    art, name = ident.artifacts, ident.robot
    if art.hold is None or not art.models:
        return
    from minparam_cli.render.identify_plots import measured_vs_predicted, residual_vs_velocity

    for k in range(1, len(art.models)):
        fig = residual_vs_velocity(art.hold, art.models[k - 1], art.models[k], f"{name}: step {k}, {art.models[k][0]} (selection data)")
        save_png(fig, plot / f"residual_vs_velocity_step{k}.png")
    if len(art.models) == 1:
        save_png(residual_vs_velocity(art.hold, art.models[0], art.models[0], f"{name}: rigid-body residual (selection data)"), plot / "residual_vs_velocity_step0.png")
    save_png(measured_vs_predicted(art.hold, art.models[-1], f"{name}: selection-data torque"), plot / "measured_vs_predicted.png")


def register(app: typer.Typer) -> None:
    app.command(name="identify", help=HELP, epilog=EPILOG)(identify)
