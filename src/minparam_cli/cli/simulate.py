"""``minparam simulate``: synthetic measured joint data for testing ``identify``.

Parses the options, calls the pure stage ``identify.simulate.simulate``,
renders CSV or npz and the truth record, writes them atomically, maps errors.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Optional

import typer

from minparam_cli.cli.common import MimicMode, guarded, mimic_option, option_errors, warning_line
from minparam_cli.output import Progress, check_output_path, is_stdout, write_output
from minparam_cli.errors import InputError

HELP = (
    "Synthetic measured data for identification: a random Fourier excitation (Swevers et al. 1997) inside the "
    "joint limits, torques from the file's inertial values (or random physically consistent ones), injected "
    "effects and Gaussian noise; writes t, q, dq, ddq, tau (SI units) as CSV or .npz, and the truth as JSON."
)

EPILOG = """\b
Examples:
  minparam simulate robots/puma560_mdh.yaml --effects coulomb,viscous --noise 0.05 -o data.csv --truth truth.json
  minparam simulate robots/planar2r.yaml --effects spring@2,cogging@1:k=12,stribeck:vs=0.05 --seed 3 -o data.npz
  minparam simulate robots/panda.yaml --effects coulomb@1-3:amp=0.5,gain:g=0.05 --duration 60 --no-ddq -o panda.csv
  minparam simulate robots/puma560_mdh.yaml --random-inertia --harmonics 3 --base-frequency 0.05 -o slow.csv

\b
Effect items: ID[@JOINTS][:key=value...], comma-separated.
  ID      coulomb viscous offset rotor_inertia stribeck asymmetric_coulomb
          spring gravity_error cogging position_error load_coulomb gain
          motor_coulomb motor_viscous motor_inertia drift
  JOINTS  2, 1-3 or 1+4-5 (numbered from 1; default: every joint)
  keys    amp=A  RMS of the injected torque in N·m or N (default: --strength
                 times the RMS of that joint's rigid-body torque)
          g=G    gain error for 'gain' (adds G·tau_rigid; default --strength)
          vs=V   Stribeck velocity, rad/s (default 0.05; on identify's grid)
          k=K    cogging (position_error) periods per revolution (default 12 (2);
                 integer 2..60)
          q0=Q   rest angle of 'spring', K·(q − Q) (default 0 rad)

\b
Columns: t, q1..qn, dq1..dqn, ddq1..ddqn, tau1..taun in s, rad or m, rad/s or
m/s, rad/s² or m/s², N·m or N.  Without -o the CSV goes to stdout.

Exit codes: 0 success, 1 failed computation, 2 bad input.
"""


def simulate(
    robot: Path = typer.Argument(..., exists=True, dir_okay=False, help="Robot file (YAML DH/MDH, URDF or MJCF .xml).", show_default=False),
    trajectory: str = typer.Option("fourier", "--trajectory", help="Excitation: fourier (a random finite Fourier series), or an excite output: its .json (the series, at --duration and --rate) or .csv (the samples as they are)."),
    effects: str = typer.Option("", "--effects", "-e", help="Effects to inject, e.g. coulomb,viscous,spring@2,cogging@3:k=12 (see below)."),
    strength: float = typer.Option(0.1, "--strength", help="Default effect size, as a fraction of each joint's rigid-body RMS torque."),
    noise: float = typer.Option(0.0, "--noise", help="Std of Gaussian noise added to every torque, N·m (N for prismatic joints)."),
    noise_q: float = typer.Option(0.0, "--noise-q", help="Std of Gaussian noise added to every q, rad (m for prismatic joints)."),
    seed: int = typer.Option(0, "--seed", help="Seed of the one random generator (written to the truth record)."),
    duration: float = typer.Option(20.0, "--duration", help="Length of the record, s."),
    rate: float = typer.Option(200.0, "--rate", help="Sampling rate, Hz."),
    harmonics: int = typer.Option(5, "--harmonics", help="Harmonics of the Fourier series."),
    base_frequency: float = typer.Option(0.1, "--base-frequency", help="Fundamental frequency of the Fourier series, Hz."),
    random_inertia: bool = typer.Option(False, "--random-inertia", help="Use random physically consistent inertial parameters instead of the file's."),
    no_ddq: bool = typer.Option(False, "--no-ddq", help="Leave out the ddq columns (identify then differentiates dq)."),
    output: Optional[Path] = typer.Option(None, "--output", "-o", help="Write here (atomically): .csv or .npz. Default: CSV on stdout."),
    truth: Optional[Path] = typer.Option(None, "--truth", help="Also write the truth record (JSON) here."),
    coulomb_smoothing: float = typer.Option(0.0, "--coulomb-smoothing", help="Smooth Coulomb friction: tanh(dq/V) for sign(dq) in the injected friction effects, V in rad/s (m/s); 0: sign."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No summary or notes on stderr."),
    mimic: MimicMode = mimic_option(),
    side: str = typer.Option("joint", "--side", help="joint, or motor: write motor angles, rates and torques through the robot's transmission (θ = N(q − zero), τ_m = N⁻ᵀτ)."),
    current: bool = typer.Option(False, "--current", help="Write currents: with --side motor τ_m / g (the transmission's drive_gains); on the joint side τ_j / k_j (the robot's drive_gains or --drive-gains)."),
    drive_gains: Optional[str] = typer.Option(None, "--drive-gains", help="With --current on the joint side: the drive gains k1,k2,... (τ_j = k_j i_j), instead of the robot file's drive_gains."),
    motor_params: str = typer.Option("", "--motor-params", help="Values of the robot's motor-side parameters to inject, e.g. Fcm6=0.06,Fvm6=6e-4,Iam6=1e-5 (motor-side units)."),
    payload_mass: Optional[float] = typer.Option(None, "--payload-mass", help="A payload on the last link: its mass, kg."),
    payload_com: Optional[str] = typer.Option(None, "--payload-com", help="Its centre of mass X,Y,Z in the last link's frame, m (default 0,0,0)."),
    payload_inertia: Optional[str] = typer.Option(None, "--payload-inertia", help="Its inertia about the centre of mass IXX,IXY,IXZ,IYY,IYZ,IZZ, kg·m² (default 0)."),
):
    _simulate(robot, trajectory, effects, strength, noise, noise_q, seed, duration, rate, harmonics, base_frequency,
              random_inertia, no_ddq, output, truth, quiet, coulomb_smoothing, mimic, side, current, motor_params,
              payload_mass, payload_com, payload_inertia, drive_gains)


@guarded
def _simulate(robot, trajectory, effects, strength, noise, noise_q, seed, duration, rate, harmonics, base_frequency,
              random_inertia, no_ddq, output, truth, quiet, coulomb_smoothing=0.0, mimic=MimicMode.coupled, side="joint",
              current=False, motor_params="", payload_mass=None, payload_com=None, payload_inertia=None, drive_gains=None):
    from minparam_cli.api.options.simulate import SimulateOptions
    from minparam_cli.api.simulation import effort_notes, prepare_simulation
    from minparam_cli.api.simulation_files import data_format, write_csv, write_npz
    from minparam_cli.render.json_text import json_text
    from minparam_cli.render.simulate_text import summary_text

    fmt = data_format(output)
    if is_stdout(truth) and (output is None or is_stdout(output)):
        raise InputError("--truth -: the data already go to stdout; give --truth or -o a file name")
    for path in (output, truth):
        if path is not None:
            check_output_path(Path(path))
    with option_errors():
        opts = SimulateOptions(
            trajectory=trajectory, effects=effects, strength=strength, noise=noise, noise_q=noise_q, seed=seed,
            duration=duration, rate=rate, harmonics=harmonics, base_frequency=base_frequency,
            random_inertia=random_inertia, ddq=not no_ddq, coulomb_smoothing=coulomb_smoothing, mimic=mimic, side=side,
            current=current, drive_gains=drive_gains, motor_params=motor_params, payload_mass=payload_mass, payload_com=payload_com,
            payload_inertia=payload_inertia)
        setup = prepare_simulation(robot, opts)
    if not quiet:
        for note in setup.notes:
            print(f"minparam: note: {note}", file=sys.stderr)
    bar = Progress(2 * setup.samples, "simulate", quiet)
    try:
        plan, stream = setup.stream(progress=bar)
        if fmt == "npz":
            write_npz(stream, opts.ddq, Path(output))
        else:
            write_csv(stream, opts.ddq, Path("-") if output is None else Path(output))
    finally:
        bar.close()
    limits = stream.limits
    if truth is not None:
        write_output(json_text(setup.record(plan, opts.ddq, limits)), Path(truth))
    if not quiet:
        sys.stderr.write(summary_text(plan, limits, setup.chain.name, seed, output, truth, setup.trajectory_label))
    for note in effort_notes(limits):
        warning_line(note)


def register(app: typer.Typer) -> None:
    app.command(name="simulate", help=HELP, epilog=EPILOG)(simulate)


