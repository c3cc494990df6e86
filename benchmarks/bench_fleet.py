"""Benchmark of batch throughput [issue 20]: `minparam derive FOLDER` (robots/s) and `minparam identify
ROBOT FOLDER` (samples/s) with one local process (--jobs 1), two (--jobs 2), and a Dask distributed
cluster (--scheduler, a LocalCluster of two single-threaded worker processes on this machine,
started once before the timed runs as a standing cluster would be).

Every run is the real command as a separate process (wall time, peak RSS of the client process);
the JSON of every configuration is checked against --jobs 1 (wall-clock fields aside; every path
absolute, as a cluster is given them) before its time is reported.  Robots: seeded random 2- to 6-joint DH arms; recordings: `minparam simulate` of
the Panda (7 joints, Coulomb + viscous, noise), --duration seconds at 200 Hz each.

Run: python benchmarks/bench_fleet.py [--robots 300] [--recordings 8] [--duration 20]
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from common import ROOT, minparam_cmd
from tabulate import tabulate

ELAPSED = re.compile(r'"elapsed_s": [-+0-9.eE]+')


def write_robots(folder: Path, count: int, seed: int = 0) -> None:
    rng = np.random.default_rng(seed)
    folder.mkdir(parents=True, exist_ok=True)
    for i in range(count):
        n = int(rng.integers(2, 7))
        lines = [f"name: arm {i}", "convention: dh", "units: {length: m, angle: deg}", "gravity: [0, 0, -9.81]", "joints:"]
        for j in range(n):
            alpha = int(rng.choice([0, 90, -90]))
            a, d = round(float(rng.uniform(0.05, 0.6)), 3), round(float(rng.uniform(0.0, 0.3)), 3)
            lines.append(f"  - {{name: j{j + 1}, type: revolute, alpha: {alpha}, a: {a}, d: {d}, theta: 0}}")
        (folder / f"arm{i:04d}.yaml").write_text("\n".join(lines) + "\n")


def write_recordings(folder: Path, count: int, duration: float) -> int:
    folder.mkdir(parents=True, exist_ok=True)
    for i in range(count):
        subprocess.run(minparam_cmd() + ["simulate", "robots/panda.yaml", "--effects", "coulomb,viscous", "--noise", "0.05",
                                         "--seed", str(i), "--duration", str(duration), "-o", str(folder / f"panda{i:03d}.csv"),
                                         "--quiet"], check=True, cwd=ROOT)
    return count * round(duration * 200)


def run_timed(cmd: list[str]) -> tuple[float, float]:
    """Wall time (s) and peak RSS (MB, GNU time) of one run of ``cmd``; its stderr is shown if it fails."""
    with tempfile.NamedTemporaryFile("r") as rss:
        full = ["/usr/bin/time", "-f", "%M", "-o", rss.name, *cmd] if os.path.exists("/usr/bin/time") else cmd
        t0 = time.perf_counter()
        p = subprocess.run(full, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, cwd=ROOT, check=False)
        t = time.perf_counter() - t0
        if p.returncode != 0:
            raise SystemExit(f"command failed ({p.returncode}): {' '.join(cmd)}\n{p.stderr[-3000:]}")
        text = rss.read().strip().splitlines()
    return t, (float(text[-1]) / 1024 if text else float("nan"))


def timeless(path: Path) -> str:
    if path.is_dir():
        return "\n".join(f"{p.name}\n{ELAPSED.sub('', p.read_text())}" for p in sorted(path.iterdir()))
    return ELAPSED.sub("", path.read_text())


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--robots", type=int, default=300)
    ap.add_argument("--recordings", type=int, default=8)
    ap.add_argument("--duration", type=float, default=20.0)
    args = ap.parse_args()
    from distributed import LocalCluster

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        write_robots(tmp / "robots", args.robots)
        samples = write_recordings(tmp / "recordings", args.recordings, args.duration)
        t0 = time.perf_counter()
        cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
        start = time.perf_counter() - t0
        configs = [("local, --jobs 1", ["--jobs", "1"]), ("local, --jobs 2", ["--jobs", "2"]),
                   ("Dask LocalCluster, 2 workers", ["--scheduler", cluster.scheduler_address])]
        rows = []
        try:
            ref = {}
            for name, opts in configs:
                out = tmp / "derive.json"
                t, peak = run_timed(minparam_cmd() + ["derive", str(tmp / "robots"), "-f", "json", "-q", "-o", str(out), *opts])
                ref.setdefault("derive", timeless(out))
                same = timeless(out) == ref["derive"]
                rows.append(["derive", name, f"{args.robots} robots", f"{t:.1f} s", f"{args.robots / t:.1f} robots/s", f"{peak:.0f} MB",
                             "yes" if same else "NO"])
                folder = tmp / f"models{len(rows)}"
                t, peak = run_timed(minparam_cmd() + ["identify", str(ROOT / "robots" / "panda.yaml"), str(tmp / "recordings"), "-f", "json", "-q",
                                                        "-o", str(folder), *opts])
                ref.setdefault("identify", timeless(folder))
                same = timeless(folder) == ref["identify"]
                rows.append(["identify", name, f"{args.recordings} x {samples // args.recordings:,} samples", f"{t:.1f} s",
                             f"{samples / t:,.0f} samples/s", f"{peak:.0f} MB", "yes" if same else "NO"])
        finally:
            cluster.close()
    print(f"Batch throughput on this machine ({os.cpu_count()} CPUs); whole processes, one run each; "
          f"LocalCluster start {start:.1f} s (not in the times)")
    print(tabulate(rows, headers=["command", "executor", "work", "wall time", "throughput", "client peak RSS",
                                  "same JSON as --jobs 1"], tablefmt="github"))
    print(json.dumps({"python": sys.version.split()[0]}))


if __name__ == "__main__":
    main()
