"""Stage composition for one robot file: load -> chain -> base set -> report dict.

Pure apart from reading the robot file itself; the CLI decides what to do
with the result.  Used by ``derive`` for single files and by batch workers.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Callable

import numpy as np

from minparam_cli.robot import DeriveOptions, load_chain

def derive_file(path: str | Path, opts: DeriveOptions, progress: Callable[[int, int], None] | None = None) -> dict:
    """Report dict (the JSON contract) for one robot file."""
    return derive_all(path, opts, progress)[0]


def derive_all(path: str | Path, opts: DeriveOptions, progress: Callable[[int, int], None] | None = None):
    """``derive_file``'s report with what it was made from: (report, description, chain, BaseSet)
    (the Python API keeps the base set's matrices beside the JSON)."""
    from minparam_cli.render.report import base_report

    t0 = time.perf_counter()
    desc, chain = load_chain(path, opts)
    if opts.method == "projection":
        from minparam_cli.base.projection import derive_projection

        base = derive_projection(chain, progress=progress)
    else:
        from minparam_cli.base.qr import derive_qr

        base = derive_qr(chain, samples=opts.samples, seed=opts.seed)
    report = base_report(chain, base, 0.0)
    from minparam_cli.dynamics.bodies import body_problems, problems_text

    problems = body_problems(desc)
    if problems:  # derive never uses them: a warning, not an error
        report["warnings"] = [problems_text(desc, problems) + "; derive does not use them, simulate and --prior nominal refuse them"]
    if opts.snap_angles is not None:
        report["snap_angles"] = {"tolerance_rad": opts.snap_angles, "changed": [dict(a) for a in desc.adjustments]}
    weak = base.rank_margin.get("weak") or []
    if weak:
        from minparam_cli.base.weak import weak_parameters

        report["weakly_identifiable"] = weak_parameters(chain, base, explain=opts.explain_weak, samples=opts.samples, seed=opts.seed)
    if opts.symbolic or opts.symbolic_numbers:
        from minparam_cli.base.symbolic import add_symbolic

        report = add_symbolic(report, desc, chain, base, numbers=opts.symbolic_numbers)
    report["elapsed_s"] = round(time.perf_counter() - t0, 6)
    return report, desc, chain, base


def check_file(path: str | Path) -> dict:
    """Validate a description; summary dict (robot, dof, convention, joints)."""
    from minparam_cli.chain import build_chain
    from minparam_cli.describe import load_description

    from minparam_cli.dynamics.bodies import body_verdicts, problems_text
    from minparam_cli.errors import DescriptionError

    desc = load_description(path)
    chain = build_chain(desc)
    verdicts = body_verdicts(desc)
    problems = [(link, problem) for link, problem in verdicts if problem is not None]
    if problems:
        raise DescriptionError(problems_text(desc, problems, shown=len(problems)))
    return {
        "robot": desc.name,
        "source": str(path),
        "dof": desc.dof,
        "convention": desc.convention,
        "types": "".join("R" if t == "revolute" else "P" for t in chain.types),
        "branched": any(chain.parents[j] != j - 1 for j in range(chain.n)),
        "exact": chain.exact is not None,
        "inertial": chain.phi_nominal is not None,
        "finite": bool(np.all(np.isfinite(chain.pre)) and np.all(np.isfinite(chain.post))),
        # per link with inertial values: "ok" (a real body); an impossible one makes the file fail above
        "bodies": {link: "ok" for link, _ in verdicts},
        # the declared transmission, validated at the loader (square, finite, invertible N)
        "transmission": _transmission_summary(chain),
    }


def _transmission_summary(chain) -> dict | None:
    if chain.transmission is None:
        return None
    from minparam_cli.dynamics.transmission import coupled_motors, motor_matrix

    N = motor_matrix(chain)
    return {"motors": int(N.shape[0]), "coupled_motors": [k + 1 for k in coupled_motors(N)],
            "condition_number": float(np.linalg.cond(N)), "drive_gains": chain.transmission.drive_gains is not None}
