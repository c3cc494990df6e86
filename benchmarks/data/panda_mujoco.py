"""From identification to simulation on the real Panda: identify, export MJCF, torques in MuJoCo (docs/simulation.md).

    python benchmarks/data/panda_mujoco.py [--data PATH] [--keep DIR]

Runs, from the repository root, the commands a user would type:

    minparam identify robots/panda.yaml DATA --no-diagnose --friction coulomb,viscous,offset --physical \\
        --save-model DIR/panda.json --export-mjcf DIR/panda.xml --export-urdf DIR/panda.urdf
        (default split: fit on the first 60 % of the time, selection on the next 20 %, test on the last 20 %)
    minparam evaluate DIR/panda.json DATA --predictions DIR/predictions.csv
        (its predictions on the samples of the test share, which chose nothing)

then reads DATA with the model's data settings (the same filtered q, q̇ and derived q̈ that
``evaluate`` uses: ``measured.blocks.iter_blocks``), keeps the test share, and computes in MuJoCo
(``mj_inverse``, on the exported MJCF, joint limits off):

* "MuJoCo": the torque as MuJoCo models it, friction loss as its soft constraint (with and without the
  offsets of the side file added);
* "MuJoCo + side file": constraints off, plus Fc·sign(q̇) (the MJCF's frictionloss) and the offsets of
  panda.xml.extra.yaml, i.e. the whole identified model through MuJoCo's rigid-body code.

Prints the relative RMS error ‖r_j‖/‖τ_j‖ per joint and overall (‖r‖/‖τ‖ over all joints) of each, beside
``minparam evaluate``'s on the same samples.  DATA defaults to ../shared/data/panda-gaz2019/panda_exciting_traj_1.csv.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
DEFAULT_DATA = Path("..") / "shared" / "data" / "panda-gaz2019" / "panda_exciting_traj_1.csv"
ROBOT = "robots/panda.yaml"


def run(*args: str) -> str:
    r = subprocess.run([sys.executable, "-m", "minparam_cli", *args], cwd=ROOT, capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit(f"minparam {' '.join(args)} failed:\n{r.stderr}")
    return r.stdout


def rel(tau: np.ndarray, pred: np.ndarray) -> tuple[list[float], float]:
    r = tau - pred
    return [float(np.linalg.norm(r[:, j]) / np.linalg.norm(tau[:, j])) for j in range(tau.shape[1])], \
        float(np.linalg.norm(r) / np.linalg.norm(tau))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", type=Path, default=DEFAULT_DATA)
    ap.add_argument("--keep", type=Path, default=None, help="keep the exported files in this folder")
    args = ap.parse_args()
    sys.path.insert(0, str(ROOT / "src"))
    from minparam_cli.optional import import_optional

    mujoco = import_optional("mujoco", "mujoco", "benchmarks/data/panda_mujoco.py")
    from minparam_cli.api.model_file import open_model
    from minparam_cli.measured.blocks import iter_blocks
    import yaml

    from minparam_cli.model.evaluation import predict

    data = (ROOT / args.data).resolve() if not args.data.is_absolute() else args.data
    with tempfile.TemporaryDirectory() as tmp:
        folder = args.keep.resolve() if args.keep else Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        model, mjcf, urdf, pred_csv = (folder / x for x in ("panda.json", "panda.xml", "panda.urdf", "predictions.csv"))
        report = json.loads(run("identify", ROBOT, str(data), "--no-diagnose", "--friction", "coulomb,viscous,offset",
                                "--physical", "-q", "--format", "json", "--save-model", str(model),
                                "--export-mjcf", str(mjcf), "--export-urdf", str(urdf)))
        test = report["test"]["files"][0]
        t_start = float(test["time_s"][0])
        run("evaluate", str(model), str(data), "--predictions", str(pred_csv), "--format", "json")
        table = np.loadtxt(pred_csv, delimiter=",", skiprows=1)
        saved, _, design = open_model(model)
        chain = design.chain
        n = chain.dof
        rows = table[table[:, 0] >= t_start]
        tau_eval, pred_eval = rows[:, 1 : 1 + n], rows[:, 1 + n : 1 + 2 * n]
        side = yaml.safe_load((folder / "panda.xml.extra.yaml").read_text())
        flags = [f for f in report["flags"] if ".extra.yaml" in f]
        m_full = mujoco.MjModel.from_xml_path(str(mjcf))
        m_full.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_LIMIT
        m_rigid = mujoco.MjModel.from_xml_path(str(mjcf))
        m_rigid.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
        order = np.array([m_full.jnt_dofadr[m_full.joint(name).id] for name in chain.joint_names])
        offsets = np.array([side.get("joints", {}).get(name, {}).get("offset", 0.0) for name in chain.joint_names])
        fc = m_full.dof_frictionloss[order]
        taus, dqs, full, rigid, ours = [], [], [], [], []
        theta = saved.fit_theta("physical")
        for b in iter_blocks(data, n, saved.data):  # the model's data settings: the q, q̇, q̈ evaluate uses
            keep = b.t >= t_start
            if not keep.any():
                continue
            taus.append(b.tau[keep])
            ours.append(predict(design, theta, b)[keep])
            dqs.append(b.dq[keep])
            for mm, out in ((m_full, full), (m_rigid, rigid)):
                d = mujoco.MjData(mm)
                got = np.empty((int(keep.sum()), n))
                for i, k in enumerate(np.flatnonzero(keep)):
                    d.qpos[order], d.qvel[order], d.qacc[order] = b.q[k], b.dq[k], b.ddq[k]
                    mujoco.mj_inverse(mm, d)
                    got[i] = d.qfrc_inverse[order]
                out.append(got)
        tau, dq, full_, rigid_, ours_ = (np.concatenate(x) for x in (taus, dqs, full, rigid, ours))
        with_side = rigid_ + fc * np.sign(dq) + offsets
    assert tau.shape == tau_eval.shape and np.allclose(tau, tau_eval, rtol=1e-9, atol=1e-9)  # the CSV's 12 digits
    print(f"data: {args.data} (Gaz et al. 2019, real Panda), robot {ROBOT}")
    print("minparam identify ROBOT DATA --no-diagnose --friction coulomb,viscous,offset --physical --export-mjcf ... "
          "(default split 0.6/0.2/0.2)")
    print(f"test share: t >= {t_start:.5f} s, {len(tau)} samples after filtering (identify's report: "
          f"{test['samples']}); it chose nothing (fit: first 60 %, selection: next 20 %)")
    for f in flags:
        print(f"identify: {f}")
    print(f"identify's own test error of the physical fit (its report): relative "
          f"{report['physical']['test']['test1']['relative_error']:.4f}")
    results = [("minparam evaluate (physical model)", tau_eval, pred_eval),
               ("MuJoCo mj_inverse on the MJCF (frictionloss its soft constraint)", tau, full_),
               ("the same + side-file offsets", tau, full_ + offsets),
               ("MuJoCo mj_inverse, constraints off, + Fc·sign(q̇) + side-file offsets", tau, with_side)]
    print("\n| test share: ‖r_j‖/‖τ_j‖ | " + " | ".join(f"j{j + 1}" for j in range(n)) + " | all |")
    print("|---|" + "---:|" * (n + 1))
    for name, t, p in results:
        per, tot = rel(t, p)
        print(f"| {name} | " + " | ".join(f"{x:.4f}" for x in per) + f" | {tot:.4f} |")
    print("\n| test share: RMS error, N·m | " + " | ".join(f"j{j + 1}" for j in range(n)) + " | all |")
    print("|---|" + "---:|" * (n + 1))
    for name, t, p in results:
        r = t - p
        print(f"| {name} | " + " | ".join(f"{x:.4f}" for x in np.sqrt(np.mean(r**2, axis=0))) + f" | {np.sqrt(np.mean(r**2)):.4f} |")
    print(f"\nlargest |MuJoCo + side file − minparam's X·θ| on the test share: {np.abs(with_side - ours_).max():.2e} N·m "
          f"(measured torques up to {np.abs(tau).max():.1f} N·m)")


if __name__ == "__main__":
    main()
