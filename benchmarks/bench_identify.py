"""Benchmark of `minparam identify` at scale [issue target: 1 M samples x 7 joints in <= 30 s,
peak memory independent of the number of samples].

Writes synthetic Panda data (random physically consistent inertia, Coulomb +
viscous friction, noise) as CSV in chunks to a temporary folder, then runs the
real command as a separate process and records wall time and peak RSS.

With --physical each size is also run with `identify --physical` (the convex
fit over the full parameters, on the accumulated triangular factors: its
program does not grow with the samples); the table then adds the solver's own
time from the report [issue 13 target: <= 5 s for the convex solve].

Each size is run with identify's two CSV readers (pyarrow's, the [arrow] extra,
and numpy's loadtxt, forced with MINPARAM_CSV_READER=numpy) [issue 20 target:
1 M samples x 7 joints <= 6 s end to end, peak <= 300 MB], and the table of
parse throughput compares the readers alone (in this process, MB/s of CSV).
A CPU calibration (a fixed numpy + Python loop, in s) is printed with the
tables: on a shared machine, times scale with it.  The CPU time column (user +
system seconds of the identify process, all its threads) moves less with the
machine's load than the wall time: identify's streaming pass runs on two
threads, so on an idle 2-core machine the wall time is below the CPU time.

Each command runs --repeats times (default 3): the table gives the median wall time, the mean CPU
time and the largest peak, as the other benchmarks do (common.run_process), so that one run slowed
by the host's neighbours does not stand for the code.

Run: python benchmarks/bench_identify.py [--sizes 100000,300000,1000000] [--physical] [--readers pyarrow,numpy] [--repeats 3]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from common import ROOT, minparam_cmd, run_process
from tabulate import tabulate

sys.path.insert(0, str(ROOT / "src"))

from minparam_cli.chain import build_chain  # noqa: E402
from minparam_cli.describe import load_description  # noqa: E402
from minparam_cli.dynamics.regressor import regressor  # noqa: E402
from minparam_cli.dynamics.inertia import random_inertia  # noqa: E402

RATE = 1000.0


def write_data(path: Path, samples: int, seed: int = 0) -> None:
    chain = build_chain(load_description(ROOT / "robots" / "panda.yaml"))
    rng = np.random.default_rng(seed)
    phi = random_inertia(chain.n, chain.length_scale, rng).phi
    n = chain.n
    w = 2 * np.pi * 0.1 * np.arange(1, 6)
    a, b = rng.uniform(-0.3, 0.3, (2, n, 5))
    header = ",".join(["t"] + [f"{k}{j}" for k in ("q", "dq", "ddq", "tau") for j in range(1, n + 1)])
    with open(path, "w") as fh:
        fh.write(header + "\n")
        for s in range(0, samples, 50_000):
            t = np.arange(s, min(s + 50_000, samples)) / RATE
            wt = np.outer(t, w)
            q = (np.sin(wt) / w) @ a.T - (np.cos(wt) / w) @ b.T
            dq = np.cos(wt) @ a.T + np.sin(wt) @ b.T
            ddq = (-np.sin(wt) * w) @ a.T + (np.cos(wt) * w) @ b.T
            tau = regressor(chain, q, dq, ddq) @ phi + 0.3 * np.sign(dq) + 0.5 * dq
            tau += 0.01 * rng.standard_normal(tau.shape)
            np.savetxt(fh, np.hstack([t[:, None], q, dq, ddq, tau]), delimiter=",", fmt="%.9g")


def _children_cpu() -> float:
    """User + system CPU seconds of the finished child processes (and theirs): on a shared machine
    the CPU a run took varies less than its wall time, which waits for the other jobs."""
    import resource

    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def calibration() -> float:
    """Seconds of a fixed CPU task (numpy and Python): a slower figure means a busier machine."""
    t0 = time.perf_counter()
    a = np.random.default_rng(0).random(5_000_000)
    for _ in range(5):
        (a * 2.0).sum()
    sum(range(3_000_000))
    return time.perf_counter() - t0


def parse_rate(path: Path, reader: str) -> float:
    """MB/s of the reader alone: every chunk of the 7-joint file, nothing else."""
    from minparam_cli.measured.records import DataOptions
    from minparam_cli.measured.reading import raw_chunks

    os.environ["MINPARAM_CSV_READER"] = reader
    t0 = time.perf_counter()
    for _ in raw_chunks(path, 7, DataOptions()):
        pass
    return os.path.getsize(path) / 1e6 / (time.perf_counter() - t0)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", default="100000,300000,1000000")
    ap.add_argument("--physical", action="store_true", help="also time identify --physical")
    ap.add_argument("--readers", default="pyarrow,numpy", help="CSV readers to compare (pyarrow needs the [arrow] extra)")
    ap.add_argument("--repeats", type=int, default=3, help="runs of each command (median wall time, largest peak)")
    args = ap.parse_args()
    readers = [r.strip() for r in args.readers.split(",") if r.strip()]
    rows, rates = [], []
    before = calibration()
    with tempfile.TemporaryDirectory() as tmp:
        for n in (int(x) for x in args.sizes.split(",")):
            data = Path(tmp) / f"panda_{n}.csv"
            write_data(data, n)
            size_mb = os.path.getsize(data) / 1e6
            rates.append([f"{n:,}", f"{size_mb:.0f} MB"] + [f"{parse_rate(data, r):.0f} MB/s" for r in readers])
            report = Path(tmp) / "report.json"
            for reader in readers:
                os.environ["MINPARAM_CSV_READER"] = reader
                for extra in ([], ["--physical"]) if args.physical else ([],):
                    cmd = minparam_cmd() + ["identify", "robots/panda.yaml", str(data), "--format", "json", "--quiet",
                                            "-o", str(report), *extra]
                    before_cpu = _children_cpu()
                    t, peak = run_process(cmd, repeats=max(1, args.repeats))
                    cpu = (_children_cpu() - before_cpu) / max(1, args.repeats)
                    solve = json.loads(report.read_text())["physical"]["elapsed_s"] if extra else None
                    rows.append([f"{n:,}", f"{size_mb:.0f} MB", reader, "physical" if extra else "least squares", f"{t:.1f} s", f"{cpu:.1f} s",
                                 "-" if solve is None else f"{solve:.2f} s", f"{peak:.0f} MB"])
            data.unlink()
    os.environ.pop("MINPARAM_CSV_READER", None)
    after = calibration()
    print("minparam identify, Panda (7 joints), CSV with q, dq, ddq, tau; Coulomb + viscous hidden; diagnosis on;"
          f" median of {max(1, args.repeats)} runs (CPU time: their mean; peak: the largest)")
    print(tabulate(rows, headers=["samples", "file", "CSV reader", "fit", "wall time", "CPU time", "convex solve", "peak RSS"], tablefmt="github"))
    print("\nCSV parsing alone (measured.reading.raw_chunks, all columns to float64), MB of CSV per second")
    print(tabulate(rates, headers=["samples", "file"] + readers, tablefmt="github"))
    print(f"\nCPU calibration (a fixed numpy + Python task; larger on a busier machine): {before:.2f} s before, {after:.2f} s after")


if __name__ == "__main__":
    main()
