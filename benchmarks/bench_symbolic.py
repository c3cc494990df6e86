"""Benchmark of `minparam derive --symbolic` against the numeric route (issue 18, point 5).

Targets: Panda (MDH) symbolic <= 5 s whole process; any 6-DOF arm <= 10 s; a robot the
route cannot handle fails (prints the numeric set and the reason) in <= 2 s of symbolic work.

For each robot: whole-process wall time of ``derive`` with and without ``--symbolic`` (run in
turn, median of --repeats), the child's CPU time (user + sys: on a shared, loaded machine the
wall time includes waiting for a core), peak RSS, and the symbolic stage's own time from the
report (exact part / with the verification at fresh geometries), and the machine's load average
(1 min) when the row's runs started and ended.  Robots from robots/ and
benchmarks/data/symbolic/ (skewed twists, prismatic joints, offsets, oblique URDF axes, joints
after fixed joints, mimic joints, a floating-base biped, CAD-exported numbers; issue 34: skewed
DH/MDH arms of 4 to 7 joints with prismatic joints and offsets); rows marked --symbolic-numbers run
that option instead.  The load average is printed before and after the runs.

Run: python benchmarks/bench_symbolic.py [--repeats 3] [--only NAME]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

from common import ROOT
from tabulate import tabulate

DATA = "benchmarks/data/symbolic"
CASES = [  # (file, extra CLI args, dof class for the target)
    ("robots/panda.yaml", [], "panda"),
    ("robots/puma560.yaml", [], 6),
    ("robots/puma560_mdh.yaml", [], 6),
    ("robots/stanford.yaml", [], 6),
    ("robots/tx40.yaml", [], 6),
    ("robots/ur5.urdf", [], 6),
    ("robots/iiwa14.urdf", [], 7),
    ("robots/universal15_glazunov.yaml", ["--friction", "offset", "--rotor-inertia"], 6),
    (f"{DATA}/skew4r_dh.yaml", [], 4),
    (f"{DATA}/skew6r_dh.yaml", [], 6),
    (f"{DATA}/skew_rrpr_mdh.yaml", ["--friction", "offset"], 4),
    (f"{DATA}/ppr_gantry.yaml", ["--friction", "offset", "--rotor-inertia"], 3),
    (f"{DATA}/arm7_offsets_parallel.yaml", ["--friction", "viscous,offset", "--rotor-inertia"], 7),
    (f"{DATA}/oblique_axis.urdf", [], 2),
    (f"{DATA}/oblique_fixed.urdf", ["--friction", "viscous", "--rotor-inertia"], 5),
    ("robots/ur5.urdf", ["--symbolic-numbers"], 6),
    (f"{DATA}/oblique_fixed.urdf", ["--symbolic-numbers"], 5),
    (f"{DATA}/mimic_gripper.urdf", [], 2),
    (f"{DATA}/mixed_mimic.urdf", ["--friction", "viscous,offset"], 2),
    (f"{DATA}/biped_floating.urdf", [], 12),
    (f"{DATA}/cad_arm.urdf", [], 6),
    (f"{DATA}/mimic_long_period.urdf", [], 1),
    # issue 34 point 2: skewed twists with prismatic joints and offsets, 4 to 7 joints (target <= 10 s each)
    (f"{DATA}/skew_rprr_dh.yaml", [], 4),
    (f"{DATA}/skew_rprr_mdh.yaml", [], 4),
    (f"{DATA}/skew_rrprr_dh.yaml", [], 5),
    (f"{DATA}/skew_rprrrr_mdh.yaml", [], 6),
    (f"{DATA}/skew_rrprrrp_dh.yaml", [], 7),
    (f"{DATA}/skew_rprrpr_dh.yaml", [], 6),
    (f"{DATA}/skew_prrrprr_mdh.yaml", [], 7),
]
SYMBOLIC_ONLY = ("--symbolic-numbers",)  # options of the symbolic run only
TARGETS = {"panda": 5.0, 4: 10.0, 5: 10.0, 6: 10.0, 7: 10.0}  # issue 34: any arm of <= 7 joints in <= 10 s


def timed(cmd: list[str]) -> tuple[float, float, float, str]:
    """Wall time, CPU time (user + sys) and peak RSS (MB) of this one child (os.wait4: the rusage of
    RUSAGE_CHILDREN is the largest RSS of all children so far, not this run's), and its stdout."""
    t0 = time.perf_counter()
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        p = subprocess.Popen(cmd, cwd=ROOT, stdout=out, stderr=err, env={**os.environ, "PYTHONPATH": str(ROOT / "src")})
        _, status, ru = os.wait4(p.pid, 0)
        p.returncode = os.waitstatus_to_exitcode(status)
        wall = time.perf_counter() - t0
        out.seek(0)
        err.seek(0)
        stdout, stderr = out.read().decode(), err.read().decode()
    if p.returncode != 0:
        raise SystemExit(f"command failed ({p.returncode}): {' '.join(cmd)}\n{stderr}")
    return wall, ru.ru_utime + ru.ru_stime, ru.ru_maxrss / 1024, stdout


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--only", default="", help="run only the cases whose file name contains this")
    args = ap.parse_args()
    rows = []
    load0 = os.getloadavg()[0]
    for path, extra, klass in CASES:
        if args.only not in path:
            continue
        sym_extra = [a for a in extra if a in SYMBOLIC_ONLY] or ["--symbolic"]
        base_cmd = [sys.executable, "-m", "minparam_cli", "derive", path, *(a for a in extra if a not in SYMBOLIC_ONLY), "--format", "json"]
        sym, num = [], []
        load_row = os.getloadavg()[0]
        for _ in range(args.repeats):
            sym.append(timed(base_cmd + sym_extra))
            num.append(timed(base_cmd))
        def med(xs, k):
            return sorted(x[k] for x in xs)[len(xs) // 2]

        report = json.loads(sym[-1][3])
        v = report.get("symbolic_verification", {})
        stage = v.get("elapsed_s", float("nan"))
        if "refused" in v:
            status = "refused: " + v["refused"][:60]
            target = 2.0
            ok = stage <= target
        elif not v.get("passed", False):  # computed, but the check failed: nothing printed
            status = f"not verified: identity error {v.get('max_identity_error_fresh', float('nan')):.1e}"
            target = TARGETS.get(klass)
            ok = None if target is None else med(sym, 0) <= target
        else:
            status = f"exact, {report['n_base']} base, verified {v.get('max_rel_error_fresh', float('nan')):.1e}"
            target = TARGETS.get(klass)
            ok = None if target is None else med(sym, 0) <= target
        rows.append((path.split("/")[-1] + "".join(f" {a}" for a in extra if a in SYMBOLIC_ONLY), klass if klass != "panda" else 7, f"{med(sym, 0):.2f}", f"{med(sym, 1):.2f}",
                     f"{med(num, 0):.2f}", f"{med(num, 1):.2f}", f"{med(sym, 0) / med(num, 0):.1f}",
                     f"{v.get('exact_s', float('nan')):.2f}" if "exact_s" in v else "-", f"{stage:.2f}",
                     f"{max(x[2] for x in sym):.0f}", f"{load_row:.1f}-{os.getloadavg()[0]:.1f}", status,
                     "" if target is None else ("ok" if ok else "FAIL") + f" (<= {target:g} s{' stage' if klass == 'refused' else ''})"))
    load = os.getloadavg()[0]
    print(f"median of {args.repeats} whole-process runs, symbolic and numeric in turn; load average {load0:.1f} before, "
          f"{load:.1f} after, on {os.cpu_count()} cores")
    print(tabulate(rows, headers=["robot", "dof", "symbolic wall s", "symbolic cpu s", "numeric wall s", "numeric cpu s",
                                  "wall ratio", "exact s", "stage s", "peak MB", "load", "result", "target"]))


if __name__ == "__main__":
    main()
