"""`minparam platform ik|fk|workspace`: kinematics of hexapods and of the dodekapod (Dang 2013)."""

from __future__ import annotations

import json
import sys
import time
from enum import Enum
from pathlib import Path
from typing import Optional

import typer

from minparam_cli.cli.common import guarded, option_errors, parse_floats, save_png
from minparam_cli.output import Progress, check_output_path, write_output
from minparam_cli.errors import DescriptionError

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


def _load(path: Path):
    from minparam_cli.describe.platform_yaml import load_platform

    return load_platform(Path(path))


def _render(d: dict, fmt: OutFormat, table) -> str:
    return json.dumps(d, indent=2) if fmt == OutFormat.json else table(d)


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
    import numpy as np

    from minparam_cli.kinematics.parallel import platform_report as rep
    from minparam_cli.kinematics.parallel.platform import leg_lengths, legs_within_limits, platform_model, pose_from_normal

    desc = _load(file)
    if desc.structure == "truss":
        from minparam_cli.kinematics.parallel.platform_truss import truss_lengths, truss_model

        if pose is not None or position is not None or normal is not None:
            raise typer.BadParameter("a free truss has no pose; give node coordinates with --coords", param_hint="--pose")
        model = truss_model(desc)
        c = np.array(parse_floats(coords, 18, "--coords")).reshape(6, 3) if coords is not None else model.nodes
        write_output(_render(rep.truss_ik_dict(model, c, truss_lengths(model, c)), fmt, rep.truss_ik_table), output)
        return
    if coords is not None:
        raise typer.BadParameter("--coords is for a 12-leg truss; give --pose or --position/--normal", param_hint="--coords")
    model = platform_model(desc)
    deg = desc.angle_unit == "deg"
    if pose is not None:
        if position is not None or normal is not None:
            raise typer.BadParameter("give either --pose or --position and --normal, not both", param_hint="--pose")
        q = np.array(parse_floats(pose, 6, "--pose"))
        if deg:
            q[3:] = np.radians(q[3:])
    elif position is not None and normal is not None:
        n = np.array(parse_floats(normal, 3, "--normal"))
        if not np.any(n):
            raise typer.BadParameter("the normal vector must not be zero", param_hint="--normal")
        q = pose_from_normal(parse_floats(position, 3, "--position"), n, np.radians(yaw) if deg else yaw)
    else:
        raise typer.BadParameter("give --pose x,y,z,roll,pitch,yaw or --position x,y,z with --normal nx,ny,nz",
                                 param_hint="--pose")
    lengths = leg_lengths(model, q)
    ok = legs_within_limits(model, lengths)
    write_output(_render(rep.ik_dict(model, q, lengths, ok), fmt, rep.ik_table), output)


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
    import numpy as np

    from minparam_cli.kinematics.parallel import platform_report as rep

    desc = _load(file)
    target = np.array(parse_floats(lengths, len(desc.legs), "--lengths"))
    if np.any(target <= 0):
        raise typer.BadParameter("leg lengths must be positive", param_hint="--lengths")
    if desc.structure == "truss":  # the API's truss branch: the same checks and report
        from minparam_cli.api.kinematics import truss_fk_result

        with option_errors():
            result = truss_fk_result(file, desc, target, None if frame is None else frame.split(","), seed, rtol)
        write_output(_render(result.to_dict(), fmt, rep.truss_fk_table), output)
        return
    if frame is not None:
        raise typer.BadParameter("--frame is for a 12-leg truss", param_hint="--frame")
    from minparam_cli.kinematics.parallel.platform import platform_model
    from minparam_cli.kinematics.parallel.platform_fk import forward_kinematics, octahedral_pattern
    from minparam_cli.kinematics.parallel.platform_pso import PSOSettings

    model = platform_model(desc)
    if method == Method.exact and octahedral_pattern(model) is None:
        raise DescriptionError("--method exact needs the octahedral 3-3 pattern (3 base and 3 platform nodes, "
                               "each joined to two of the other side); use pso or multistart", str(file), "legs")
    settings = PSOSettings(particles=particles, iterations=iterations)
    bar = Progress(1, f"fk {Path(file).name}", quiet)
    t0 = time.perf_counter()
    try:
        result = forward_kinematics(model, target, method.value, rng=np.random.default_rng(seed), seed=seed,
                                    settings=settings, starts=starts, rtol=rtol, side=side.value, progress=bar)
    finally:
        bar.close()
    elapsed = time.perf_counter() - t0
    if result.certificate is not None and not result.certificate.complete and not result.note and not quiet:
        print("minparam: warning: the elimination could not verify every root; some modes may be missing "
              "(compare with --method multistart)", file=sys.stderr)
    write_output(_render(rep.fk_dict(model, result, seed, elapsed), fmt, rep.fk_table), output)


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
    import numpy as np

    from minparam_cli.kinematics.parallel import platform_report as rep
    from minparam_cli.kinematics.parallel.platform import platform_model
    from minparam_cli.kinematics.parallel.platform_workspace import default_box, require_workspace, sample_workspace, workspace_figure

    desc = _load(file)
    require_workspace(desc, str(file))
    if plot is not None and Path(plot).suffix.lower() != ".png":
        raise typer.BadParameter("the plot is written as PNG; use a .png file name", param_hint="--plot")
    for path in (plot, output):  # both checked before the sampling: a failure leaves neither
        if path is not None:
            check_output_path(Path(path))
    model = platform_model(desc)
    box = list(default_box(model, dict(desc.workspace)))
    if orientation is not None:
        ang = np.array(parse_floats(orientation, 3, "--orientation"))
        if desc.angle_unit == "deg":
            ang = np.radians(ang)
        box[3:] = [(float(a), float(a)) for a in ang]
    bar = Progress(samples, f"workspace {Path(file).name}", quiet)
    t0 = time.perf_counter()
    try:
        result = sample_workspace(model, tuple(box), samples, np.random.default_rng(seed), seed=seed, progress=bar)
    finally:
        bar.close()
    d = rep.workspace_dict(model, result, time.perf_counter() - t0)
    if plot is not None:
        save_png(workspace_figure(model, result, desc.length_unit), Path(plot))
        d["plot"] = {"file": str(plot)}
    text = _render(d, fmt, rep.workspace_table)
    if plot is not None and fmt != OutFormat.json:
        text = text.rstrip("\n") + f"\n\nplot of the reachable positions written to {plot}"
    write_output(text, output)


def register(app: typer.Typer) -> None:
    """Add the `platform` sub-app with its three commands."""
    sub = typer.Typer(help=HELP, no_args_is_help=True, context_settings={"help_option_names": ["-h", "--help"]})
    sub.command(name="ik", help=IK_HELP, epilog=IK_EPILOG)(ik)
    sub.command(name="fk", help=FK_HELP, epilog=FK_EPILOG)(fk)
    sub.command(name="workspace", help=WS_HELP, epilog=WS_EPILOG)(workspace)
    app.add_typer(sub, name="platform", help=HELP)
