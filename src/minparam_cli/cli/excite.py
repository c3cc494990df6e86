"""``minparam excite``: design an excitation trajectory for identification.

Parses the options and calls what ``minparam.excite`` calls (``api.excitation``:
the option checks, the chain with the declared effects and its limits, the
stage ``excite.design.design``, the JSON record); prints the notes and the
summary, writes the CSV, JSON and plot atomically, maps errors to exit codes.
"""

from __future__ import annotations

import sys
from enum import Enum
from pathlib import Path
from typing import Optional

import typer

from minparam_cli.cli.common import MimicMode, guarded, mimic_option, option_errors, save_png
from minparam_cli.output import Progress, check_output_path, write_output
from minparam_cli.errors import InputError

HELP = (
    "Design an excitation trajectory: a finite Fourier series (Swevers et al. 1997) that minimises the condition "
    "number (or log-det) of the base regressor, declared friction / rotor inertia / offsets included, within the "
    "joint position, velocity, acceleration and torque limits; writes t, q, dq, ddq as CSV and the coefficients as JSON."
)

EPILOG = """\b
Examples:
  minparam excite robots/puma560.yaml -o traj.csv --json traj.json --plot traj.png
  minparam excite robots/panda.yaml --friction coulomb,viscous --rest --harmonics 6 -o panda_traj.csv
  minparam excite robots/tx40.yaml --criterion logdet --seed 3 -o tx40.csv
  minparam excite arm.urdf --box ":,:,0.10:" -o traj.csv     # keep the tool 10 cm above the table (z >= 0.10 m)
  minparam excite robots/ur5.urdf --floor 0.05 -o traj.csv   # every link origin 5 cm above the mounting plane
  minparam excite examples/urdf/ur5_cylinders.urdf --collisions --floor 0 -o traj.csv   # links' shapes apart and above z = 0

\b
Columns: t, q1..qn, dq1..dqn, ddq1..ddqn in s, rad or m, rad/s or m/s,
rad/s² or m/s² (simulate's and identify's names).  Run it on the robot, add
the measured tau1..taun columns, and give the file to identify; or give it to
simulate --trajectory.  Without -o the CSV goes to stdout.

Exit codes: 0 success, 1 failed computation, 2 bad input.
"""


class Criterion(str, Enum):
    cond = "cond"
    logdet = "logdet"


class Scaling(str, Enum):
    columns = "columns"
    si = "si"


def excite(
    robot: Path = typer.Argument(..., exists=True, dir_okay=False, help="Robot file (YAML DH/MDH, URDF or MJCF .xml).", show_default=False),
    output: Optional[Path] = typer.Option(None, "--output", "-o", help="CSV of the samples (atomically). Default: stdout."),
    json_path: Optional[Path] = typer.Option(None, "--json", help="Also write the Fourier coefficients and the report (JSON) here."),
    plot: Optional[Path] = typer.Option(None, "--plot", help="Also write a PNG of every joint's q(t) with its limits."),
    harmonics: int = typer.Option(5, "--harmonics", help="Harmonics of the Fourier series."),
    base_frequency: float = typer.Option(0.1, "--base-frequency", help="Fundamental frequency, Hz (the period is its inverse)."),
    rate: float = typer.Option(200.0, "--rate", help="Sampling rate of the CSV, Hz."),
    periods: int = typer.Option(1, "--periods", help="Periods written to the CSV."),
    criterion: Criterion = typer.Option(Criterion.cond, "--criterion", help="cond (condition number) or logdet (D-optimal)."),
    scaling: Scaling = typer.Option(Scaling.si, "--scaling", help="Criterion of the base regressor in SI units (as FIGAROH and Gautier & Khalil), or with unit-norm columns."),
    rest: bool = typer.Option(False, "--rest", help="Start and end every period at rest (dq = ddq = 0)."),
    margin: float = typer.Option(0.1, "--margin", help="Fraction of each position range kept free at both ends, and of each rate and effort limit."),
    friction: str = typer.Option("", "--friction", help="Friction columns in the regressor, every joint: any of coulomb,viscous,offset."),
    rotor_inertia: bool = typer.Option(False, "--rotor-inertia", help="A rotor inertia column Ia per joint in the regressor."),
    box: Optional[str] = typer.Option(None, "--box", help="Cartesian box for the tool point, base frame, m: XMIN:XMAX,YMIN:YMAX,ZMIN:ZMAX (a side may be empty)."),
    point: Optional[str] = typer.Option(None, "--point", help="The point kept in --box, X,Y,Z in the last link's frame, m (default: the file's tool point, else the link origin)."),
    floor: Optional[float] = typer.Option(None, "--floor", help="Keep every link frame's origin and the tool point at least this high, m, against gravity in the base frame (a table or floor; points, not the links' volumes)."),
    collisions: bool = typer.Option(False, "--collisions", help="Keep the robot file's collision shapes (URDF <collision>, MJCF geoms; needs the [mujoco] extra) apart: non-adjacent links, and the floor with --floor."),
    clearance: Optional[float] = typer.Option(None, "--clearance", help="With --collisions: the distance kept between shapes on the optimiser's grid, m (default 0.01; the dense check after the fit asks half of it)."),
    starts: int = typer.Option(4, "--starts", help="Random starts of the optimiser (seeded)."),
    max_iterations: int = typer.Option(150, "--max-iterations", help="Iterations of SLSQP per start."),
    seed: int = typer.Option(0, "--seed", help="Seed of the random starts (written to the JSON)."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress bar, summary or notes on stderr."),
    mimic: MimicMode = mimic_option(),
):
    _excite(robot, output, json_path, plot, harmonics, base_frequency, rate, periods, criterion, scaling, rest, margin,
            friction, rotor_inertia, box, point, starts, max_iterations, seed, quiet, mimic, floor, collisions, clearance)


@guarded
def _excite(robot, output, json_path, plot, harmonics, base_frequency, rate, periods, criterion, scaling, rest, margin,
            friction, rotor_inertia, box, point, starts, max_iterations, seed, quiet, mimic=MimicMode.coupled, floor=None,
            collisions=False, clearance=None):
    from minparam_cli.api.excitation import after_notes, prepare_excite, run_excite
    from minparam_cli.api.options.excite import ExciteOptions

    with option_errors():
        opts = ExciteOptions(harmonics=harmonics, base_frequency=base_frequency, rate=rate, periods=periods,
                             criterion=criterion, scaling=scaling, rest=rest, margin=margin, friction=friction,
                             rotor_inertia=rotor_inertia, box=box, point=point, floor=floor, collisions=collisions, clearance=clearance, starts=starts,
                             max_iterations=max_iterations, seed=seed, mimic=mimic)
    if plot is not None and Path(plot).suffix.lower() != ".png":
        raise InputError(f"--plot {plot}: expected a .png file name")
    for path in (output, json_path, plot):
        if path is not None:
            check_output_path(Path(path))
    prep = prepare_excite(robot, opts)
    if not quiet:
        for note in prep.notes:
            print(f"minparam: note: {note}", file=sys.stderr)
    bar = Progress(opts.starts * opts.max_iterations, "excite", quiet)
    try:
        result = run_excite(prep, bar)
    finally:
        bar.close()

    write_output(result.to_csv(), output)
    if json_path is not None:
        from minparam_cli.render.json_text import json_text

        write_output(json_text(result.to_dict()), Path(json_path))
    if plot is not None:
        from minparam_cli.render.excite_plot import render_trajectory

        save_png(render_trajectory(result.design, prep.chain.coordinate_types), Path(plot))
    if not quiet:
        sys.stderr.write(result.summary())
        for note in after_notes(prep, result):
            print(f"minparam: note: {note}", file=sys.stderr)


def register(app: typer.Typer) -> None:
    app.command(name="excite", help=HELP, epilog=EPILOG)(excite)
