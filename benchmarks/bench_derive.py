"""Benchmark of `minparam derive` (issue targets in brackets).

* whole process: `minparam derive robots/puma560.yaml` vs `python -c "import numpy"`
  [<= 1.6x]; `minparam derive robots/ur5.xml` (MJCF, MuJoCo imported for it) vs the same
  robot's `robots/ur5.urdf` [<= 1.5x];
* in process: the QR base-set computation at 100 samples vs pinocchio's
  computeJointTorqueRegressor + the same QR [no slower], with glibc's default
  allocator and with the allocator tuning the CLI applies (runtime.py);
* the regressor alone per sample: numpy reference, compiled kernel, pinocchio.

Run: python benchmarks/bench_derive.py   (pinocchio: pip install ".[bench]")
Measure the whole process with a regular install of minparam alone, as a user has it:

    python -m venv /tmp/plain && /tmp/plain/bin/pip install .
    python benchmarks/bench_derive.py --python /tmp/plain/bin/python

An editable install adds its finder's import time, and pinocchio's wheel adds a
start-up hook (cmeel.pth) to every process of its environment, numpy's import
included, which lowers the ratio; the table says when it sees one.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time

import numpy as np
from common import ROOT, best_of, minparam_cmd, run_processes_alternating, startup_hooks
from tabulate import tabulate

sys.path.insert(0, str(ROOT / "src"))

from minparam_cli.base.qr import base_from_regressor, derive_qr  # noqa: E402
from minparam_cli.chain import build_chain  # noqa: E402
from minparam_cli.describe import load_description  # noqa: E402
from minparam_cli.dynamics.regressor import random_states, regressor  # noqa: E402
from minparam_cli.runtime import tune_allocator  # noqa: E402


def pinocchio_model(chain):
    """The chain as a pinocchio model: same placements, axes and gravity (inertias do not matter here)."""
    import pinocchio as pin

    model = pin.Model()
    parent = 0
    for j in range(chain.n):
        placement = pin.SE3(chain.pre[j][:3, :3].copy(), chain.pre[j][:3, 3].copy())
        parent = model.addJoint(parent, pin.JointModelRevoluteUnaligned(chain.axes[j].copy()), placement, f"j{j}")
        model.appendBodyToJoint(parent, pin.Inertia.Random(), pin.SE3.Identity())
    model.gravity.linear = chain.gravity.copy()
    return model, model.createData()


def pinocchio_pipeline(chain, samples: int, seed: int):
    """Same job with pinocchio: regressor per sample (Python loop), then the same QR keep rule."""
    import pinocchio as pin

    model, data = pinocchio_model(chain)
    q, qd, qdd = random_states(chain, samples, np.random.default_rng(seed))

    def run():
        rows = [pin.computeJointTorqueRegressor(model, data, q[s], qd[s], qdd[s]) for s in range(samples)]
        kept, *_ = base_from_regressor(np.vstack(rows))
        return len(kept)

    return run


def interleaved(fa, fb, repeats: int = 21) -> tuple[float, float]:
    """Median times of fa and fb, run alternately after a warm-up, so that drift in the
    machine's speed hits both alike."""
    for _ in range(3):
        fa(), fb()
    ta, tb = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fa()
        t1 = time.perf_counter()
        fb()
        ta.append(t1 - t0)
        tb.append(time.perf_counter() - t1)
    return statistics.median(ta), statistics.median(tb)


def in_process_rows(allocator: str) -> list[list]:
    rows = []
    for name in ("puma560_mdh.yaml", "panda.yaml"):
        chain = build_chain(load_description(ROOT / "robots" / name))
        for samples in (100, 1000):
            n_base = derive_qr(chain, samples=samples).n_base
            ours_fn = lambda: derive_qr(chain, samples=samples, seed=0)  # noqa: E731
            try:
                run = pinocchio_pipeline(chain, samples, 0)
                assert run() == n_base, "pinocchio pipeline found another rank"
                ours, theirs = interleaved(ours_fn, run)
                peer = f"{theirs * 1000:.2f} ms"
                ratio = f"{theirs / ours:.2f}"
            except ImportError:
                ours = best_of(ours_fn, repeats=21)
                peer, ratio = "pinocchio not installed", "-"
            rows.append([allocator, name, samples, n_base, f"{ours * 1000:.2f} ms", peer, ratio])
    return rows


def regressor_rows() -> list[list]:
    """The regressor alone, per sample: numpy reference, compiled kernel, pinocchio (Python loop)."""
    rows = []
    for name in ("puma560_mdh.yaml", "panda.yaml"):
        chain = build_chain(load_description(ROOT / "robots" / name))
        for samples in (100, 10_000):
            q, qd, qdd = random_states(chain, samples, np.random.default_rng(0))
            cells = [name, samples]
            for backend in ("numpy", "kernel"):
                try:
                    t = best_of(lambda: regressor(chain, q, qd, qdd, backend=backend), repeats=11)
                    cells.append(f"{t / samples * 1e6:.2f}")
                except RuntimeError:
                    cells.append("not built")
            try:
                import pinocchio as pin

                model, data = pinocchio_model(chain)
                t = best_of(
                    lambda: [pin.computeJointTorqueRegressor(model, data, q[s], qd[s], qdd[s]) for s in range(samples)],
                    repeats=11,
                )
                cells.append(f"{t / samples * 1e6:.2f}")
            except ImportError:
                cells.append("not installed")
            rows.append(cells)
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--python", default=sys.executable, help="interpreter of the install to time as a whole process")
    ap.add_argument("--repeats", type=int, default=41, help="alternating runs of each command (default 41)")
    args = ap.parse_args()
    py = args.python
    rows = []
    (t_numpy, m_numpy), (t_floor, m_floor), (t_cli, m_cli), (t_urdf, m_urdf), (t_mjcf, m_mjcf) = run_processes_alternating(
        [
            [py, "-c", "import numpy"],
            [py, "-c", "import numpy, typer, yaml"],
            minparam_cmd(py) + ["derive", "robots/puma560.yaml"],
            minparam_cmd(py) + ["derive", "robots/ur5.urdf"],
            minparam_cmd(py) + ["derive", "robots/ur5.xml"],
        ],
        repeats=args.repeats,
    )
    rows.append(["python -c 'import numpy'", f"{t_numpy * 1000:.0f} ms", f"{m_numpy:.0f} MB", "1.00"])
    rows.append(["python -c 'import numpy, typer, yaml' (the libraries derive needs)", f"{t_floor * 1000:.0f} ms", f"{m_floor:.0f} MB", f"{t_floor / t_numpy:.2f}"])
    rows.append(["minparam derive robots/puma560.yaml", f"{t_cli * 1000:.0f} ms", f"{m_cli:.0f} MB", f"{t_cli / t_numpy:.2f} (target <= 1.6)"])
    rows.append(["minparam derive robots/ur5.urdf", f"{t_urdf * 1000:.0f} ms", f"{m_urdf:.0f} MB", f"{t_urdf / t_numpy:.2f}"])
    rows.append(["minparam derive robots/ur5.xml (MJCF: MuJoCo's compiler)", f"{t_mjcf * 1000:.0f} ms", f"{m_mjcf:.0f} MB",
                 f"{t_mjcf / t_numpy:.2f}; {t_mjcf / t_urdf:.2f} x the URDF (target <= 1.5)"])
    print(f"Whole process (median of {args.repeats} alternating runs; minparam = {minparam_cmd(py)[0]})")
    print(tabulate(rows, headers=["command", "wall time", "peak RSS", "ratio to numpy import"], tablefmt="github"))
    hooks = startup_hooks(py)
    if hooks:
        print(f"note: this environment runs start-up hooks in every process ({', '.join(hooks)}), which lowers "
              "the ratio; time a plain install with --python (see this file's docstring)")
    print()

    # glibc's default allocator first (a library caller's process), then tuned as the CLI runs
    rows = in_process_rows("glibc default")
    rows += in_process_rows("tuned (as the CLI)" if tune_allocator() else "tuning unavailable")
    print("In process: base set by random samples + QR (median of 21), both pipelines in the same process")
    headers = ["allocator", "robot", "samples", "base", "minparam derive_qr", "pinocchio regressor + same QR", "speed-up"]
    print(tabulate(rows, headers=headers, tablefmt="github"))
    print()
    print("Regressor alone, microseconds per sample (median of 11)")
    print(tabulate(regressor_rows(), headers=["robot", "samples", "minparam numpy", "minparam kernel", "pinocchio"], tablefmt="github"))


if __name__ == "__main__":
    main()
