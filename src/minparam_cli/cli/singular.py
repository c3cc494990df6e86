"""``minparam singular``: singular positions by screw theory (Glazunov 1985).

Parses, calls the kinematics stage (``kinematics.serial.screws``, ``singular_scan``, ``singular_grid``,
``singular_symbolic``), renders with ``render.singular_text`` / ``singular_plot``,
writes, maps errors.
"""

from __future__ import annotations

import json
import math
from enum import Enum
from pathlib import Path

import numpy as np
import typer

from minparam_cli.cli.common import guarded, parse_floats, save_png
from minparam_cli.output import Progress, write_output
from minparam_cli.errors import InputError
from minparam_cli.kinematics.defaults import DEFAULT_DAMPING, DEFAULT_EPSILON, DEFAULT_STEP_DEG
from minparam_cli.render.singular_text import json_safe, local_table, scan_table, symbolic_table

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


# --- option parsing (callbacks raise BadParameter: exit code 2 with the option named) -------------


def _floats(text: str | None, what: str, count: int | None = None) -> tuple[float, ...] | None:
    if text is None:
        return None
    vals = parse_floats(text, count, what)
    if not all(math.isfinite(v) for v in vals):
        raise typer.BadParameter(f"expected finite numbers, got {text!r}", param_hint=what)
    return vals


def _joint_list(text: str | None, what: str, count: int | None = None) -> tuple[int, ...] | None:
    if text is None:
        return None
    try:
        vals = tuple(int(p) for p in text.replace(" ", "").split(","))
    except ValueError:
        raise typer.BadParameter(f"expected joint numbers like 2,3, got {text!r}", param_hint=what) from None
    if count is not None and len(vals) != count:
        raise typer.BadParameter(f"expected {count} joint numbers, got {len(vals)}", param_hint=what)
    if any(v < 1 for v in vals):
        raise typer.BadParameter("joints are numbered from 1", param_hint=what)
    return vals


def _q_cb(text):
    return _floats(text, "--q")


def _twist_cb(text):
    return _floats(text, "--twist", 6)


def _joints_cb(text):
    return _joint_list(text, "--joints", 2)


def _hold_cb(text):
    return _joint_list(text, "--hold")


def _epsilon_cb(value: float) -> float:
    if not (math.isfinite(value) and 0 < value < 1):
        raise typer.BadParameter(f"expected a number between 0 and 1 (exclusive), got {value:g}", param_hint="--epsilon")
    return value


def _step_cb(value: float) -> float:
    if not (math.isfinite(value) and value > 0):
        raise typer.BadParameter(f"expected a positive step, got {value:g}", param_hint="--step")
    return value


def _q_to_si(chain, values, rad: bool) -> np.ndarray:
    if len(values) != chain.n:
        raise InputError(f"--q: {chain.name} has {chain.n} joints, got {len(values)} values")
    q = np.array(values, dtype=float)
    if not rad:
        q = np.where(chain.revolute, np.radians(q), q)
    return q


def _check_joint_numbers(chain, joints, what):
    for j in joints:
        if not 1 <= j <= chain.n:
            raise InputError(f"{what}: joint {j} does not exist; {chain.name} has joints 1..{chain.n}")


# --- the command --------------------------------------------------------------------------------------


@guarded
def singular(
    robot: Path = typer.Argument(..., exists=True, dir_okay=False, readable=True, help="Robot file: YAML DH/MDH or URDF."),
    q: str = typer.Option(None, "--q", callback=_q_cb, help="Joint values, comma-separated: degrees for revolute joints (radians with --rad), metres for prismatic joints."),
    rad: bool = typer.Option(False, "--rad", help="Read revolute --q values (and --step) in radians."),
    twist: str = typer.Option(None, "--twist", callback=_twist_cb, help="Requested twist wx,wy,wz,vx,vy,vz: rad/s and m/s of the tool point O_c, base-frame components."),
    epsilon: float = typer.Option(DEFAULT_EPSILON, "--epsilon", callback=_epsilon_cb, help="Relative cut on sigma_min/sigma_max of the normalised screw matrix, 0 < epsilon < 1."),
    hold: str = typer.Option(None, "--hold", callback=_hold_cb, help="Joints (from 1) to hold at zero rate at a singular position; default: chosen from the dependent group."),
    damping: float = typer.Option(DEFAULT_DAMPING, "--damping", min=0.0, help="Damping of the damped-least-squares comparison, relative to sigma_max."),
    scan: bool = typer.Option(False, "--scan", help="Sweep joints 2..n-1 on a grid and report the singular set."),
    step: float = typer.Option(DEFAULT_STEP_DEG, "--step", callback=_step_cb, help="Grid step of --scan for revolute joints: degrees (radians with --rad)."),
    plot: Path = typer.Option(None, "--plot", dir_okay=False, help="Write a PNG map of sigma_min/sigma_max over the two --joints."),
    joints: str = typer.Option(None, "--joints", callback=_joints_cb, help="Two joints (from 1) for the --plot map, e.g. 2,3; default: the first two swept joints."),
    symbolic: bool = typer.Option(False, "--symbolic", help="Symbolic conditions: the vanishing minors of the screw matrix (arms up to six joints)."),
    fmt: OutputFormat = typer.Option(OutputFormat.table, "--format", "-f", help="Output format."),
    output: Path = typer.Option(None, "--output", "-o", dir_okay=False, help="Write the output to this file (atomically) instead of stdout."),
    seed: int = typer.Option(0, "--seed", help="Seed of the random draws of the nearest-twist check (reported)."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress bar."),
    tool: str = typer.Option(None, "--tool", help="URDF: the link whose origin is the tool point O_c (any link rigidly attached to a moving link); default: the fixed link farthest out on the last moving link."),
):
    from minparam_cli.chain import build_chain
    from minparam_cli.describe import load_description

    if q is None and (twist is not None or hold is not None):
        raise InputError("--twist and --hold need a configuration --q")
    if q is None and not (scan or plot or symbolic):
        raise InputError("give --q for the local test, or --scan, --plot or --symbolic")
    desc = load_description(robot)
    if tool is not None:
        from minparam_cli.describe.urdf_tool import select_tool

        desc = select_tool(desc, tool)
    chain = build_chain(desc)
    from minparam_cli.kinematics.serial.plucker import require_serial

    require_serial(chain)
    angle = "rad" if rad else "deg"
    q_si = _q_to_si(chain, q, rad) if q is not None else None
    from minparam_cli.api.kinematics import singular_analysis, tool_report

    _, tool_line = tool_report(desc)
    bar = Progress(1, "scanning", quiet=quiet) if scan else None
    try:
        res = singular_analysis(desc, chain, str(robot), q_si, twist=twist, epsilon=epsilon, hold=hold, damping=damping,
                                seed=seed, scan_step=(step if rad else math.radians(step)) if scan else None,
                                symbolic=symbolic, progress=bar)
    finally:
        if bar is not None:
            bar.close()
    doc = res.doc
    sections: list[str] = []
    if res.local is not None:
        sections.append(local_table(res.local, res.check, seed, angle))
    if res.scan is not None:
        sections.append(scan_table(res.scan, chain.types, angle))

    if plot is not None:
        from minparam_cli.kinematics.serial.singular_grid import sigma_map, swept_joints

        if joints is None:
            sw = swept_joints(chain)
            if len(sw) < 2:
                raise InputError(f"--plot: {chain.name} has fewer than two swept joints; choose two with --joints")
            pair = (sw[0], sw[1])
        else:
            _check_joint_numbers(chain, joints, "--joints")
            pair = (joints[0] - 1, joints[1] - 1)
        q_fixed = q_si if q_si is not None else np.zeros(chain.n)
        smap = sigma_map(chain, q_fixed, pair, epsilon=epsilon)
        from minparam_cli.render.singular_plot import render_map

        save_png(render_map(smap, chain, angle, marker=q_si), plot)
        if "symbolic" in doc:  # the plot's section stays before the symbolic one in the output
            doc = {**{k: v for k, v in doc.items() if k != "symbolic"}, "plot": None, "symbolic": doc["symbolic"]}
        doc["plot"] = {"file": str(plot), "joints": [pair[0] + 1, pair[1] + 1], "points_per_axis": int(smap.x.size),
                       "sigma_min_on_map": float(smap.sigma.min())}
        sections.append(f"map of sigma_min/sigma_max over joints {pair[0] + 1} and {pair[1] + 1} written to {plot}")

    if res.symbolic is not None:
        sections.append(symbolic_table(res.symbolic, chain, angle))

    if fmt == OutputFormat.json:
        text = json.dumps(json_safe(doc), indent=2, allow_nan=False)
    else:
        header = f"robot      {chain.name}  ({robot})\n{tool_line}"
        text = "\n\n".join([header] + sections)
    write_output(text, output)


def register(app: typer.Typer) -> None:
    app.command(name="singular", help=HELP, epilog=EPILOG)(singular)
