"""Identify a robot from joint data you already hold in memory, and plot the torque before/after.

    python examples/identify_arrays.py [FIGURE.png] [--duration SECONDS]

Your logger gives arrays t (N,), q, dq, tau (N, dof); here ``minparam.simulate`` stands in for it
(a 2R arm in a vertical plane with Coulomb and viscous friction and torque noise).  ``identify``
fits the rigid-body base parameters, lets the selection data choose the missing effects (it finds
the friction), and reports the error on test data that chose nothing.  The figure shows the test
part of joint 1: measured torque, the rigid-body model and the final model.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

import minparam

ROOT = Path(__file__).resolve().parents[1]
ROBOT = ROOT / "robots" / "planar2r.yaml"


def main(argv: list[str]) -> None:
    duration = float(argv[argv.index("--duration") + 1]) if "--duration" in argv else 10.0
    args = [a for i, a in enumerate(argv) if not a.startswith("--") and (i == 0 or argv[i - 1] != "--duration")]
    figure = Path(args[0]) if args else Path("identify_before_after.png")
    # stand-in for your logger: 10 s at 200 Hz; dq comes from the logger, ddq is left to identify
    sim = minparam.simulate(ROBOT, effects="coulomb,viscous", noise=0.05, duration=duration, seed=3)
    data = {"t": sim.t, "q": sim.q, "dq": sim.dq, "tau": sim.tau}

    rigid = minparam.identify(ROBOT, data, diagnose=False)  # the rigid-body model alone
    final = minparam.identify(ROBOT, data)  # with the effects the residual asks for
    print("effects found:", ", ".join(e["effect"] for e in final.effects) or "none")
    for name, r in (("rigid body", rigid), ("final", final)):
        assert r.test is not None
        print(f"{name:10}  test error {100 * r.test.relative_error:5.2f} %  "
              f"RMS per joint {np.round(r.test.rms_per_joint, 3)} N·m")
    truth = {k: v for e in sim.to_dict()["effects"] for k, v in zip((f"{e['columns'][0]}1", f"{e['columns'][0]}2"),
                                                                  (e["coefficients"]["1"][0], e["coefficients"]["2"][0]))}
    for name, value in final.parameters.items():
        if name in truth:
            print(f"{name}: identified {value:.3f}, simulated {truth[name]:.3f}")

    import matplotlib

    matplotlib.use("Agg")  # a file, no window
    import matplotlib.pyplot as plt

    test = sim.t >= sim.t[0] + 0.8 * (sim.t[-1] - sim.t[0])  # the default split's test share: the last 20 %
    args = (sim.q[test], sim.dq[test], sim.ddq[test])
    fig, ax = plt.subplots(figsize=(8, 3.5))
    ax.plot(sim.t[test], sim.tau[test, 0], color="0.6", lw=2, label="measured")
    ax.plot(sim.t[test], rigid.predict(*args)[:, 0], "--", label="rigid-body model")
    ax.plot(sim.t[test], final.predict(*args)[:, 0], label="+ " + ", ".join(e["effect"] for e in final.effects))
    ax.set(xlabel="t [s]", ylabel="joint 1 torque [N·m]", title=f"{final.robot}: test data")
    ax.legend(loc="best")
    fig.tight_layout()
    fig.savefig(figure, dpi=100)
    print("figure:", figure)


if __name__ == "__main__":
    main(sys.argv[1:])
