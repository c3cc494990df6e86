"""A simulated recording with long standstills, for the `--trim-still` example in docs/commands/identify.md.

    python benchmarks/data/standstill_demo.py OUT.csv [--seed 3]

The PUMA 560 (robots/puma560_mdh.yaml) follows `minparam simulate`'s Fourier
excitation with Coulomb and viscous friction (0.1 N·m RMS each) and torque
noise σ = 0.01 N·m; the robot stops three times for 4 s (about 37 % of the
record), as whole recordings of a working robot do.  While it stands still the
measured torque is gravity plus whatever static friction holds the joint: a
constant drawn uniformly in [−Fc, Fc] for each joint and stop, which a model
with sign(q̇) friction (zero at q̇ = 0) cannot predict.  Seeded: the same seed
writes the same file.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from minparam_cli.experiment.simulate import rigid_torque, simulate
from minparam_cli.experiment.simulate_spec import SimulationOptions, parse_effects
from minparam_cli.robot import DeriveOptions, load_chain

ROBOT = Path(__file__).resolve().parents[2] / "robots" / "puma560_mdh.yaml"
STOPS = (5.0, 10.0, 15.0)  # s of motion after which the robot stops
STOP_S = 4.0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--seed", type=int, default=3)
    args = ap.parse_args()
    _, chain = load_chain(ROBOT, DeriveOptions())
    n = chain.n
    effects = parse_effects("coulomb:amp=0.1,viscous:amp=0.1", n)
    rng = np.random.default_rng(args.seed)
    sim = simulate(chain, SimulationOptions(effects=effects, noise=0.01), rng)
    fc = np.zeros(n)
    for e in sim.effects:
        if e.effect == "coulomb":
            fc[list(e.joints)] = [c[0] for c in e.coefficients]
    t, q, dq, ddq, tau = sim.t, sim.q, sim.dq, sim.ddq, sim.tau
    dt = float(t[1] - t[0])
    parts, shift = [], 0.0
    start = 0
    for stop in STOPS + (np.inf,):
        k = int(np.searchsorted(t, stop))
        parts.append((t[start:k] + shift, q[start:k], dq[start:k], ddq[start:k], tau[start:k]))
        if np.isfinite(stop):
            m = int(round(STOP_S / dt))
            hold = np.repeat(q[k - 1 : k], m, axis=0)
            zero = np.zeros_like(hold)
            gravity = rigid_torque(chain, hold, zero, zero, sim.phi)
            static = rng.uniform(-fc, fc)
            t_hold = t[k - 1] + shift + dt * np.arange(1, m + 1)
            parts.append((t_hold, hold, zero, zero, gravity + static + rng.normal(0.0, 0.01, size=hold.shape)))
            shift += m * dt
        start = k
    cols = [np.concatenate([p[i] for p in parts]) for i in range(5)]
    header = ["t"] + [f"{k}{j}" for k in ("q", "dq", "ddq", "tau") for j in range(1, n + 1)]
    table = np.column_stack([cols[0]] + cols[1:])
    np.savetxt(args.out, table, delimiter=",", header=",".join(header), comments="", fmt="%.10g")
    print(f"wrote {args.out}: {len(table)} samples, {STOP_S * len(STOPS):g} s of standstill in "
          f"{cols[0][-1] - cols[0][0]:.1f} s, seed {args.seed}")


if __name__ == "__main__":
    main()
