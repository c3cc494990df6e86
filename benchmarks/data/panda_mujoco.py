"""From identification to simulation on the real Panda: identify, export MJCF, torques in MuJoCo (docs/simulation.md).

    python benchmarks/data/panda_mujoco.py [--data PATH] [--keep DIR]

Runs, from the repository root, the commands a user would type:

    minparam identify robots/panda.yaml DATA --no-diagnose --friction coulomb,viscous,offset --physical \\
        --save-model DIR/panda.json --export-mjcf DIR/panda.xml --export-urdf DIR/panda.urdf
        (default split: fit on the first 60 % of the time, selection on the next 20 %, test on the last 20 %)
    minparam evaluate DIR/panda.json DIR/test.csv
        (DIR/test.csv: the rows of DATA in the test share, the last 20 % of the time; they chose nothing)

then reads DIR/test.csv with the model's data settings (the same filtered q, q̇ and derived q̈ that
``evaluate`` uses: ``measured.blocks.iter_blocks``), and computes in MuJoCo (``mj_inverse``, on the
exported MJCF, joint limits off):

* "MuJoCo": the torque as MuJoCo models it, friction loss as its soft constraint;
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


def test_rows(data: Path, out: Path, start_share: float = 0.8) -> float:
    """Write the rows of the test share (the last 20 % of the time) to ``out``; returns its first time."""
    lines = data.read_text().splitlines()
    t = np.array([float(line.split(",", 1)[0]) for line in lines[1:]])
    t_start = t[0] + start_share * (t[-1] - t[0])
    keep = [lines[0]] + [line for line, ti in zip(lines[1:], t) if ti >= t_start]
    out.write_text("\n".join(keep) + "\n")
    return float(t_start)


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
    from minparam_cli.model.evaluation import predict

    data = (ROOT / args.data).resolve() if not args.data.is_absolute() else args.data
    with tempfile.TemporaryDirectory() as tmp:
        folder = args.keep.resolve() if args.keep else Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        model, mjcf, urdf, test = (folder / x for x in ("panda.json", "panda.xml", "panda.urdf", "test.csv"))
        report = json.loads(run("identify", ROBOT, str(data), "--no-diagnose", "--friction", "coulomb,viscous,offset",
                                "--physical", "-q", "--format", "json", "--save-model", str(model),
                                "--export-mjcf", str(mjcf), "--export-urdf", str(urdf)))
        t_start = test_rows(data, test)
        evaluated = json.loads(run("evaluate", str(model), str(test), "--format", "json"))
        saved, _, design = open_model(model)
        theta = saved.fit_theta("physical")
        side = __import__("yaml").safe_load((folder / "panda.xml.extra.yaml").read_text())
        m_full = mujoco.MjModel.from_xml_path(str(mjcf))
        m_full.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_LIMIT
        m_rigid = mujoco.MjModel.from_xml_path(str(mjcf))
        m_rigid.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
        chain = design.chain
        order = np.array([m_full.jnt_dofadr[m_full.joint(name).id] for name in chain.joint_names])
        offsets = np.array([side.get("joints", {}).get(name, {}).get("offset", 0.0) for name in chain.joint_names])
        fc = m_full.dof_frictionloss[order]
        taus, ours, full, rigid = [], [], [], []
        for b in iter_blocks(test, chain.dof, saved.data):
            if not len(b):
                continue
            taus.append(b.tau)
            ours.append(predict(design, theta, b))
            for mm, out in ((m_full, full), (m_rigid, rigid)):
                d = mujoco.MjData(mm)
                rows = np.empty_like(b.tau)
                for i in range(len(b)):
                    d.qpos[order], d.qvel[order], d.qacc[order] = b.q[i], b.dq[i], b.ddq[i]
                    mujoco.mj_inverse(mm, d)
                    rows[i] = d.qfrc_inverse[order]
                out.append(rows)
        tau, ours_, full_, rigid_ = (np.concatenate(x) for x in (taus, ours, full, rigid))
        dq = np.concatenate([b.dq for b in iter_blocks(test, chain.dof, saved.data) if len(b)])
        side_model = rigid_ + fc * np.sign(dq) + offsets
    print(f"data: {args.data} (Gaz et al. 2019, real Panda); robot {ROBOT}")
    print("identify --no-diagnose --friction coulomb,viscous,offset --physical, default split; "
          f"test share: t >= {t_start:.3f} s, {len(tau)} samples (chose nothing)")
    print(f"identify's own test error of the physical fit (report): {report['physical']['test']}" if "physical" in report
          and "test" in report.get("physical", {}) else "")
    print(f"minparam evaluate on test.csv: ‖r‖/‖τ‖ = {evaluated['pooled']['relative']:.4f}"
          if "pooled" in evaluated and "relative" in evaluated["pooled"] else json.dumps(evaluated)[:400])
    print(f"side file panda.xml.extra.yaml holds: {', '.join(sorted(side.get('joints', {})))} offsets")
    rows = [("minparam (regressor · θ_physical)", rel(tau, ours_)), ("MuJoCo mj_inverse, MJCF as written", rel(tau, full_)),
            ("MuJoCo, constraints off, + Fc·sign(q̇) + side-file offsets", rel(tau, side_model))]
    n = tau.shape[1]
    print("\n| torque error on the test share (‖r_j‖/‖τ_j‖) | " + " | ".join(f"j{j + 1}" for j in range(n)) + " | all |")
    print("|---|" + "---:|" * (n + 1))
    for name, (per, tot) in rows:
        print(f"| {name} | " + " | ".join(f"{x:.4f}" for x in per) + f" | {tot:.4f} |")
    print(f"\nlargest |MuJoCo + side file − minparam| on the test share: {np.abs(side_model - ours_).max():.3e} N·m "
          f"(torques up to {np.abs(tau).max():.1f} N·m)")


if __name__ == "__main__":
    main()
