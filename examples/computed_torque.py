"""The base regressor inside a computed-torque controller.

    python examples/computed_torque.py [--error 0.2] [--duration 2]

A 2R arm in a vertical plane follows a smooth trajectory.  The controller computes

    tau = Y(q, dq, ddq_d + Kp e + Kd de) @ beta_hat

with ``minparam.regressor`` (the base columns: 6 parameters instead of 20) and base parameters
``beta_hat = K @ phi_hat`` whose standard parameters are off by ``--error`` (20 %) from the plant's.
The plant is the same regressor with the true parameters: M(q) ddq + h(q, dq) = tau, integrated at
1 kHz.  With the exact base parameters and no feedback the arm follows (the base regressor and the
full one agree); with the model error and no feedback it drifts away; with feedback it tracks.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

import minparam

ROOT = Path(__file__).resolve().parents[1]


def desired(t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q_d, dq_d, ddq_d: a sine on each joint (rad)."""
    w = np.array([2.0, 3.0])
    a = np.array([0.8, 0.5])
    return a * np.sin(w * t), a * w * np.cos(w * t), -a * w**2 * np.sin(w * t)


def run(robot, base, phi_true, beta_hat, kp: float, kd: float, duration: float, dt: float = 1e-3) -> float:
    """Max tracking error (rad) over the run."""
    n = robot.dof
    q, dq = desired(0.0)[0].copy(), desired(0.0)[1].copy()
    worst = 0.0
    for k in range(int(round(duration / dt))):
        qd, dqd, ddqd = desired(k * dt)
        e, de = qd - q, dqd - dq
        worst = max(worst, float(np.abs(e).max()))
        # controller: inverse dynamics of its model at the commanded acceleration
        tau = minparam.regressor(robot, q, dq, ddqd + kp * e + kd * de, base=base) @ beta_hat
        # plant: M(q) and h(q, dq) from the full regressor and the true parameters, n + 1 rows at once
        states = np.tile(q, (n + 1, 1))
        rates = np.vstack([np.zeros((n, n)), dq])
        accs = np.vstack([np.eye(n), np.zeros(n)])
        Y = minparam.regressor(robot, states, rates, accs, base=False) @ phi_true  # (n + 1, n)
        h = Y[n]
        M = (Y[:n] - minparam.regressor(robot, q, np.zeros(n), np.zeros(n), base=False) @ phi_true).T
        ddq = np.linalg.solve(M, tau - h)
        dq = dq + dt * ddq  # semi-implicit Euler
        q = q + dt * dq
    return worst


def main(argv: list[str]) -> None:
    error = float(argv[argv.index("--error") + 1]) if "--error" in argv else 0.2
    duration = float(argv[argv.index("--duration") + 1]) if "--duration" in argv else 2.0
    robot = minparam.load_robot(ROOT / "robots" / "planar2r.yaml")
    base = minparam.derive(robot)
    phi_true = robot.chain.phi_nominal
    rng = np.random.default_rng(0)  # the controller's model error, reproducible
    phi_hat = phi_true * (1 + error * rng.choice([-1.0, 1.0], size=phi_true.size))
    beta_hat = base.K @ phi_hat
    print(f"{robot.name}: {base.n_base} base parameters {base.names}; model error {100 * error:g} % on each")
    rows = (("exact model, feed-forward only", base.K @ phi_true, 0.0, 0.0),
            ("model error, feed-forward only", beta_hat, 0.0, 0.0),
            ("model error, Kp 400, Kd 40", beta_hat, 400.0, 40.0))
    for label, beta, kp, kd in rows:
        print(f"{label:32} max tracking error {run(robot, base, phi_true, beta, kp, kd, duration):.4f} rad")


if __name__ == "__main__":
    main(sys.argv[1:])
