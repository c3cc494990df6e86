"""The two commands over robot files, one file at a time: ``derive_file`` (``minparam derive``) and
``check_file`` (``minparam check``).  The command line calls them for each file (in worker processes
or on a Dask cluster for a batch), ``minparam.derive`` and ``minparam.check`` for one."""

from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Callable

from minparam_cli.api.check_result import CheckResult, TransmissionSummary

if TYPE_CHECKING:
    from minparam_cli.api.options.derive import DeriveOptions
    from minparam_cli.base.result import BaseSet


def derive_file(path: str | Path, opts: DeriveOptions, progress: Callable[[int, int], None] | None = None) -> BaseSet:
    """The base set of one robot file with its derivation (``to_dict()``: the derive JSON)."""
    return derive_all(path, opts, progress)[0]


def derive_all(path: str | Path, opts: DeriveOptions, progress: Callable[[int, int], None] | None = None):
    """``derive_file``'s base set with what it was made from: (BaseSet, description, chain)."""
    from minparam_cli.base.report import Derivation, RobotSummary
    from minparam_cli.dynamics.bodies import body_problems, problems_text
    from minparam_cli.robot import load_chain

    t0 = time.perf_counter()
    desc, chain = load_chain(path, opts.stage(), loops=True)
    if desc.loops is not None:  # a closed chain: the actuated torques through the loops (loops/derive.py)
        from minparam_cli.loops.derive import derive_closed

        base = derive_closed(desc, chain, opts.samples, opts.seed, opts.method, bool(opts.symbolic or opts.symbolic_numbers))
    elif opts.method == "projection":
        from minparam_cli.base.projection import derive_projection

        base = derive_projection(chain, progress=progress)
    else:
        from minparam_cli.base.qr import derive_qr

        base = derive_qr(chain, samples=opts.samples, seed=opts.seed)
    warnings: tuple[str, ...] = ()
    problems = body_problems(desc)
    if problems:  # derive never uses them: a warning, not an error
        warnings = (problems_text(desc, problems) + "; derive does not use them, simulate and --prior nominal refuse them",)
    snap = None
    if opts.snap_angles is not None:
        snap = {"tolerance_rad": opts.snap_angles, "changed": [dict(a) for a in desc.adjustments]}
    weak: tuple = ()
    if base.rank_margin.get("weak") and desc.loops is None:
        from minparam_cli.base.weak import weak_parameters

        weak = tuple(weak_parameters(chain, base, explain=True, samples=opts.samples, seed=opts.seed))
    symbolic = None
    if opts.symbolic or opts.symbolic_numbers:
        from minparam_cli.base.symbolic import add_symbolic

        symbolic = add_symbolic(desc, chain, base, numbers=opts.symbolic_numbers)
    summary = RobotSummary.of(chain)
    if desc.loops is not None:  # the robot's degrees of freedom are its actuated joints, not the tree's
        summary = replace(summary, dof=base.extra["closed_chain"]["mobility"], convention=f"closed chain, {chain.n} tree joints")
    derivation = Derivation(summary, warnings, snap, weak, symbolic, time.perf_counter() - t0)
    return replace(base, derivation=derivation), desc, chain


def check_file(path: str | Path) -> CheckResult:
    """Validate a description; raises ``DescriptionError`` when it is invalid."""
    import numpy as np

    from minparam_cli.chain import build_chain
    from minparam_cli.describe import load_description
    from minparam_cli.dynamics.bodies import body_verdicts, problems_text
    from minparam_cli.errors import DescriptionError

    desc = load_description(path)
    chain = build_chain(desc)
    if desc.loops is not None:  # the loops close, leave the mechanism mobile and are driven by the actuated joints
        from minparam_cli.loops.model import closed_model

        closed_model(desc, chain)
    verdicts = body_verdicts(desc)
    problems = [(link, problem) for link, problem in verdicts if problem is not None]
    if problems:
        raise DescriptionError(problems_text(desc, problems, shown=len(problems)))
    return CheckResult(
        robot=desc.name, source=str(path), dof=desc.dof, convention=desc.convention,
        joint_types="".join("R" if t == "revolute" else "P" for t in chain.types),
        branched=any(chain.parents[j] != j - 1 for j in range(chain.n)),
        exact=chain.exact is not None, inertial=chain.phi_nominal is not None,
        finite=bool(np.all(np.isfinite(chain.pre)) and np.all(np.isfinite(chain.post))),
        # per link with inertial values: a real body (an impossible one makes the file fail above)
        bodies=tuple(dict.fromkeys(link for link, _ in verdicts)),
        # the declared transmission, validated at the loader (square, finite, invertible N)
        transmission=_transmission(chain),
    )


def _transmission(chain) -> TransmissionSummary | None:
    if chain.transmission is None:
        return None
    import numpy as np

    from minparam_cli.dynamics.transmission import coupled_motors, motor_matrix

    N = motor_matrix(chain)
    return TransmissionSummary(int(N.shape[0]), tuple(k + 1 for k in coupled_motors(N)), float(np.linalg.cond(N)),
                               chain.transmission.drive_gains is not None)
