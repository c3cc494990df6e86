"""Kinematics: ``singular`` (screw theory, Glazunov 1985) for serial arms, and the platform
inverse/forward kinematics and workspace (Dang 2013).

``singular_analysis`` is the computation and JSON of ``minparam singular`` (less the --plot map,
a file): the CLI and ``singular`` both call it.  The platform functions call the same stages and
report builders (``kinematics.parallel.platform_report``) as ``minparam platform ik|fk|workspace``; poses and
lengths are in the platform file's units, as on the command line.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

from minparam_cli.api.common import OptionError, ProgressArg, choice, close, progress_callback, robot_path, warn
from minparam_cli.api.results import PlatformResult, Robot, Singularity
from minparam_cli.errors import DescriptionError, InputError
from minparam_cli.kinematics.defaults import DEFAULT_DAMPING, DEFAULT_EPSILON, DEFAULT_STEP_DEG


@dataclass
class SingularAnalysis:
    """The JSON document of ``minparam singular`` and the results its tables are rendered from."""

    doc: dict
    local: Any = None  # screws.SingularReport
    check: Any = None  # the nearest-twist check
    scan: Any = None
    symbolic: Any = None


def tool_report(desc) -> tuple[dict, str]:
    """Which tool point O_c the analysis uses: (JSON record, table line)."""
    frame = desc.joints[-1].link_name if desc.convention == "urdf" else "last link"
    point = (0.0, 0.0, 0.0) if desc.tool is None else tuple(float(v) for v in desc.tool)
    where = f"{frame} frame" if desc.convention == "urdf" else "last link frame"
    xyz = "(" + ", ".join(f"{v:.6g}" for v in point) + ") m"
    if desc.tool_link is not None:
        source, line = f"link {desc.tool_link}", f"link {desc.tool_link}: {xyz} in the {where}"
    elif desc.tool is not None:
        source, line = "the file's 'tool' entry", f"the file's 'tool' entry: {xyz} in the {where}"
    else:
        source, line = "none given", f"none given: {xyz}, the {where}'s origin"
    doc = {"link": desc.tool_link, "point": list(point), "frame": frame, "source": source}
    return doc, f"tool       {line}"


def check_joint_numbers(chain, joints, what: str) -> None:
    for j in joints:
        if not 1 <= j <= chain.n:
            raise InputError(f"{what}: joint {j} does not exist; {chain.name} has joints 1..{chain.n}")


def singular_analysis(desc, chain, source: str, q_si=None, *, twist=None, epsilon: float = DEFAULT_EPSILON,
                      hold: Sequence[int] | None = None, damping: float = DEFAULT_DAMPING, seed: int = 0,
                      scan_step: float | None = None, symbolic: bool = False, progress=None) -> SingularAnalysis:
    """The local test at ``q_si`` (SI units; with ``twist`` the nearest feasible twist, ``hold`` joints
    numbered from 1), a scan of joints 2..n-1 on a grid of ``scan_step`` rad, and the symbolic
    conditions: JSON sections in the CLI's order."""
    import numpy as np

    from minparam_cli.kinematics.serial import screws
    from minparam_cli.kinematics.serial.nearest_twist import check_nearest
    from minparam_cli.render.singular_text import local_json, scan_json, symbolic_json

    tool_doc, _ = tool_report(desc)
    out = SingularAnalysis({"robot": chain.name, "source": str(source), "tool": tool_doc})
    if q_si is not None:
        held = None
        if hold is not None:
            check_joint_numbers(chain, hold, "--hold")
            held = tuple(h - 1 for h in hold)
        out.local = screws.analyse(chain, q_si, twist=twist, epsilon=epsilon, hold=held, damping=damping)
        if out.local.twist is not None:
            out.check = check_nearest(out.local, chain, np.random.default_rng(seed))
        out.doc.update(local_json(out.local, out.check, seed))
    if scan_step is not None:
        from minparam_cli.kinematics.serial.singular_scan import scan as run_scan

        q_fixed = q_si if q_si is not None else np.zeros(chain.n)
        out.scan = run_scan(chain, q_fixed, step=scan_step, epsilon=epsilon, progress=progress)
        out.doc["scan"] = scan_json(out.scan)
    if symbolic:
        from minparam_cli.kinematics.serial.singular_symbolic import symbolic_conditions

        out.symbolic = symbolic_conditions(chain)
        out.doc["symbolic"] = symbolic_json(out.symbolic)
    return out


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
    import numpy as np

    from minparam_cli.chain import build_chain
    from minparam_cli.describe import load_description
    from minparam_cli.kinematics.serial.plucker import require_serial
    from minparam_cli.render.singular_text import json_safe

    if not (math.isfinite(epsilon) and 0 < epsilon < 1):
        raise InputError(f"epsilon: expected a number between 0 and 1 (exclusive), got {epsilon:g}")
    if q is None and (twist is not None or hold is not None):
        raise InputError("--twist and --hold need a configuration --q")
    if q is None and not (scan or symbolic):
        raise InputError("give --q for the local test, or --scan, --plot or --symbolic")
    path = robot_path(robot)
    desc = load_description(path)
    if tool is not None:
        from minparam_cli.describe.urdf_tool import select_tool

        desc = select_tool(desc, tool)
    chain = build_chain(desc)
    require_serial(chain)
    q_si = None
    if q is not None:
        values = np.asarray(q, dtype=float).reshape(-1)
        if len(values) != chain.n:
            raise InputError(f"--q: {chain.name} has {chain.n} joints, got {len(values)} values")
        if not np.all(np.isfinite(values)):
            raise InputError("q: expected finite numbers")
        q_si = np.where(chain.revolute, np.radians(values), values) if degrees else values
    tw = None
    if twist is not None:
        tw = tuple(float(x) for x in twist)
        if len(tw) != 6 or not all(math.isfinite(x) for x in tw):
            raise InputError("twist: expected six finite numbers wx,wy,wz,vx,vy,vz")
    step_rad = None
    if scan:
        step_value = (DEFAULT_STEP_DEG if degrees else math.radians(DEFAULT_STEP_DEG)) if step is None else step
        if not (math.isfinite(step_value) and step_value > 0):
            raise InputError(f"step: expected a positive step, got {step_value:g}")
        step_rad = math.radians(step_value) if degrees else step_value
    bar = progress_callback(progress, 1, "scanning") if scan else None
    try:
        out = singular_analysis(desc, chain, str(path), q_si, twist=tw, epsilon=epsilon,
                                hold=tuple(hold) if hold is not None else None, damping=damping, seed=seed,
                                scan_step=step_rad, symbolic=symbolic, progress=bar)
    finally:
        close(bar)
    doc = json_safe(out.doc)
    return Singularity(robot=chain.name, singular=doc.get("singular"),
                       sigma_ratio=doc.get("sigma_min"),
                       dependent=tuple(tuple(g) for g in doc.get("dependent_groups", [])), _report=doc)


# --- platforms ----------------------------------------------------------------------------------------


def _platform(path: str | Path):
    from minparam_cli.describe.platform_yaml import load_platform

    return load_platform(Path(path))


def _numbers(values: Any, count: int | None, what: str):
    import numpy as np

    try:
        a = np.asarray(values, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise InputError(f"{what}: expected numbers, got {values!r}") from None
    if count is not None and len(a) != count:
        raise InputError(f"{what}: expected {count} numbers, got {len(a)}")
    if not np.all(np.isfinite(a)):
        raise InputError(f"{what}: expected finite numbers")
    return a


def platform_ik(platform: str | Path, pose: Sequence[float] | None = None, *, position: Sequence[float] | None = None,
                normal: Sequence[float] | None = None, yaw: float = 0.0,
                coords: Sequence[float] | None = None) -> PlatformResult:
    """Inverse kinematics (``minparam platform ik``): leg lengths from a pose x,y,z,roll,pitch,yaw, or
    from a position and the platform normal (with a fixed ``yaw``), in the file's units; a 12-leg
    truss takes node coordinates (18 numbers; default: the file's)."""
    import numpy as np

    from minparam_cli.kinematics.parallel import platform_report as rep
    from minparam_cli.kinematics.parallel.platform import leg_lengths, legs_within_limits, platform_model, pose_from_normal

    desc = _platform(platform)
    if desc.structure == "truss":
        from minparam_cli.kinematics.parallel.platform_truss import truss_lengths, truss_model

        if pose is not None or position is not None or normal is not None:
            raise InputError("pose: a free truss has no pose; give node coordinates with coords")
        truss = truss_model(desc)
        c = _numbers(coords, 18, "coords").reshape(6, 3) if coords is not None else truss.nodes
        d = rep.truss_ik_dict(truss, c, truss_lengths(truss, c))
        return PlatformResult("ik", lengths=tuple(d["lengths"]), _report=d)
    if coords is not None:
        raise InputError("coords: for a 12-leg truss; give pose or position and normal")
    model = platform_model(desc)
    deg = desc.angle_unit == "deg"
    if pose is not None:
        if position is not None or normal is not None:
            raise InputError("pose: give either pose or position and normal, not both")
        q = _numbers(pose, 6, "pose")
        if deg:
            q[3:] = np.radians(q[3:])
    elif position is not None and normal is not None:
        n = _numbers(normal, 3, "normal")
        if not np.any(n):
            raise InputError("normal: the normal vector must not be zero")
        q = pose_from_normal(tuple(_numbers(position, 3, "position")), n, np.radians(yaw) if deg else yaw)
    else:
        raise InputError("pose: give pose x,y,z,roll,pitch,yaw or position x,y,z with normal nx,ny,nz")
    lengths = leg_lengths(model, q)
    d = rep.ik_dict(model, q, lengths, legs_within_limits(model, lengths))
    return PlatformResult("ik", lengths=tuple(d["lengths"]), _report=d)


def platform_fk(platform: str | Path, lengths: Sequence[float], *, method: str = "auto", starts: int | None = None,
                particles: int = 50, iterations: int = 50, seed: int = 0, side: str = "both", rtol: float = 1e-12,
                frame: Sequence[str] | None = None, progress: ProgressArg = False) -> PlatformResult:
    """Forward kinematics (``minparam platform fk``): every real assembly mode for the leg lengths.
    ``method``: "auto", "exact" (degree-16 elimination, octahedral 3-3 pattern), "pso" (the paper's
    particle swarm) or "multistart".  A free 12-leg truss gives node coordinates (in ``to_dict()``),
    in the frame of the three nodes ``frame`` (default: the first face in node order)."""
    import numpy as np

    from minparam_cli.kinematics.parallel import platform_report as rep
    from minparam_cli.kinematics.parallel.platform import platform_model
    from minparam_cli.kinematics.parallel.platform_fk import forward_kinematics, octahedral_pattern
    from minparam_cli.kinematics.parallel.platform_pso import PSOSettings

    desc = _platform(platform)
    if desc.structure == "truss":
        return truss_fk_result(platform, desc, lengths, frame, seed, rtol)
    if frame is not None:
        raise InputError("frame: for a 12-leg truss")
    method = choice(method, ("auto", "exact", "pso", "multistart"), "method")
    side = choice(side, ("both", "above", "below"), "side")
    if seed < 0:
        raise InputError(f"seed: must be >= 0, got {seed}")
    target = _numbers(lengths, len(desc.legs), "lengths")
    if np.any(target <= 0):
        raise InputError("lengths: leg lengths must be positive")
    model = platform_model(desc)
    if method == "exact" and octahedral_pattern(model) is None:
        raise DescriptionError("--method exact needs the octahedral 3-3 pattern (3 base and 3 platform nodes, "
                               "each joined to two of the other side); use pso or multistart", str(platform), "legs")
    bar = progress_callback(progress, 1, f"fk {Path(platform).name}")
    t0 = time.perf_counter()
    try:
        result = forward_kinematics(model, target, method, rng=np.random.default_rng(seed), seed=seed,
                                    settings=PSOSettings(particles=particles, iterations=iterations), starts=starts,
                                    rtol=rtol, side=side, progress=bar)
    finally:
        close(bar)
    if result.certificate is not None and not result.certificate.complete and not result.note:
        warn(["the elimination could not verify every root; some modes may be missing (compare with method='multistart')"])
    d = rep.fk_dict(model, result, seed, time.perf_counter() - t0)
    poses = tuple(tuple(float(v) for v in s["pose"].values()) for s in d["solutions"])
    return PlatformResult("fk", lengths=tuple(d["lengths"]), poses=poses, _report=d)


def truss_fk_result(platform: str | Path, desc, lengths: Sequence[float], frame: Sequence[str] | None, seed: int,
              rtol: float) -> PlatformResult:
    """The truss branch of ``minparam platform fk`` (the command calls it too: same checks, same report)."""
    import numpy as np

    from minparam_cli.kinematics.parallel import platform_report as rep
    from minparam_cli.kinematics.parallel.platform_truss import truss_fk, truss_model

    target = _numbers(lengths, len(desc.legs), "lengths")
    if np.any(target <= 0):
        raise InputError("lengths: leg lengths must be positive")
    model = truss_model(desc)
    face = None
    if frame is not None:
        names = [str(n).strip() for n in frame if str(n).strip()]
        if len(names) != 3 or any(n not in model.node_names for n in names):
            raise OptionError("--frame", f"expected three node names of {', '.join(model.node_names)}")
        i, j, k = (model.node_names.index(n) for n in names)
        face = (i, j, k)
    t0 = time.perf_counter()
    try:
        result = truss_fk(model, target, face, rtol=rtol)
    except ValueError as e:
        raise InputError(f"{platform}: --frame: {e}") from None
    d = rep.truss_fk_dict(model, result, seed, time.perf_counter() - t0)
    return PlatformResult("fk", lengths=tuple(float(v) for v in target), _report=d)


def platform_workspace(platform: str | Path, *, samples: int = 20000, orientation: Sequence[float] | None = None,
                       seed: int = 0, progress: ProgressArg = False) -> PlatformResult:
    """Workspace (``minparam platform workspace``): ``samples`` poses from ``seed`` in the file's box,
    those with every leg within its limits counted (``reachable``: their share)."""
    import numpy as np

    from minparam_cli.kinematics.parallel import platform_report as rep
    from minparam_cli.kinematics.parallel.platform import platform_model
    from minparam_cli.kinematics.parallel.platform_workspace import default_box, require_workspace, sample_workspace

    desc = _platform(platform)
    require_workspace(desc, str(platform))
    if samples < 1 or seed < 0:
        raise InputError("samples: must be >= 1, and seed >= 0")
    model = platform_model(desc)
    box = list(default_box(model, dict(desc.workspace)))
    if orientation is not None:
        ang = _numbers(orientation, 3, "orientation")
        if desc.angle_unit == "deg":
            ang = np.radians(ang)
        box[3:] = [(float(a), float(a)) for a in ang]
    bar = progress_callback(progress, samples, f"workspace {Path(platform).name}")
    t0 = time.perf_counter()
    try:
        result = sample_workspace(model, tuple(box), samples, np.random.default_rng(seed), seed=seed, progress=bar)
    finally:
        close(bar)
    d = rep.workspace_dict(model, result, time.perf_counter() - t0)
    return PlatformResult("workspace", reachable=float(d["fraction"]), _report=d)
