"""Parallel platforms (Dang 2013): inverse and forward kinematics and the workspace of hexapods and
the dodekapod (``minparam platform ik|fk|workspace``).  ``inverse``, ``forward`` and ``workspace``
take the command's options records and are what both the command and ``minparam.platform_ik``,
``platform_fk``, ``platform_workspace`` call; poses and lengths are in the platform file's units."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any, Sequence, cast

from minparam_cli.api.common import OptionError, ProgressArg, close, progress_callback, warn
from minparam_cli.api.options.platform import FKOptions, IKOptions, WorkspaceOptions
from minparam_cli.api.platform_result import PlatformResult
from minparam_cli.errors import DescriptionError, InputError

INCOMPLETE = "the elimination could not verify every root; some modes may be missing"


def load(path: str | Path):
    """The platform description of a file (YAML with 'kind: platform')."""
    from minparam_cli.describe.platform_yaml import load_platform

    return load_platform(Path(path))


def inverse(path: str | Path, opts: IKOptions) -> PlatformResult:
    """Leg lengths from a pose (or a truss's lengths from its node coordinates)."""
    import numpy as np

    from minparam_cli.kinematics.parallel.platform import leg_lengths, legs_within_limits, platform_model, pose_from_normal

    desc = load(path)
    if desc.structure == "truss":
        from minparam_cli.kinematics.parallel.platform_truss import truss_lengths, truss_model

        if opts.pose is not None or opts.position is not None or opts.normal is not None:
            raise OptionError("--pose", "a free truss has no pose; give node coordinates with --coords")
        truss = truss_model(desc)
        if opts.coords is not None and len(opts.coords) != 18:
            raise OptionError("--coords", f"expected 18 comma-separated numbers, got {len(opts.coords)}")
        c = np.array(opts.coords).reshape(6, 3) if opts.coords is not None else truss.nodes
        return PlatformResult("ik", truss, truss=True, pose=c, leg_lengths=truss_lengths(truss, c))
    if opts.coords is not None:
        raise OptionError("--coords", "--coords is for a 12-leg truss; give --pose or --position/--normal")
    model = platform_model(desc)
    deg = desc.angle_unit == "deg"
    if opts.pose is not None:
        if opts.position is not None or opts.normal is not None:
            raise OptionError("--pose", "give either --pose or --position and --normal, not both")
        q = np.array(opts.pose)
        if deg:
            q[3:] = np.radians(q[3:])
    elif opts.position is not None and opts.normal is not None:
        q = pose_from_normal(opts.position, np.array(opts.normal), np.radians(opts.yaw) if deg else opts.yaw)
    else:
        raise OptionError("--pose", "give --pose x,y,z,roll,pitch,yaw or --position x,y,z with --normal nx,ny,nz")
    lengths = leg_lengths(model, q)
    return PlatformResult("ik", model, pose=q, leg_lengths=lengths, within=legs_within_limits(model, lengths))


def _target(desc, opts: FKOptions):
    import numpy as np

    if len(opts.lengths) != len(desc.legs):
        raise OptionError("--lengths", f"expected {len(desc.legs)} comma-separated numbers, got {len(opts.lengths)}")
    target = np.array(opts.lengths)
    if np.any(target <= 0):
        raise OptionError("--lengths", "leg lengths must be positive")
    return target


def forward(path: str | Path, opts: FKOptions, progress=None) -> PlatformResult:
    """Every real assembly mode for the leg lengths (a truss: every configuration of its nodes)."""
    import numpy as np

    desc = load(path)
    target = _target(desc, opts)
    if desc.structure == "truss":
        return _truss_forward(path, desc, target, opts)
    if opts.frame is not None:
        raise OptionError("--frame", "--frame is for a 12-leg truss")
    from minparam_cli.kinematics.parallel.platform import platform_model
    from minparam_cli.kinematics.parallel.platform_fk import forward_kinematics, octahedral_pattern
    from minparam_cli.kinematics.parallel.platform_pso import PSOSettings

    model = platform_model(desc)
    if opts.method == "exact" and octahedral_pattern(model) is None:
        raise DescriptionError("--method exact needs the octahedral 3-3 pattern (3 base and 3 platform nodes, "
                               "each joined to two of the other side); use pso or multistart", str(path), "legs")
    t0 = time.perf_counter()
    result = forward_kinematics(model, target, opts.method, rng=np.random.default_rng(opts.seed), seed=opts.seed,
                                settings=PSOSettings(particles=opts.particles, iterations=opts.iterations),
                                starts=opts.starts, rtol=opts.rtol, side=opts.side, progress=progress)
    return PlatformResult("fk", model, solved=result, seed=opts.seed, elapsed_s=time.perf_counter() - t0)


def incomplete(result: PlatformResult) -> bool:
    """Whether the elimination of an fk result could not verify every root (and said nothing else)."""
    c = result.solved.certificate
    return c is not None and not c.complete and not result.solved.note


def _truss_forward(path, desc, target, opts: FKOptions) -> PlatformResult:
    from minparam_cli.kinematics.parallel.platform_truss import truss_fk, truss_model

    model = truss_model(desc)
    face = None
    if opts.frame is not None:
        names = [n.strip() for n in opts.frame if n.strip()]
        if len(names) != 3 or any(n not in model.node_names for n in names):
            raise OptionError("--frame", f"expected three node names of {', '.join(model.node_names)}")
        i, j, k = (model.node_names.index(n) for n in names)
        face = (i, j, k)
    t0 = time.perf_counter()
    try:
        result = truss_fk(model, target, face, rtol=opts.rtol)
    except ValueError as e:
        raise InputError(f"{path}: --frame: {e}") from None
    return PlatformResult("fk", model, truss=True, solved=result, seed=opts.seed, elapsed_s=time.perf_counter() - t0)


def workspace(path: str | Path, opts: WorkspaceOptions, progress=None) -> PlatformResult:
    """Sample poses in the file's box, keep those with every leg within its limits."""
    import numpy as np

    from minparam_cli.kinematics.parallel.platform import platform_model
    from minparam_cli.kinematics.parallel.platform_workspace import default_box, require_workspace, sample_workspace

    desc = load(path)
    require_workspace(desc, str(path))
    model = platform_model(desc)
    box = list(default_box(model, dict(desc.workspace)))
    if opts.orientation is not None:
        ang = np.array(opts.orientation)
        if desc.angle_unit == "deg":
            ang = np.radians(ang)
        box[3:] = [(float(a), float(a)) for a in ang]
    t0 = time.perf_counter()
    result = sample_workspace(model, tuple(box), opts.samples, np.random.default_rng(opts.seed), seed=opts.seed,
                              progress=progress)
    return PlatformResult("workspace", model, solved=result, seed=opts.seed, elapsed_s=time.perf_counter() - t0,
                          plot=opts.plot)


def platform_ik(platform: str | Path, pose: Sequence[float] | None = None, *, position: Sequence[float] | None = None,
                normal: Sequence[float] | None = None, yaw: float = 0.0,
                coords: Sequence[float] | None = None) -> PlatformResult:
    """Inverse kinematics (``minparam platform ik``): leg lengths from a pose x,y,z,roll,pitch,yaw, or
    from a position and the platform normal (with a fixed ``yaw``), in the file's units; a 12-leg
    truss takes node coordinates (18 numbers; default: the file's)."""
    # cast(Any, ...): raw values (text, sequences, mappings) that the record normalises on construction (its fields: the stored types)
    return inverse(platform, IKOptions(pose=cast(Any, pose), position=cast(Any, position), normal=cast(Any, normal), yaw=yaw, coords=cast(Any, coords)))


def platform_fk(platform: str | Path, lengths: Sequence[float], *, method: str = "auto", starts: int | None = None,
                particles: int = 50, iterations: int = 50, seed: int = 0, side: str = "both", rtol: float = 1e-12,
                frame: Sequence[str] | None = None, progress: ProgressArg = False) -> PlatformResult:
    """Forward kinematics (``minparam platform fk``): every real assembly mode for the leg lengths.
    ``method``: "auto", "exact" (degree-16 elimination, octahedral 3-3 pattern), "pso" (the paper's
    particle swarm) or "multistart".  A free 12-leg truss gives node coordinates (in ``to_dict()``),
    in the frame of the three nodes ``frame`` (default: the first face in node order)."""
    # cast(Any, ...): raw values (text, sequences, mappings) that the record normalises on construction (its fields: the stored types)
    opts = FKOptions(lengths=cast(Any, lengths), method=method, starts=starts, particles=particles, iterations=iterations, seed=seed,
                     side=side, rtol=rtol, frame=cast(Any, frame))
    bar = progress_callback(progress, 1, f"fk {Path(platform).name}")
    try:
        result = forward(platform, opts, progress=bar)
    finally:
        close(bar)
    if not result.truss and incomplete(result):
        warn([INCOMPLETE + " (compare with method='multistart')"])
    return result


def platform_workspace(platform: str | Path, *, samples: int = 20000, orientation: Sequence[float] | None = None,
                       seed: int = 0, progress: ProgressArg = False) -> PlatformResult:
    """Workspace (``minparam platform workspace``): ``samples`` poses from ``seed`` in the file's box,
    those with every leg within its limits counted (``reachable``: their share)."""
    # cast(Any, ...): raw values (text, sequences, mappings) that the record normalises on construction (its fields: the stored types)
    opts = WorkspaceOptions(samples=samples, orientation=cast(Any, orientation), seed=seed)
    bar = progress_callback(progress, samples, f"workspace {Path(platform).name}")
    try:
        return workspace(platform, opts, progress=bar)
    finally:
        close(bar)
