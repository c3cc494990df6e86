"""Benchmark of `minparam platform fk` on the Dang (2013) example, against the paper's PSO settings.

The paper solves the forward problem with a particle swarm: 50 particles x 50
iterations x 30 restarts (multistart), w = 0.7298, c1 = c2 = 1.49618.  Rows:

* exact elimination (the default for the 3-3 pattern): every mode, deterministic;
* the paper's PSO settings with our LM polish and de-duplication;
* the paper's PSO alone (no polish): the residual it reaches by itself;
* random multistart + LM (200 starts);
* the 1000-pose IK -> FK round trip with the exact solver;
* whole process `minparam platform fk ...` (default, and --method pso).

Wall time is the median of several runs; peak memory is tracemalloc's peak of
Python allocations in process, and peak RSS for whole processes.  PSO rows
also count how many modes each seed returns (40 seeds for PSO, 10 for multistart).

Run: python benchmarks/bench_platform.py
"""

from __future__ import annotations

import shutil
import statistics
import subprocess
import sys
import time
import tracemalloc

from pathlib import Path

import numpy as np
from common import ROOT, best_of, minparam_cmd, run_process
from tabulate import tabulate

sys.path.insert(0, str(ROOT / "src"))

from minparam_cli.describe.platform_yaml import load_platform  # noqa: E402
from minparam_cli.kinematics.parallel.platform import leg_lengths, legs_within_limits, platform_model  # noqa: E402
from minparam_cli.kinematics.parallel.platform_fk import forward_kinematics  # noqa: E402
from minparam_cli.kinematics.parallel.platform_pso import PSOSettings, pso_search  # noqa: E402

L = np.array([238.6357, 269.3776, 256.0046, 247.4046, 185.4388, 190.2705])


def peak_mb(fn) -> float:
    tracemalloc.start()
    fn()
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    return peak / 2**20


def whole_process(cmd: list[str], repeats: int = 5) -> tuple[float, float]:
    """Median wall time (s) and peak RSS (MB) of a fresh process.

    Peak RSS comes from /usr/bin/time -f %M, which sees only the command: the
    ru_maxrss a parent reads from wait4 can include the parent's own RSS at
    fork time.  Without /usr/bin/time it falls back to common.run_process.
    """
    gnu_time = shutil.which("time") or ("/usr/bin/time" if Path("/usr/bin/time").exists() else None)
    if gnu_time is None:
        return run_process(cmd, repeats)
    times, peaks = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        p = subprocess.run([gnu_time, "-f", "%M"] + cmd, cwd=ROOT, stdout=subprocess.DEVNULL,
                           stderr=subprocess.PIPE, text=True, check=True)
        times.append(time.perf_counter() - t0)
        peaks.append(int(p.stderr.strip().splitlines()[-1]) / 1024)
    return statistics.median(times), max(peaks)


def main() -> None:
    process_rows = process_table()  # first, while this process is still small
    model = platform_model(load_platform(ROOT / "robots" / "dodekapod_dang2013.yaml"))
    exact = forward_kinematics(model, L, "exact")
    n_exact = len(exact.solutions)
    rows = []

    t = best_of(lambda: forward_kinematics(model, L, "exact"), 21)
    rows.append(["exact elimination (default)", "-", f"{t * 1e3:.1f} ms",
                 f"{peak_mb(lambda: forward_kinematics(model, L, 'exact')):.2f} MB", f"{n_exact} (every run)",
                 f"{max(s.residual for s in exact.solutions):.1e}"])

    for label, method, starts, seeds in (("paper PSO 50x50x30 + LM polish", "pso", None, range(40)),
                                         ("multistart 200 + LM", "multistart", 200, range(10))):
        counts, worst, times = [], 0.0, []
        for seed in seeds:
            t0 = time.perf_counter()
            r = forward_kinematics(model, L, method, seed=seed, starts=starts)
            times.append(time.perf_counter() - t0)
            counts.append(len(r.solutions))
            worst = max([worst] + [s.residual for s in r.solutions])
        full = sum(c == n_exact for c in counts)
        hist = ", ".join(f"{k}: {counts.count(k)}" for k in sorted(set(counts)))
        mem = peak_mb(lambda: forward_kinematics(model, L, method, seed=0, starts=starts))
        rows.append([label, "50x50x30" if method == "pso" else "200 starts", f"{np.median(times) * 1e3:.0f} ms",
                     f"{mem:.2f} MB", f"all {n_exact} in {full}/{len(counts)} seeds ({hist})", f"{worst:.1e}"])

    # the swarm alone: the best particle of each restart, before any polish
    res = []

    def swarm():
        x, _ = pso_search(model, L, np.random.default_rng(0), PSOSettings())
        res.append(np.max(np.abs(leg_lengths(model, x) - L), axis=1))

    t = best_of(swarm, 5)
    r0 = res[-1]
    rows.append(["paper PSO 50x50x30, no polish", "50x50x30", f"{t * 1e3:.0f} ms", f"{peak_mb(swarm):.2f} MB",
                 "one noisy point per restart", f"median {np.median(r0):.1e}, best {r0.min():.1e}"])

    rng = np.random.default_rng(1000)
    poses = []
    while len(poses) < 1000:
        q = np.column_stack([rng.uniform(-150, 150, (4000, 2)), rng.uniform(20, 300, 4000),
                             rng.uniform(-0.5, 0.5, (4000, 3))])
        poses.extend(q[np.all(legs_within_limits(model, leg_lengths(model, q)), axis=-1)])
    poses = np.array(poses[:1000])
    t0 = time.perf_counter()
    worst = 0.0
    for q in poses:
        r = forward_kinematics(model, leg_lengths(model, q), "exact")
        worst = max(worst, min(np.max(np.abs(s.pose - q)) for s in r.solutions))
    t = time.perf_counter() - t0
    rows.append(["round trip IK -> exact FK", "1000 poses", f"{t:.2f} s total", "-", "pose recovered in 1000/1000",
                 f"worst pose error {worst:.1e}"])

    print("Dang (2013) example, L = " + ", ".join(f"{v:g}" for v in L))
    print(tabulate(rows, headers=["solver", "settings", "wall time (median)", "peak memory",
                                  "modes found", "max |l - l*| [mm]"], tablefmt="github"))
    print()

    print("Whole process (median of 5 runs)")
    print(tabulate(process_rows, headers=["command", "wall time", "peak RSS"], tablefmt="github"))


def process_table() -> list[list[str]]:
    cmd = minparam_cmd() + ["platform", "fk", "robots/dodekapod_dang2013.yaml", "--lengths", ",".join(map(str, L))]
    t_np, m_np = whole_process([sys.executable, "-c", "import numpy"])
    rows = [["python -c 'import numpy'", f"{t_np * 1e3:.0f} ms", f"{m_np:.0f} MB"]]
    for extra in ([], ["--method", "pso"]):
        t, m = whole_process(cmd + extra)
        rows.append(["minparam platform fk <paper example> " + " ".join(extra), f"{t * 1e3:.0f} ms", f"{m:.0f} MB"])
    return rows


if __name__ == "__main__":
    main()
