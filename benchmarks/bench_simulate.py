"""simulate at scale: 1 M samples x 7 joints (the Panda), whole process, wall time and peak memory.

Rows:
  streamed CSV        the command as shipped (two passes in chunks; pyarrow formats when installed)
  streamed npz        the same stream into an .npz archive
  in-memory + repr    the previous way, as a peer in the same run: every array whole in memory,
                      then one Python ``repr`` per number (the stage's ``simulate`` and the writer's
                      fallback formatter)

Goal (issue 15): 1 M samples x 7 joints <= 10 s and <= 300 MB peak.

    python benchmarks/bench_simulate.py [--samples 1000000] [--repeats 1]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

from common import ROOT, minparam_cmd, run_process

IN_MEMORY = """
import sys, numpy as np
from minparam_cli.chain import build_chain
from minparam_cli.describe import load_description
from minparam_cli.experiment.simulate import simulate
from minparam_cli.experiment.simulate_spec import SimulationOptions, parse_effects
from minparam_cli.measured.writing import csv_block
chain = build_chain(load_description("robots/panda.yaml"))
n = int(sys.argv[1])
sim = simulate(chain, SimulationOptions(duration=n / 200, rate=200, effects=parse_effects("coulomb,viscous", 7), noise=0.05),
               np.random.default_rng(0))
table = np.hstack([sim.t[:, None], sim.q, sim.dq, sim.ddq, sim.tau])
with open(sys.argv[2], "wb") as fh:
    fh.write(csv_block(table, fast=False))
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--samples", type=int, default=1_000_000)
    ap.add_argument("--repeats", type=int, default=1)
    args = ap.parse_args()
    try:
        import pyarrow  # noqa: F401
        fmt = "pyarrow"
    except ImportError:
        fmt = "repr (pyarrow not installed)"
    duration = args.samples / 200
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        base = minparam_cmd() + ["simulate", "robots/panda.yaml", "--duration", f"{duration:g}", "--rate", "200",
                                 "-e", "coulomb,viscous", "--noise", "0.05", "-q", "-o"]
        for label, cmd in (
            (f"streamed CSV ({fmt})", base + [str(Path(tmp) / "a.csv")]),
            ("streamed npz", base + [str(Path(tmp) / "a.npz")]),
            ("in-memory + repr (previous)", [sys.executable, "-c", IN_MEMORY, str(args.samples), str(Path(tmp) / "b.csv")]),
        ):
            wall, peak = run_process(cmd, repeats=args.repeats)
            rows.append((label, wall, peak))
    first = rows[0][1]
    print(f"simulate robots/panda.yaml: {args.samples} samples x 7 joints, coulomb+viscous, noise 0.05 (root {ROOT.name})")
    print(f"{'run':<34} {'wall s':>8} {'peak MB':>8} {'wall / streamed CSV':>20}")
    for label, wall, peak in rows:
        print(f"{label:<34} {wall:8.2f} {peak:8.0f} {wall / first:20.2f}")


if __name__ == "__main__":
    main()
