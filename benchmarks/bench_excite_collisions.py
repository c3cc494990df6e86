"""Benchmark of `minparam excite --collisions` (issue 32).

For examples/urdf/ur5_cylinders.urdf (the UR5 with minparam's collision cylinders), seeds 0..S-1, the
same options with and without `--collisions` (and `--floor 0` in both, so that the floor is a constraint
of the plain design too, on the link origins): the smallest signed distance between the collision shapes
(non-adjacent links and the floor) on the dense grid of the check (negative: overlap depth) with its
pair, the condition number of the base regressor (SI, output samples), wall and CPU time, and the time
spent in MuJoCo's distances.  The distances of the plain design are measured with the same pairs as the
flag's check.  The load average is printed beside the times.

`--rounds-only` adds a third design per seed: the optimiser's step-bounded rounds (``experiment.excite.rounds``)
with the collision rows and the dense collision check switched off, to tell what the rounds cost from
what the distances cost.

Run: python benchmarks/bench_excite_collisions.py [--seeds 3] [--harmonics 5] [--starts 4] [--max-iterations 150] [--rounds-only]
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
import argparse
import sys
import time
from pathlib import Path

import numpy as np
from common import ROOT, load_average, peak_rss_mb
from tabulate import tabulate

sys.path.insert(0, str(ROOT / "src"))

from minparam_cli.api.excitation import prepare_excite, run_excite  # noqa: E402
from minparam_cli.api.options.excite import ExciteOptions  # noqa: E402
from minparam_cli.experiment.excite import constraints as cons  # noqa: E402
from minparam_cli.experiment.excite.collisions import REPORT_REACH  # noqa: E402

ROBOT = ROOT / "examples" / "urdf" / "ur5_cylinders.urdf"


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--harmonics", type=int, default=5)
    ap.add_argument("--starts", type=int, default=4)
    ap.add_argument("--max-iterations", type=int, default=150)
    ap.add_argument("--rounds-only", action="store_true")
    args = ap.parse_args()
    rows = []
    for seed in range(args.seeds):
        for flag in (False, True, "rounds only") if args.rounds_only else (False, True):
            opts = ExciteOptions(harmonics=args.harmonics, starts=args.starts, max_iterations=args.max_iterations, seed=seed,
                                 floor=0.0, collisions=True)
            prep = prepare_excite(Path(ROBOT), opts)
            shapes = prep.limits.collisions
            if not flag:  # the plain design: same options, the shapes only measured afterwards
                from dataclasses import replace

                prep = replace(prep, limits=replace(prep.limits, collisions=None))
            w0, c0 = time.perf_counter(), time.process_time()
            spent = shapes.seconds
            if flag == "rounds only":
                from unittest import mock

                from minparam_cli.experiment.excite.collisions import Collisions

                off = {"type": "ineq", "fun": lambda x: np.ones(1), "jac": lambda x: np.zeros((1, x.size))}
                with mock.patch.object(Collisions, "constraint", lambda *a, _off=off: _off), \
                        mock.patch.object(Collisions, "violations", lambda *a, **k: []):
                    result = run_excite(prep)
            else:
                result = run_excite(prep)
            wall, cpu, used = time.perf_counter() - w0, time.process_time() - c0, shapes.seconds - spent
            traj = result.design.trajectory
            dense = cons.dense_times(traj, result.t)
            low, k, when = shapes.closest(prep.chain, traj.evaluate(dense)[0], dense, REPORT_REACH)
            label = flag if isinstance(flag, str) else "--collisions" if flag else "plain"
            rows.append([seed, label, f"{1000 * low:.1f}", shapes.labels[k], f"{when:.2f}",
                         f"{result.condition_number_si:.3g}", f"{wall:.1f}", f"{cpu:.1f}",
                         f"{used:.1f}" if flag is True else "-"])
    print(f"{ROBOT.relative_to(ROOT)}: {args.harmonics} harmonics, {args.starts} starts x {args.max_iterations} iterations, "
          f"--floor 0, clearance {1000 * shapes.clearance:g} mm; {load_average()}")
    print(tabulate(rows, headers=["seed", "design", "smallest distance mm", "pair", "at t s", "cond (SI)", "wall s", "CPU s",
                                  "distances s"]))
    print(f"peak RSS {peak_rss_mb():.0f} MB")


if __name__ == "__main__":
    main()
