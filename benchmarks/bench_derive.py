"""Benchmark of `minparam derive` (issue targets in brackets).

* whole process: `minparam derive robots/puma560.yaml` vs `python -c "import numpy"`
  [<= 1.6x];
* in process: the QR base-set computation at 100 samples vs pinocchio's
  computeJointTorqueRegressor + the same QR [no slower].

Run: python benchmarks/bench_derive.py   (pinocchio: pip install ".[bench]")
"""

from __future__ import annotations

import sys

import numpy as np
from common import ROOT, best_of, minparam_cmd, run_process
from tabulate import tabulate

sys.path.insert(0, str(ROOT / "src"))

from minparam_cli.base.qr import base_from_regressor, derive_qr  # noqa: E402
from minparam_cli.chain import build_chain  # noqa: E402
from minparam_cli.describe import load_description  # noqa: E402
from minparam_cli.dynamics.regressor import random_states  # noqa: E402


def pinocchio_pipeline(chain, samples: int, seed: int):
    """Same job with pinocchio: regressor per sample (Python loop), then the same QR keep rule."""
    import pinocchio as pin

    model = pin.Model()
    parent = 0
    rng = np.random.default_rng(seed)
    for j in range(chain.n):
        placement = pin.SE3(chain.pre[j][:3, :3].copy(), chain.pre[j][:3, 3].copy())
        parent = model.addJoint(parent, pin.JointModelRevoluteUnaligned(chain.axes[j].copy()), placement, f"j{j}")
        model.appendBodyToJoint(parent, pin.Inertia.Random(), pin.SE3.Identity())
    model.gravity.linear = chain.gravity.copy()
    data = model.createData()
    q, qd, qdd = random_states(chain, samples, rng)

    def run():
        rows = [pin.computeJointTorqueRegressor(model, data, q[s], qd[s], qdd[s]) for s in range(samples)]
        kept, *_ = base_from_regressor(np.vstack(rows))
        return len(kept)

    return run


def main() -> None:
    rows = []
    t_numpy, m_numpy = run_process([sys.executable, "-c", "import numpy"])
    t_cli, m_cli = run_process(minparam_cmd() + ["derive", "robots/puma560.yaml"])
    rows.append(["python -c 'import numpy'", f"{t_numpy * 1000:.0f} ms", f"{m_numpy:.0f} MB", "1.00"])
    rows.append(["minparam derive robots/puma560.yaml", f"{t_cli * 1000:.0f} ms", f"{m_cli:.0f} MB", f"{t_cli / t_numpy:.2f} (target <= 1.6)"])
    print("Whole process (median of 7 runs)")
    print(tabulate(rows, headers=["command", "wall time", "peak RSS", "ratio to numpy import"], tablefmt="github"))
    print()

    rows = []
    for name in ("puma560_mdh.yaml", "panda.yaml"):
        chain = build_chain(load_description(ROOT / "robots" / name))
        for samples in (100, 1000):
            ours = best_of(lambda: derive_qr(chain, samples=samples, seed=0))
            n_base = derive_qr(chain, samples=samples).n_base
            try:
                run = pinocchio_pipeline(chain, samples, 0)
                theirs = best_of(run)
                assert run() == n_base, "pinocchio pipeline found another rank"
                peer = f"{theirs * 1000:.1f} ms"
                ratio = f"{theirs / ours:.2f}"
            except ImportError:
                peer, ratio = "pinocchio not installed", "-"
            rows.append([name, samples, n_base, f"{ours * 1000:.1f} ms", peer, ratio])
    print("In process: base set by random samples + QR (median of 7)")
    print(tabulate(rows, headers=["robot", "samples", "base", "minparam", "pinocchio regressor + same QR", "speed-up"], tablefmt="github"))


if __name__ == "__main__":
    main()
