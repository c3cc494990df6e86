"""``minparam singular``: singular positions by screw theory (Glazunov 1985).

Parses into ``SingularOptions``, calls ``api.kinematics.analyse_singular`` (what ``minparam.singular``
calls), renders with ``render.singular_text`` / ``singular_plot``, writes, maps errors.
"""

from __future__ import annotations

import json
from enum import Enum
from pathlib import Path
from typing import Any, cast

import typer

from minparam_cli.api.options.singular import DEFAULT_DAMPING, DEFAULT_EPSILON, DEFAULT_STEP_DEG
from minparam_cli.cli.common import guarded, option_errors, save_png
from minparam_cli.output import Progress, write_output

HELP = (
    "Singular positions by screw theory (Glazunov 1985): the local test at --q, the dependent joints, "
    "the reciprocal screw(s), the nearest feasible twist to --twist and the joint rates that realise it; "
    "--scan for the singular set, --plot for a map, --symbolic for the vanishing minors. "
    "Units: --q in degrees for revolute joints (radians with --rad) and metres for prismatic joints; "
    "--twist is wx,wy,wz (rad/s), vx,vy,vz (m/s, velocity of the tool point O_c), base-frame components."
)

EPILOG = """\b
Examples:
  minparam singular robots/puma560.yaml --q 10,-30,40,20,0,15
  minparam singular robots/ur5.yaml --q 10,-30,0,20,30,15 --twist 0.1,0.2,0.3,0.1,0.1,0.1 --format json
  minparam singular robots/universal15_glazunov.yaml --q 0,0,0,0.4,0,0 --twist 0.1,0.1,0.2,0.2,0.4,0.4
  minparam singular robots/puma560.yaml --scan --step 15 --plot map.png --joints 2,3
  minparam singular robots/stanford.yaml --symbolic

Units: --q in degrees for revolute joints (radians with --rad), metres for
prismatic joints.  Twists: (wx, wy, wz) in rad/s and (vx, vy, vz) in m/s, the
velocity of the tool point O_c (YAML: the file's 'tool' entry, else the last link
frame's origin; URDF: the origin of --tool LINK, else of the fixed link farthest
from the last moving link's origin, else that link's origin), base-frame components.

Exit codes: 0 success, 1 failed computation, 2 bad input.
"""


class OutputFormat(str, Enum):
    table = "table"
    json = "json"


@guarded
def singular(
    robot: Path = typer.Argument(..., exists=True, dir_okay=False, readable=True, help="Robot file: YAML DH/MDH, URDF or MJCF .xml."),
    q: str = typer.Option(None, "--q", help="Joint values, comma-separated: degrees for revolute joints (radians with --rad), metres for prismatic joints."),
    rad: bool = typer.Option(False, "--rad", help="Read revolute --q values (and --step) in radians."),
    twist: str = typer.Option(None, "--twist", help="Requested twist wx,wy,wz,vx,vy,vz: rad/s and m/s of the tool point O_c, base-frame components."),
    epsilon: float = typer.Option(DEFAULT_EPSILON, "--epsilon", help="Relative cut on sigma_min/sigma_max of the normalised screw matrix, 0 < epsilon < 1."),
    hold: str = typer.Option(None, "--hold", help="Joints (from 1) to hold at zero rate at a singular position; default: chosen from the dependent group."),
    damping: float = typer.Option(DEFAULT_DAMPING, "--damping", min=0.0, help="Damping of the damped-least-squares comparison, relative to sigma_max."),
    scan: bool = typer.Option(False, "--scan", help="Sweep joints 2..n-1 on a grid and report the singular set."),
    step: float = typer.Option(DEFAULT_STEP_DEG, "--step", help="Grid step of --scan for revolute joints: degrees (radians with --rad)."),
    plot: Path = typer.Option(None, "--plot", dir_okay=False, help="Write a PNG map of sigma_min/sigma_max over the two --joints."),
    joints: str = typer.Option(None, "--joints", help="Two joints (from 1) for the --plot map, e.g. 2,3; default: the first two swept joints."),
    symbolic: bool = typer.Option(False, "--symbolic", help="Symbolic conditions: the vanishing minors of the screw matrix (arms up to six joints)."),
    fmt: OutputFormat = typer.Option(OutputFormat.table, "--format", "-f", help="Output format."),
    output: Path = typer.Option(None, "--output", "-o", dir_okay=False, help="Write the output to this file (atomically) instead of stdout."),
    seed: int = typer.Option(0, "--seed", help="Seed of the random draws of the nearest-twist check (reported)."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress bar."),
    tool: str = typer.Option(None, "--tool", help="URDF: the link whose origin is the tool point O_c (any link rigidly attached to a moving link); default: the fixed link farthest out on the last moving link."),
):
    from minparam_cli.api.kinematics import analyse_singular
    from minparam_cli.api.options.singular import SingularOptions
    from minparam_cli.render.singular_plot import singular_map
    from minparam_cli.render.singular_text import singular_text

    with option_errors():
        # cast(Any, ...): raw values (text, sequences, mappings) that the record normalises on construction (its fields: the stored types)
        opts = SingularOptions(q=cast(Any, q), twist=cast(Any, twist), degrees=not rad, epsilon=epsilon, hold=cast(Any, hold), damping=damping, scan=scan,
                               step=step, plot=plot, joints=cast(Any, joints), symbolic=symbolic, seed=seed, tool=tool)
    bar = Progress(1, "scanning", quiet=quiet) if scan else None
    try:
        result = analyse_singular(robot, opts, progress=bar)
    finally:
        if bar is not None:
            bar.close()
    if result.map is not None:
        save_png(singular_map(result), result.map.file)
    if fmt == OutputFormat.json:
        text = json.dumps(result.to_dict(), indent=2, allow_nan=False)
    else:
        text = singular_text(result)
    write_output(text, output)


def register(app: typer.Typer) -> None:
    app.command(name="singular", help=HELP, epilog=EPILOG)(singular)
