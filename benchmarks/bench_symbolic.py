"""Benchmark of `minparam derive --symbolic` (issue target: Panda <= 5 s in process).

Times the symbolic stage alone (``symbolic_base`` + the sympy rendering) for
every shipped robot, after the numeric base set, and prints a table with the
number of β evaluations (chain rebuilds + regressor + least squares) it used.

Run: python benchmarks/bench_symbolic.py
"""

from __future__ import annotations

import sys

from common import ROOT, best_of
from tabulate import tabulate

sys.path.insert(0, str(ROOT / "src"))

from minparam_cli.base.qr import derive_qr  # noqa: E402
from minparam_cli.base.symbolic import add_symbolic  # noqa: E402
from minparam_cli.chain import build_chain  # noqa: E402
from minparam_cli.describe import load_description  # noqa: E402
from minparam_cli.render.report import base_report  # noqa: E402

ROBOTS = ["planar2r.yaml", "planar3r.yaml", "scara.yaml", "stanford.yaml", "puma560.yaml", "puma560_mdh.yaml", "ur5.yaml", "ur5.urdf", "iiwa14.urdf", "panda.yaml"]
TARGET_S = {"panda.yaml": 5.0}


def main() -> None:
    rows = []
    for name in ROBOTS:
        desc = load_description(ROOT / "robots" / name)
        chain = build_chain(desc)
        base = derive_qr(chain)
        report = base_report(chain, base, 0.0)
        out = {}

        def run():
            out["r"] = add_symbolic(report, desc, chain, base)

        t = best_of(run, repeats=3)
        v = out["r"]["symbolic_verification"]
        target = TARGET_S.get(name)
        rows.append((name, chain.n, len(out["r"]["symbols"]), base.n_base, v["beta_evaluations"], f"{v['max_rel_error_fresh']:.1e}",
                     f"{t:.2f}", "" if target is None else ("ok" if t <= target else "FAIL") + f" (<= {target:g} s)"))
    print(tabulate(rows, headers=["robot", "dof", "symbols", "base", "β evals", "max rel err", "time s (median of 3)", "target"]))


if __name__ == "__main__":
    main()
