"""`minparam platform ik|fk|workspace`: kinematics of hexapods and of the dodekapod (Dang 2013)."""

from __future__ import annotations

import sys
from enum import Enum
from pathlib import Path
from typing import Optional

import typer

from minparam_cli.cli.common import guarded, option_errors, save_png
from minparam_cli.output import Progress, check_output_path, write_output

HELP = "Kinematics of parallel platforms: hexapods and the dodekapod (Dang 2013). Inverse, forward (every assembly mode), workspace."
IK_HELP = "Inverse kinematics: leg lengths from a pose (x,y,z + roll,pitch,yaw, or position + platform normal)."
IK_EPILOG = """\b
Examples:
  minparam platform ik robots/dodekapod_dang2013.yaml --pose 0,0,200,5,-3,10
  minparam platform ik robots/dodekapod_dang2013.yaml --position 0,0,200 --normal 0.1,0,1 --yaw 10
  minparam platform ik robots/platforms/dodekapod_truss.yaml --format json

\b
Angles are in the file's angle unit (units.angle); lengths in its length unit.
R = Rz(yaw) Ry(pitch) Rx(roll) (Dang 2013 eq. 4: alpha = yaw, beta = pitch, gamma = roll).
A 12-leg truss takes node coordinates: the file's own, or --coords x1,y1,z1,...,x6,y6,z6.
Exit codes: 0 success, 1 failed computation, 2 bad input.
"""
FK_HELP = "Forward kinematics: every real assembly mode for the given leg lengths."
FK_EPILOG = """\b
Examples:
  minparam platform fk robots/dodekapod_dang2013.yaml \\
      --lengths 238.6357,269.3776,256.0046,247.4046,185.4388,190.2705
  minparam platform fk robots/dodekapod_dang2013.yaml --lengths ... --method pso --seed 1 --format json
  minparam platform fk robots/platforms/dodekapod_truss.yaml --lengths l1,...,l12 --frame B1,B2,B3

\b
Methods: exact = elimination to a degree-16 polynomial, complete for the octahedral
3-3 pattern (the paper's legs B_i P_j, i != j); pso = the paper's particle swarm
(50 particles x 50 iterations x --starts restarts) + Levenberg-Marquardt polish;
multistart = random starts + Levenberg-Marquardt; auto = exact where it applies.
Every solution reproduces the lengths to --rtol x max length.
Exit codes: 0 success (also when no real assembly exists), 1 failed computation, 2 bad input.
"""
WS_HELP = "Workspace: sample poses, keep those with every leg within its limits, count and plot them."
WS_EPILOG = """\b
Examples:
  minparam platform workspace robots/dodekapod_dang2013.yaml --plot workspace.png
  minparam platform workspace robots/dodekapod_dang2013.yaml --samples 200000 --orientation 0,10,0
  minparam platform workspace robots/platforms/hexapod_6_6.yaml --format json -o ws.json

\b
The box comes from the file's `workspace` section (x, y, z, roll, pitch, yaw
ranges); missing ranges default to |x|, |y| <= R, 0 <= z <= R and zero angles.
Exit codes: 0 success, 1 failed computation, 2 bad input.
"""


class OutFormat(str, Enum):
    table = "table"
    json = "json"


class Method(str, Enum):
    auto = "auto"
    exact = "exact"
    pso = "pso"
    multistart = "multistart"


class Side(str, Enum):
    both = "both"
    above = "above"
    below = "below"


_FILE = typer.Argument(..., help="Platform description (YAML with 'kind: platform').", show_default=False)
_FORMAT = typer.Option(OutFormat.table, "--format", "-f", help="Output format.")
_OUTPUT = typer.Option(None, "--output", "-o", help="Write to this file (atomically) instead of stdout.")
_QUIET = typer.Option(False, "--quiet", "-q", help="No progress bar on stderr.")


def _write(result, fmt: OutFormat, output) -> None:
    from minparam_cli.render.platform_text import platform_text

    write_output(platform_text(result, fmt.value), output)


# ---------------------------------------------------------------- ik


def ik(
    file: Path = _FILE,
    pose: Optional[str] = typer.Option(None, "--pose", help="x,y,z,roll,pitch,yaw (file units)."),
    position: Optional[str] = typer.Option(None, "--position", help="x,y,z of the platform origin (with --normal)."),
    normal: Optional[str] = typer.Option(None, "--normal", help="nx,ny,nz: platform normal R(0,0,1), eq. 11-15."),
    yaw: float = typer.Option(0.0, "--yaw", help="Fixed yaw alpha0 used with --normal (file angle unit)."),
    coords: Optional[str] = typer.Option(None, "--coords", help="Truss only: 18 numbers x1,y1,z1,...,x6,y6,z6."),
    fmt: OutFormat = _FORMAT,
    output: Optional[Path] = _OUTPUT,
):
    _ik(file, pose, position, normal, yaw, coords, fmt, output)


@guarded
def _ik(file, pose, position, normal, yaw, coords, fmt, output):
    from minparam_cli.api.options.platform import IKOptions
    from minparam_cli.api.platform import inverse

    with option_errors():
        result = inverse(file, IKOptions(pose=pose, position=position, normal=normal, yaw=yaw, coords=coords))
    _write(result, fmt, output)


# ---------------------------------------------------------------- fk


def fk(
    file: Path = _FILE,
    lengths: str = typer.Option(..., "--lengths", "-l", help="Leg lengths l1,...,ln in the file's leg order.",
                                show_default=False),
    method: Method = typer.Option(Method.auto, "--method", "-m", help="auto, exact, pso or multistart."),
    starts: Optional[int] = typer.Option(None, "--starts", min=1,
                                         help="pso restarts (default 30, the paper's) or multistart starts (default 200)."),
    particles: int = typer.Option(50, "--particles", min=2, help="pso: particles per swarm (paper: 50)."),
    iterations: int = typer.Option(50, "--iterations", min=1, help="pso: iterations per restart (paper: 50)."),
    seed: int = typer.Option(0, "--seed", min=0, help="Seed of the random starts (reported in the output)."),
    side: Side = typer.Option(Side.both, "--side", help="Keep both mirror images, or modes above/below the base plane."),
    rtol: float = typer.Option(1e-12, "--rtol", min=0.0, help="Accept a mode when max|l - l*| <= rtol x max l*."),
    frame: Optional[str] = typer.Option(None, "--frame", help="Truss only: three nodes of a face that fix the frame."),
    fmt: OutFormat = _FORMAT,
    output: Optional[Path] = _OUTPUT,
    quiet: bool = _QUIET,
):
    _fk(file, lengths, method, starts, particles, iterations, seed, side, rtol, frame, fmt, output, quiet)


@guarded
def _fk(file, lengths, method, starts, particles, iterations, seed, side, rtol, frame, fmt, output, quiet):
    from minparam_cli.api.options.platform import FKOptions
    from minparam_cli.api.platform import INCOMPLETE, forward, incomplete

    bar = Progress(1, f"fk {Path(file).name}", quiet)
    try:
        with option_errors():
            opts = FKOptions(lengths=lengths, method=method, starts=starts, particles=particles, iterations=iterations,
                             seed=seed, side=side, rtol=rtol, frame=frame)
            result = forward(file, opts, progress=bar)
    finally:
        bar.close()
    if not result.truss and incomplete(result) and not quiet:
        print(f"minparam: warning: {INCOMPLETE} (compare with --method multistart)", file=sys.stderr)
    _write(result, fmt, output)


# ---------------------------------------------------------------- workspace


def workspace(
    file: Path = _FILE,
    samples: int = typer.Option(20000, "--samples", "-n", min=1, help="Poses to sample."),
    orientation: Optional[str] = typer.Option(None, "--orientation",
                                              help="roll,pitch,yaw held fixed (overrides the file's angle ranges)."),
    seed: int = typer.Option(0, "--seed", min=0, help="Seed of the samples (reported in the output)."),
    plot: Optional[Path] = typer.Option(None, "--plot", help="Write a PNG of the reachable positions."),
    fmt: OutFormat = _FORMAT,
    output: Optional[Path] = _OUTPUT,
    quiet: bool = _QUIET,
):
    _workspace(file, samples, orientation, seed, plot, fmt, output, quiet)


@guarded
def _workspace(file, samples, orientation, seed, plot, fmt, output, quiet):
    from minparam_cli.api.options.platform import WorkspaceOptions
    from minparam_cli.api.platform import workspace
    from minparam_cli.render.platform_text import workspace_plot

    with option_errors():
        opts = WorkspaceOptions(samples=samples, orientation=orientation, seed=seed, plot=plot)
    for path in (plot, output):  # both checked before the sampling: a failure leaves neither
        if path is not None:
            check_output_path(Path(path))
    bar = Progress(samples, f"workspace {Path(file).name}", quiet)
    try:
        result = workspace(file, opts, progress=bar)
    finally:
        bar.close()
    if plot is not None:
        save_png(workspace_plot(result), Path(plot))
    _write(result, fmt, output)


def register(app: typer.Typer) -> None:
    """Add the `platform` sub-app with its three commands."""
    sub = typer.Typer(help=HELP, no_args_is_help=True, context_settings={"help_option_names": ["-h", "--help"]})
    sub.command(name="ik", help=IK_HELP, epilog=IK_EPILOG)(ik)
    sub.command(name="fk", help=FK_HELP, epilog=FK_EPILOG)(fk)
    sub.command(name="workspace", help=WS_HELP, epilog=WS_EPILOG)(workspace)
    app.add_typer(sub, name="platform", help=HELP)
