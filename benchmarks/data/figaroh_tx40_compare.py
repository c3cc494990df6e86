"""minparam's TX40 identification against FIGAROH's own run of its TX40 example (docs/data/tx40_report.md).

Two steps, two interpreters (FIGAROH is never a dependency of minparam, and nothing of it is copied here):

1. In a throwaway environment that has FIGAROH (see the report for the versions), run FIGAROH's
   example class on the recording and save its arrays:

       /tmp/figvenv07/bin/python benchmarks/data/figaroh_tx40_compare.py --models MODELS --run-figaroh EXAMPLE_DIR OUT.npz

   EXAMPLE_DIR is a copy of figaroh-examples' examples/staubli_TX40 importable as
   ``examples.staubli_tx40`` (its identification.py imports that module name) with the URDF's meshes
   under MODELS (``--models``).  This calls the example's ``TX40Identification`` exactly as its
   ``identification.py`` does (decimate=True, save_results=False, wls=False) except plotting=False.
   FIGAROH is imported inside that function only.

2. With minparam on the path, compare (prints Markdown):

       PYTHONPATH=src python benchmarks/data/figaroh_tx40_compare.py OUT.npz MINPARAM.json

   MINPARAM.json is ``minparam identify robots/tx40.yaml examples/tx40.recording.yaml --side motor
   --cutoff 20 --format json``.  The FIGAROH rigid-body base parameters are expressed in minparam's
   base (both are K·φ of the same standard parameters, but FIGAROH's URDF frames and QR pivoting give
   other groupings): minparam's base regressor is evaluated on FIGAROH's own filtered states,
   decimated the same way (scipy.signal.decimate, q=10, zero phase, per column), and the matrix T
   with Y_minparam·T = W_FIGAROH is found by least squares; its residual shows that the two bases span
   the same space.  FIGAROH's β in minparam's base is then T·β_FIGAROH.
"""

from __future__ import annotations

import argparse
import json
import os
import sys

import numpy as np

RATE = 5000.0
BORDER = 20  # FIGAROH's example drops 5 × (Butterworth order 4) samples at each end
DECIM = 10
FIT_END, TEST_START = 5.4, 7.2  # minparam's default roles of this 9 s record (split 0.6, 0.2, 0.2)


def run_figaroh(example_parent: str, example_dir: str, models: str, out: str) -> None:
    """FIGAROH's example run, plotting off; saves its base regressor, torques, parameters and states."""
    sys.path.insert(0, example_parent)
    os.chdir(example_dir)
    import matplotlib

    matplotlib.use("Agg")
    from examples.staubli_tx40.utils.staubli_tx40_tools import TX40Identification  # type: ignore
    from figaroh.tools.robot import load_robot  # type: ignore

    robot = load_robot("urdf/tx40_mdh_modified.urdf", package_dirs=models)
    it = TX40Identification(robot, "config/TX40_config.yaml")
    it.initialize()
    it.solve(decimate=True, plotting=False, save_results=False, wls=False)
    r = it.result
    np.savez(out, W=it.dynamic_regressor_base, tau=it.tau_noised, phi=np.asarray(it.phi_base),
             names=np.array(it.params_base), std=np.asarray(r["std dev of estimated param"]),
             cond=r["condition number"], rmse=r["effort rmse"], corr=it.correlation,
             q=it.processed_data["positions"], dq=it.processed_data["velocities"],
             ddq=it.processed_data["accelerations"])


def decimate_rows(Y: np.ndarray) -> np.ndarray:
    """(N, 6, P) → FIGAROH's stacked layout (6·N/10, P): per joint, per column, scipy decimate."""
    from scipy import signal

    blocks = [np.column_stack([signal.decimate(Y[:, j, c], q=DECIM, zero_phase=True) for c in range(Y.shape[2])])
              for j in range(Y.shape[1])]
    return np.vstack(blocks)


def rms_rows(r: np.ndarray, nj: int = 6) -> np.ndarray:
    return np.sqrt((r.reshape(nj, -1) ** 2).mean(axis=1))


def fmt(x: float) -> str:
    return f"{x:.4g}"


def compare(npz: str, mp_json: str, robot_file: str = "robots/tx40.yaml") -> None:
    from minparam_cli.api.robot import derive, load_robot, regressor

    d = np.load(npz)
    W, tau, phi, names, std = d["W"], d["tau"], d["phi"], [str(s) for s in d["names"]], d["std"]
    mp = json.load(open(mp_json))
    par = mp["parameters"]
    nj = 6
    n = W.shape[0] // nj
    t = (BORDER + DECIM * np.arange(n)) / RATE
    fit, test = t < FIT_END, t >= TEST_START

    def rows(mask):
        return np.concatenate([np.where(mask)[0] + j * n for j in range(nj)])

    rf, rt = rows(fit), rows(test)
    phi_fit, *_ = np.linalg.lstsq(W[rf], tau[rf], rcond=None)
    res_all = tau - W @ phi
    sig_fit = np.sqrt(np.sum((tau[rf] - W[rf] @ phi_fit) ** 2) / (len(rf) - W.shape[1]))
    C = sig_fit**2 * np.linalg.inv(W[rf].T @ W[rf])
    std_fit = 100 * np.sqrt(np.diag(C)) / np.abs(phi_fit)

    print("## FIGAROH run")
    print(f"base parameters {len(phi)}; samples {n} per joint after decimation ({W.shape[0]} rows); "
          f"condition number {float(d['cond']):.1f}; effort rmse {float(d['rmse']):.3f} N·m; "
          f"correlation {float(d['corr']):.4f}")
    print("rms per joint, all data, in-sample [N·m]: " + " ".join(f"{x:.3f}" for x in rms_rows(res_all)))

    # friction and rotor inertias, same meaning on both sides
    print("\n## Friction and rotor inertia (joint side)")
    print("| parameter | FIGAROH all data (σ %) | FIGAROH columns, fit t < 5.4 s (σ %) | minparam 20 Hz (σ % hac) | minparam / FIGAROH all | minparam / FIGAROH t < 5.4 s |")
    print("|---|---|---|---|---|---|")
    pairs = [(f"fv_joint_{j}", f"Fv{j}") for j in range(1, 7)] + [(f"fs_joint_{j}", f"Fc{j}") for j in range(1, 7)] \
        + [(f"Ia_joint_{j}", f"Ia{j}") for j in range(3, 7)]
    for fn, mn in pairs:
        i = names.index(fn)
        m = par.get(mn)
        mv = f"{fmt(m['value'])} ({m['std_percent']:.3g})" if m else "—"
        r1 = f"{m['value'] / phi[i]:.3f}" if m else "—"
        r2 = f"{m['value'] / phi_fit[i]:.3f}" if m else "—"
        print(f"| {fn} / {mn} | {fmt(phi[i])} ({std[i]:.3g}) | {fmt(phi_fit[i])} ({std_fit[i]:.3g}) | {mv} | {r1} | {r2} |")
    offs = [names.index(f"off_joint_{j}") for j in range(1, 7)]
    print("\nFIGAROH torque offsets off_joint_1..6 [N·m], all data: " + ", ".join(fmt(phi[i]) for i in offs)
          + "; fit t < 5.4 s: " + ", ".join(fmt(phi_fit[i]) for i in offs) + " (minparam's run has no offset column)")
    for k in ("Iam6", "Fcm6", "Fvm6"):
        if k in par:
            print(f"minparam {k} = {par[k]['value']:.4g} (σ {par[k]['std_percent']:.3g} %): no FIGAROH column")

    # rigid body in minparam's base
    rob = load_robot(robot_file)
    bs = derive(rob, symbolic=True)
    rigid = [k for k, nm in enumerate(bs.names) if nm not in ("Iam6", "Fcm6", "Fvm6")]
    Y = regressor(rob, d["q"], d["dq"], d["ddq"], base=bs)[:, :, rigid]
    ia = np.zeros(Y.shape[:2] + (4,))
    for c, j in enumerate(range(2, 6)):
        ia[:, j, c] = d["ddq"][:, j]
    Yd = decimate_rows(np.concatenate([Y, ia], axis=2))
    fcols = [k for k, nm in enumerate(names) if not nm.startswith(("fv_", "fs_", "off_"))]
    Wf = W[:, fcols]
    T, *_ = np.linalg.lstsq(Yd, Wf, rcond=None)
    resid = np.linalg.norm(Yd @ T - Wf, axis=0) / np.linalg.norm(Wf, axis=0)
    mnames = [bs.names[k] for k in rigid] + [f"Ia{j}" for j in range(3, 7)]
    print(f"\n## Rigid body in minparam's base ({len(mnames)} columns against FIGAROH's {len(fcols)})")
    print(f"largest relative residual of Y_minparam·T = W_FIGAROH over FIGAROH's columns: {resid.max():.2e}")
    b_all, b_fit = T @ phi[fcols], T @ phi_fit[fcols]
    print("| minparam base | FIGAROH all data | FIGAROH fit t < 5.4 s | minparam 20 Hz | σ % (hac) | minparam / FIGAROH t < 5.4 s | difference / σ |")
    print("|---|---|---|---|---|---|---|")
    within = 0
    for k, nm in enumerate(mnames):
        m = par[nm]
        s = abs(m["value"]) * m["std_percent"] / 100
        z = (m["value"] - b_fit[k]) / s if s > 0 else float("inf")
        within += abs(z) <= 2
        print(f"| {nm} | {fmt(b_all[k])} | {fmt(b_fit[k])} | {fmt(m['value'])} | {m['std_percent']:.3g} | "
              f"{m['value'] / b_fit[k]:.3f} | {z:+.2f} |")
    print(f"\n{within} of {len(mnames)} within 2 σ (minparam's hac σ) of FIGAROH's fit on t < 5.4 s")
    keep = [k for k, nm in enumerate(names) if not nm.startswith("off_")]
    p_no, *_ = np.linalg.lstsq(W[rf][:, keep], tau[rf], rcond=None)
    p_full = np.zeros(len(names))
    p_full[keep] = p_no
    b_no = T @ p_full[fcols]
    print("FIGAROH's columns without its offsets, fit t < 5.4 s, in minparam's base: "
          + ", ".join(f"{nm} {fmt(b_no[mnames.index(nm)])}" for nm in ("ZZR1", "XXR2", "ZZR2", "MXR2", "MYR3", "ZZR3", "Ia3")))

    # held-out block
    print("\n## Test block t ≥ 7.2 s, rms per joint [N·m] on FIGAROH's own torque samples")
    from scipy import signal

    b, a = signal.butter(4, 20 / (RATE / DECIM / 2))
    tau_t = tau[rt].reshape(nj, -1)
    floor = np.sqrt(((tau_t - signal.filtfilt(b, a, tau_t, axis=1)) ** 2).mean(axis=1))
    for label, p in (("FIGAROH all data (test block in its fit)", phi), ("FIGAROH columns, fit t < 5.4 s", phi_fit)):
        r = tau[rt] - W[rt] @ p
        print(f"{label}: " + " ".join(f"{x:.3f}" for x in rms_rows(r))
              + f"; ‖r‖/‖τ‖ {100 * np.linalg.norm(r) / np.linalg.norm(tau[rt]):.1f} %")
    # what-ifs on FIGAROH's own samples, refitted on t < 5.4 s: (a) the three motor-6 columns that the
    # example defines (its add_additional_parameters, which FIGAROH 0.7.0 never calls): on joint 5's row
    # ddq6, dq6, sign(dq5 + dq6), on joint 6's row ddq5, dq5, sign(dq5 + dq6); (b) minparam's rest rule
    # (derived |dq| < 0.01 rad/s read as dq = 0) in the Coulomb columns.
    dq, ddq = d["dq"], d["ddq"]
    N = dq.shape[0]
    s56 = np.sign(dq[:, 4] + dq[:, 5])
    extra = np.zeros((N, nj, 3))
    extra[:, 4] = np.column_stack([ddq[:, 5], dq[:, 5], s56])
    extra[:, 5] = np.column_stack([ddq[:, 4], dq[:, 4], s56])
    Xc = decimate_rows(extra)
    rest = np.where(np.abs(dq) < 0.01, 0.0, np.sign(dq))
    fs_cols = [names.index(f"fs_joint_{j}") for j in range(1, 7)]
    Ws = W.copy()
    Ws[:, fs_cols] = decimate_rows(np.stack([np.diag(r) for r in rest]))[:, :6]
    s56r = np.sign(np.where(np.abs(dq[:, 4] + dq[:, 5]) < 0.01, 0.0, dq[:, 4] + dq[:, 5]))
    extra_r = extra.copy()
    extra_r[:, 4, 2] = extra_r[:, 5, 2] = s56r
    Xcr = decimate_rows(extra_r)
    for label, M in (("(a) + motor-6 columns", np.hstack([W, Xc])), ("(b) + rest rule", Ws),
                     ("(a) + (b)", np.hstack([Ws, Xcr]))):
        p, *_ = np.linalg.lstsq(M[rf], tau[rf], rcond=None)
        r = tau[rt] - M[rt] @ p
        print(f"FIGAROH columns {label}, fit t < 5.4 s: " + " ".join(f"{x:.3f}" for x in rms_rows(r))
              + f"; ‖r‖/‖τ‖ {100 * np.linalg.norm(r) / np.linalg.norm(tau[rt]):.1f} %")
    print("their target's content above 20 Hz in the block: " + " ".join(f"{x:.3f}" for x in floor))
    still = (np.abs(d["dq"][::DECIM][:n][test]) < 0.01).mean(axis=0)
    print("share of the block with derived |dq| < 0.01 rad/s: " + " ".join(f"{x:.2f}" for x in still))
    for f in mp["test"]["files"]:
        fin = f["final"]
        print(f"minparam 20 Hz, final model, {f['part']} ({f['samples']} samples of its own, filtered at 20 Hz): "
              + " ".join(f"{x:.3f}" for x in fin["rms_per_joint"]) + f"; ‖r‖/‖τ‖ {100 * fin['relative_error']:.1f} %")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--run-figaroh", nargs=2, metavar=("EXAMPLE_DIR", "OUT"))
    ap.add_argument("--models", help="folder holding staubli_tx40_description/ (the URDF's meshes); needed by --run-figaroh")
    ap.add_argument("files", nargs="*", help="OUT.npz MINPARAM.json")
    a = ap.parse_args()
    if a.run_figaroh:
        if not a.models:
            ap.error("--run-figaroh needs --models")
        ex = os.path.abspath(a.run_figaroh[0])
        run_figaroh(os.path.dirname(os.path.dirname(ex)), ex, os.path.abspath(a.models), os.path.abspath(a.run_figaroh[1]))
    elif len(a.files) == 2:
        compare(*a.files)
    else:
        ap.error("give --run-figaroh EXAMPLE_DIR OUT.npz, or OUT.npz MINPARAM.json")


if __name__ == "__main__":
    main()
