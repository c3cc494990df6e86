"""Benchmark of `minparam identify` at scale [issue target: 1 M samples x 7 joints in <= 30 s,
peak memory independent of the number of samples].

Writes synthetic Panda data (random physically consistent inertia, Coulomb +
viscous friction, noise) as CSV in chunks to a temporary folder, then runs the
real command as a separate process and records wall time and peak RSS.

With --physical each size is also run with `identify --physical` (the convex
fit over the full parameters, on the accumulated triangular factors: its
program does not grow with the samples); the table then adds the solver's own
time from the report [issue 13 target: <= 5 s for the convex solve].

Each size is run with identify's two CSV readers (pyarrow's, part of the install since issue 34,
and numpy's loadtxt, the fallback, forced with MINPARAM_CSV_READER=numpy) [issue 20 target:
1 M samples x 7 joints <= 6 s end to end, peak <= 300 MB], and the table of
parse throughput compares the readers alone (in this process, MB/s of CSV).
A CPU calibration (a fixed numpy + Python loop, in s) is printed with the
tables: on a shared machine, times scale with it.  The CPU time column (user +
system seconds of the identify process, all its threads) moves less with the
machine's load than the wall time: identify's streaming pass runs on two
threads, so on an idle 2-core machine the wall time is below the CPU time.

The floor [issue 34 target: identify <= 1.5x, stretch 1.2x, peak <= 300 MB]: the same file read into
memory by pyarrow alone (pyarrow.csv.read_csv, its default threads, in a process of its own, start-up
included as in identify's).  The commands run --repeats rounds (default 3), in turn (floor, identify,
floor, identify, ...): the table gives the median wall and CPU time and the largest peak, and 'x
floor' is the median over the rounds of identify's wall time over the floor's in the same round, so
that a change in the load of the shared machine hits both alike.  The load average before and after
is printed beside the figures.

Run: python benchmarks/bench_identify.py [--sizes 100000,300000,1000000] [--physical] [--readers pyarrow,numpy] [--repeats 3]
     [--cpus 0,1] [--data-dir /tmp]   (--data-dir: keep the generated CSV files there and reuse them)
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from common import ROOT, load_average, minparam_cmd, run_measured
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


FLOOR = "import sys, pyarrow.csv; pyarrow.csv.read_csv(sys.argv[1])"  # the file into memory, pyarrow alone


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", default="100000,300000,1000000")
    ap.add_argument("--physical", action="store_true", help="also time identify --physical")
    ap.add_argument("--readers", default="pyarrow,numpy", help="CSV readers to compare (numpy: the fallback reader, forced)")
    ap.add_argument("--repeats", type=int, default=3, help="rounds of the commands, run in turn (median wall time)")
    ap.add_argument("--cpus", default="", help="run every command on these CPUs (taskset -c, e.g. 0,1: a 2-core machine)")
    ap.add_argument("--data-dir", default="", help="keep the data files in this folder and reuse them (same seed: same file)")
    args = ap.parse_args()
    pin = ["taskset", "-c", args.cpus] if args.cpus else []
    readers = [r.strip() for r in args.readers.split(",") if r.strip()]
    repeats = max(1, args.repeats)
    rows, rates = [], []
    before = calibration()
    with tempfile.TemporaryDirectory() as tmp:
        for n in (int(x) for x in args.sizes.split(",")):
            data = Path(args.data_dir or tmp) / f"minparam_bench_panda_{n}.csv"
            if not (args.data_dir and data.exists()):
                write_data(data, n)
            size_mb = os.path.getsize(data) / 1e6
            rates.append([f"{n:,}", f"{size_mb:.0f} MB"] + [f"{parse_rate(data, r):.0f} MB/s" for r in readers])
            report = Path(tmp) / "report.json"
            # (label, reader, extra arguments, command): the floor first, then identify's runs
            runs: list[tuple[str, str, list[str], list[str]]] = [("pyarrow.csv.read_csv alone (floor)", "", [],
                                                                   [*pin, sys.executable, "-c", FLOOR, str(data)])]
            for reader in readers:
                for extra in ([], ["--physical"]) if args.physical else ([],):
                    cmd = pin + minparam_cmd() + ["identify", "robots/panda.yaml", str(data), "--format", "json", "--quiet",
                                            "-o", str(report), *extra]
                    runs.append(("physical" if extra else "least squares", reader, extra, cmd))
            # in turn (floor, identify, ..., floor, identify, ...): a change in the machine's load hits all alike
            measured: list[list[tuple[float, float, float]]] = [[] for _ in runs]
            solve: dict[int, float] = {}
            load_before = load_average()
            for _ in range(repeats):
                for i, (_, reader, extra, cmd) in enumerate(runs):
                    os.environ["MINPARAM_CSV_READER"] = reader or "pyarrow"
                    measured[i].append(run_measured(cmd))
                    if extra:
                        solve[i] = json.loads(report.read_text())["physical"]["elapsed_s"]
            load_after = load_average()
            floor = [m[0] for m in measured[0]]
            for i, (label, reader, _, _) in enumerate(runs):
                walls = [m[0] for m in measured[i]]
                ratio = statistics.median(w / f for w, f in zip(walls, floor, strict=True))  # per round: the same load
                rows.append([f"{n:,}", f"{size_mb:.0f} MB", reader or "-", label, f"{statistics.median(walls):.1f} s",
                             f"{statistics.median(m[1] for m in measured[i]):.1f} s", "-" if i == 0 else f"{ratio:.2f}",
                             f"{solve[i]:.2f} s" if i in solve else "-", f"{max(m[2] for m in measured[i]):.0f} MB",
                             f"{load_before} / {load_after.split(' on ')[0].removeprefix('load ')}"])
            if not args.data_dir:
                data.unlink()
    os.environ.pop("MINPARAM_CSV_READER", None)
    after = calibration()
    print("minparam identify, Panda (7 joints), CSV with q, dq, ddq, tau; Coulomb + viscous hidden; diagnosis on;"
          f" {repeats} rounds, the commands in turn; median wall and CPU time, largest peak; 'x floor': the median over"
          " rounds of identify's wall time over the floor's in the same round"
          + (f"; every command on CPUs {args.cpus} (taskset)" if pin else ""))
    print(tabulate(rows, headers=["samples", "file", "CSV reader", "run", "wall time", "CPU time", "x floor",
                                  "convex solve", "peak RSS", "load before / after"], tablefmt="github"))
    print("\nCSV parsing alone (measured.reading.raw_chunks, all columns to float64), MB of CSV per second")
    print(tabulate(rates, headers=["samples", "file"] + readers, tablefmt="github"))
    print(f"\nCPU calibration (a fixed numpy + Python task; larger on a busier machine): {before:.2f} s before, {after:.2f} s after")


if __name__ == "__main__":
    main()
