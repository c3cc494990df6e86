"""Benchmark of `minparam identify` at scale [issue target: 1 M samples x 7 joints in <= 30 s,
peak memory independent of the number of samples].

Writes synthetic Panda data (random physically consistent inertia, Coulomb +
viscous friction, noise) as CSV in chunks to a temporary folder, then runs the
real command as a separate process and records wall time and peak RSS.

With --physical each size is also run with `identify --physical` (the convex
fit over the full parameters, on the accumulated triangular factors: its
program does not grow with the samples); the table then adds the solver's own
time from the report [issue 13 target: <= 5 s for the convex solve].

Run: python benchmarks/bench_identify.py [--sizes 100000,300000,1000000] [--physical]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from pathlib import Path

import numpy as np
from common import ROOT, minparam_cmd, run_process
from tabulate import tabulate

sys.path.insert(0, str(ROOT / "src"))

from minparam_cli.chain import build_chain  # noqa: E402
from minparam_cli.describe import load_description  # noqa: E402
from minparam_cli.dynamics.regressor import regressor  # noqa: E402
from minparam_cli.identify.inertia import random_inertia  # noqa: E402

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


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", default="100000,300000,1000000")
    ap.add_argument("--physical", action="store_true", help="also time identify --physical")
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for n in (int(x) for x in args.sizes.split(",")):
            data = Path(tmp) / f"panda_{n}.csv"
            write_data(data, n)
            size_mb = os.path.getsize(data) / 1e6
            report = Path(tmp) / "report.json"
            for extra in ([], ["--physical"]) if args.physical else ([],):
                cmd = minparam_cmd() + ["identify", "robots/panda.yaml", str(data), "--format", "json", "--quiet",
                                        "-o", str(report), *extra]
                t, peak = run_process(cmd, repeats=1)
                solve = json.loads(report.read_text())["physical"]["elapsed_s"] if extra else None
                rows.append([f"{n:,}", f"{size_mb:.0f} MB", "physical" if extra else "least squares", f"{t:.1f} s",
                             "-" if solve is None else f"{solve:.2f} s", f"{peak:.0f} MB"])
            data.unlink()
    print("minparam identify, Panda (7 joints), CSV with q, dq, ddq, tau; Coulomb + viscous hidden; diagnosis on")
    print(tabulate(rows, headers=["samples", "file", "fit", "wall time", "convex solve", "peak RSS"], tablefmt="github"))


if __name__ == "__main__":
    main()
