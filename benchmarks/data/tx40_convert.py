"""Convert the Staubli TX40 motor-side recording (FIGAROH examples) to a CSV for `minparam identify`.

Input (never copied into the repository): ``../shared/data/staubli-tx40/pos_read_data.csv`` (motor
encoder angles, rad) and ``curr_data.csv`` (motor-side torque/current signal), 45000 rows each, no
time column, 5 kHz.  See that folder's README.txt.

Output: columns ``t, q1..q6, tau1..tau6`` (no dq, ddq: `minparam identify` derives them by
zero-phase low-pass filtering), with FIGAROH's conversion:

* t = k * 0.0002 s;
* q = inv(N) theta_m with N = diag(32, 32, 45, -48, 45, 32) and N[5,4] = 32 (wrist coupling:
  theta_m6 = 32 q5 + 32 q6, so q6 = theta_m6/32 - q5); then q2 -= pi/2, q3 += pi/2 (URDF zero);
* tau = Nt c with Nt = diag(32, 32, 45, -48, 45, 32) and Nt[4,5] = 32, i.e.
  tau5 = 45 c5 + 32 c6, tau6 = 32 c6 (the transpose of the position coupling).

The torque signal's unit and drive gains are undocumented: ``--scale`` multiplies every torque.

Usage (from the repository root)::

    python benchmarks/data/tx40_convert.py /tmp/tx40.csv
    python benchmarks/data/tx40_convert.py /tmp/tx40_nocoup.csv --no-coupling   # for checks only
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

TS = 0.0002
RATIOS = np.array([32.0, 32.0, 45.0, -48.0, 45.0, 32.0])
COUPLING = 32.0  # motor 6 turns with joint 5: theta_m6 = 32 q5 + 32 q6
DEFAULT_DIR = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "staubli-tx40"


def gear_matrix(coupled: bool) -> np.ndarray:
    n = np.diag(RATIOS)
    if coupled:
        n[5, 4] = COUPLING
    return n


def convert(data_dir: Path, coupled: bool = True, scale: float = 1.0) -> tuple[np.ndarray, list[str]]:
    theta_m = np.loadtxt(data_dir / "pos_read_data.csv", delimiter=",", skiprows=1)
    current = np.loadtxt(data_dir / "curr_data.csv", delimiter=",", skiprows=1)
    if theta_m.shape != current.shape or theta_m.shape[1] != 6:
        raise SystemExit(f"unexpected shapes {theta_m.shape} and {current.shape}")
    n = gear_matrix(coupled)
    q = np.linalg.solve(n, theta_m.T).T  # theta_m = N q
    q[:, 1] -= math.pi / 2
    q[:, 2] += math.pi / 2
    tau = scale * (n.T @ current.T).T  # tau = N^T c (power conservation): tau5 = 45 c5 + 32 c6
    t = np.arange(len(q)) * TS
    header = ["t"] + [f"q{j}" for j in range(1, 7)] + [f"tau{j}" for j in range(1, 7)]
    return np.column_stack([t, q, tau]), header


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("output", type=Path, help="CSV to write (outside the repository)")
    ap.add_argument("--data-dir", type=Path, default=DEFAULT_DIR)
    ap.add_argument("--no-coupling", action="store_true", help="ignore the wrist coupling (checks only)")
    ap.add_argument("--scale", type=float, default=1.0, help="factor applied to every torque")
    args = ap.parse_args()
    table, header = convert(args.data_dir, coupled=not args.no_coupling, scale=args.scale)
    np.savetxt(args.output, table, delimiter=",", header=",".join(header), comments="", fmt="%.10g")
    print(f"wrote {args.output}: {table.shape[0]} rows, {table[-1, 0]:.4f} s")


if __name__ == "__main__":
    main()
