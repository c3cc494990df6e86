"""Benchmark of the method of projections, `--method projection` (issue targets in brackets).

* in process: PUMA 560 (robots/puma560.yaml, exact mode) [<= 200 ms, the paper's C++ in 2011];
* Panda (robots/panda.yaml, 7 joints, exact mode): time [<= 3 s] and peak RSS [<= 500 MB],
  each in a fresh process;
* a table for serial chains of 2..8 revolute joints (``--max-joints`` for more): dim B (the
  paper's basis rows), the rows of Z that are nonzero, time and peak RSS, for a generic
  geometry (twists of 23 + 31k degrees: float64, nothing cancels exactly) and for right-angle
  twists with decimal lengths (exact integer arithmetic).  Each case runs in its own process,
  so the peak RSS is that case's (Python, numpy and scipy included).

Run: python benchmarks/bench_projection.py [--max-joints 10]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time

from common import ROOT, best_of
from tabulate import tabulate

sys.path.insert(0, str(ROOT / "src"))

from minparam_cli.base.projection import MAX_ROWS, derive_projection, projection_cost  # noqa: E402
from minparam_cli.chain import build_chain  # noqa: E402
from minparam_cli.describe import load_description  # noqa: E402
from minparam_cli.describe.yaml_dh import description_from_mapping  # noqa: E402


def serial_chain(n: int, geometry: str):
    """n revolute joints, standard DH; 'generic' twists or 'right' (multiples of 90 degrees)."""
    joints = []
    for k in range(n):
        alpha = 23 + 31 * k if geometry == "generic" else (90, -90, 0)[k % 3]
        joints.append({"type": "revolute", "alpha": alpha, "a": round(0.1 + 0.05 * k, 3), "d": round(0.2 - 0.03 * k, 3), "theta": 0})
    doc = {"name": f"{geometry}{n}R", "convention": "dh", "units": {"length": "m", "angle": "deg"}, "joints": joints}
    return build_chain(description_from_mapping(doc, f"{geometry}{n}R.yaml"))


def load(spec: str):
    """'robot:panda.yaml' or 'generic:7' / 'right:7'."""
    kind, arg = spec.split(":", 1)
    if kind == "robot":
        return build_chain(load_description(ROOT / "robots" / arg))
    return serial_chain(int(arg), kind)


def child(spec: str, repeats: int) -> None:
    """Run one case in this (fresh) process and print a JSON line."""
    chain = load(spec)
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        b = derive_projection(chain)
        times.append(time.perf_counter() - t0)
    print(json.dumps({
        "time": statistics.median(times),
        "first": times[0],
        "n_base": b.n_base,
        "exact": b.exact,
        "basis_rows": b.extra["basis_rows"],
        "nonzero_rows": b.extra["nonzero_rows"],
    }))


def in_fresh_process(spec: str, repeats: int = 1) -> dict:
    """Median in-process time of ``repeats`` runs and the process's peak RSS (MB)."""
    p = subprocess.Popen([sys.executable, __file__, "--case", spec, "--repeats", str(repeats)], stdout=subprocess.PIPE, cwd=ROOT)
    out = p.stdout.read()
    _, status, usage = os.wait4(p.pid, 0)
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit(f"case {spec} failed")
    res = json.loads(out.decode().strip().splitlines()[-1])
    res["rss"] = usage.ru_maxrss / 1024
    return res


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--case")
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--max-joints", type=int, default=8)
    args = ap.parse_args()
    if args.case:
        child(args.case, args.repeats)
        return

    puma = build_chain(load_description(ROOT / "robots" / "puma560.yaml"))
    b = derive_projection(puma)
    t_puma = best_of(lambda: derive_projection(puma))
    panda = in_fresh_process("robot:panda.yaml", repeats=3)
    rows = [
        ["PUMA 560 (puma560.yaml)", b.n_base, "exact" if b.exact else "float", f"{t_puma * 1000:.0f} ms (median of 7, in process)", "-", "<= 200 ms"],
        ["Panda (panda.yaml)", panda["n_base"], "exact" if panda["exact"] else "float",
         f"{panda['time'] * 1000:.0f} ms (first call {panda['first'] * 1000:.0f} ms)", f"{panda['rss']:.0f} MB", "<= 3 s, <= 500 MB"],
    ]
    print("Targets")
    print(tabulate(rows, headers=["robot", "base", "arithmetic", "time", "peak RSS", "target"], tablefmt="github"))
    print()

    rows = []
    for n in range(2, args.max_joints + 1):
        cost = projection_cost(serial_chain(n, "generic"))
        if cost["rows"] > MAX_ROWS:
            rows.append([n, f"{cost['basis_rows']:,}", "refused (> MAX_ROWS)", "", "", "", "", ""])
            continue
        g = in_fresh_process(f"generic:{n}")
        r = in_fresh_process(f"right:{n}")
        rows.append([
            n, f"{g['basis_rows']:,}",
            f"{g['nonzero_rows']:,}", f"{g['time']:.3f} s", f"{g['rss']:.0f} MB",
            f"{r['nonzero_rows']:,}", f"{r['time']:.3f} s", f"{r['rss']:.0f} MB",
        ])
    print("Serial revolute chains: generic twists (float64) | right-angle twists (exact integers)")
    print(tabulate(rows, headers=["joints", "basis rows (dim B)", "nonzero rows", "time", "peak RSS",
                                  "nonzero rows", "time", "peak RSS"], tablefmt="github"))


if __name__ == "__main__":
    main()
