"""Kinematics of serial arms: ``singular`` (screw theory, Glazunov 1985).

``analyse_singular`` is the computation of ``minparam singular`` (the --plot map's file is the
caller's to write): the CLI and ``singular`` both call it.  The platforms' are in ``api.platform``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Sequence, cast

from minparam_cli.api.common import ProgressArg, close, progress_callback, robot_path
from minparam_cli.api.options.singular import SingularOptions
from minparam_cli.api.results import Robot
from minparam_cli.api.singularity import SigmaMap, Singularity, ToolPoint
from minparam_cli.errors import InputError
from minparam_cli.kinematics.defaults import DEFAULT_DAMPING, DEFAULT_EPSILON


def tool_point(desc) -> ToolPoint:
    """Which tool point O_c the analysis uses."""
    frame = desc.joints[-1].link_name if desc.convention in ("urdf", "mjcf") else "last link"
    point = (0.0, 0.0, 0.0) if desc.tool is None else tuple(float(v) for v in desc.tool)
    where = f"{frame} frame" if desc.convention in ("urdf", "mjcf") else "last link frame"
    xyz = "(" + ", ".join(f"{v:.6g}" for v in point) + ") m"
    if desc.tool_link is not None:
        source, line = f"link {desc.tool_link}", f"link {desc.tool_link}: {xyz} in the {where}"
    elif desc.tool is not None:
        source, line = "the file's 'tool' entry", f"the file's 'tool' entry: {xyz} in the {where}"
    else:
        source, line = "none given", f"none given: {xyz}, the {where}'s origin"
    return ToolPoint(desc.tool_link, (point[0], point[1], point[2]), frame, source, f"tool       {line}")


def check_joint_numbers(chain, joints, what: str) -> None:
    for j in joints:
        if not 1 <= j <= chain.n:
            raise InputError(f"{what}: joint {j} does not exist; {chain.name} has joints 1..{chain.n}")


def analyse_singular(robot: Path, opts: SingularOptions, progress=None) -> Singularity:
    """``minparam singular`` on one robot file: the local test at ``opts.q`` (with ``twist`` the
    nearest feasible twist), a scan of joints 2..n-1, the σ map of --plot (its file is the caller's
    to write) and the symbolic conditions."""
    import numpy as np

    from minparam_cli.chain import build_chain
    from minparam_cli.describe import load_description
    from minparam_cli.kinematics.serial.plucker import require_serial

    desc = load_description(robot)
    from minparam_cli.robot import require_open_chain

    require_open_chain(desc)
    if opts.tool is not None:
        from minparam_cli.describe.urdf_tool import select_tool

        desc = select_tool(desc, opts.tool)
    chain = build_chain(desc)
    require_serial(chain)
    q_si = None
    if opts.q is not None:
        if len(opts.q) != chain.n:
            raise InputError(f"--q: {chain.name} has {chain.n} joints, got {len(opts.q)} values")
        q = np.array(opts.q, dtype=float)
        q_si = np.where(chain.revolute, np.radians(q), q) if opts.degrees else q
    q_fixed = q_si if q_si is not None else np.zeros(chain.n)
    local = check = scan = smap = symbolic = None
    if q_si is not None:
        from minparam_cli.kinematics.serial import screws
        from minparam_cli.kinematics.serial.nearest_twist import check_nearest

        held = None
        if opts.hold is not None:
            check_joint_numbers(chain, opts.hold, "--hold")
            held = tuple(h - 1 for h in opts.hold)
        local = screws.analyse(chain, q_si, twist=opts.twist, epsilon=opts.epsilon, hold=held, damping=opts.damping)
        if local.twist is not None:
            check = check_nearest(local, chain, np.random.default_rng(opts.seed))
    if opts.scan:
        from minparam_cli.kinematics.serial.singular_scan import scan as run_scan

        scan = run_scan(chain, q_fixed, step=opts.step_rad, epsilon=opts.epsilon, progress=progress)
    if opts.symbolic:
        from minparam_cli.kinematics.serial.singular_symbolic import symbolic_conditions

        symbolic = symbolic_conditions(chain)
    if opts.plot is not None:
        from minparam_cli.kinematics.serial.singular_grid import sigma_map, swept_joints

        if opts.joints is None:
            sw = swept_joints(chain)
            if len(sw) < 2:
                raise InputError(f"--plot: {chain.name} has fewer than two swept joints; choose two with --joints")
            pair = (sw[0], sw[1])
        else:
            check_joint_numbers(chain, opts.joints, "--joints")
            pair = (opts.joints[0] - 1, opts.joints[1] - 1)
        smap = SigmaMap(opts.plot, pair, sigma_map(chain, q_fixed, pair, epsilon=opts.epsilon))
    return Singularity(robot=chain.name, source=str(robot), tool=tool_point(desc), chain=chain, degrees=opts.degrees,
                       seed=opts.seed, q=q_si, local=local, check=check, scan=scan, map=smap, symbolic=symbolic)


def singular(robot: Robot | str | Path, q: Sequence[float] | None = None, *, twist: Sequence[float] | None = None,
             degrees: bool = False, epsilon: float = DEFAULT_EPSILON, hold: Sequence[int] | None = None,
             damping: float = DEFAULT_DAMPING, scan: bool = False, step: float | None = None,
             symbolic: bool = False, seed: int = 0, tool: str | None = None,
             progress: ProgressArg = False) -> Singularity:
    """Singular positions by screw theory (``minparam singular``).

    ``q``: joint values in rad (m for prismatic joints; ``degrees=True`` reads revolute values in
    degrees, as the CLI does by default).  ``twist``: wx,wy,wz (rad/s), vx,vy,vz (m/s) of the tool
    point; ``hold``: joints (from 1) held at zero rate.  ``scan=True`` sweeps joints 2..n-1 with
    ``step`` (rad, or degrees with ``degrees=True``; default 15°); ``symbolic=True`` adds the
    vanishing minors.
    """
    # cast(Any, ...): raw values (text, sequences, mappings) that the record normalises on construction (its fields: the stored types)
    opts = SingularOptions(q=cast(Any, q), twist=cast(Any, twist), degrees=degrees, epsilon=epsilon, hold=cast(Any, hold), damping=damping, scan=scan,
                           step=step, symbolic=symbolic, seed=seed, tool=tool)
    path = robot_path(robot)
    bar = progress_callback(progress, 1, "scanning") if scan else None
    try:
        return analyse_singular(path, opts, progress=bar)
    finally:
        close(bar)
