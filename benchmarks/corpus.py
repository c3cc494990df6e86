"""`minparam derive` over every URDF of example-robot-data, against pinocchio.

Reference count per robot: pinocchio's computeJointTorqueRegressor of the
fixed-base model (buildModelFromUrdf, no free-flyer) at random states, stacked,
then pivoted QR (scipy.linalg.qr, pivoting=True); rank = #{|R_kk| > 1e-8 |R_00|}.
The table also prints the reference's gap (smallest kept and largest dropped
|R_kk| / |R_00|), so a reader sees how clean each reference decision is.

Mimic joints: pinocchio's model keeps every joint independent (the <mimic> tags
are not applied); the coupling is read here from the URDF text (q = m q_master
+ o, mimics of mimics followed), the states are drawn for the independent
joints only, and the regressor's rows are projected, Y_red = Gᵀ Y_full, G the
(nv x n_independent) coupling Jacobian, before the same pivoted QR.

Regrouping (column "regrouping"): on the reference's coupled regressor W (fixed base, pinocchio's
columns put in minparam's order), max over columns |W - W_kept K| / largest column, with the kept
columns and K of ``derive --method qr``; above the cut (1e-8) the verdict is "differ" even where the
counts agree (icub-models' left_hand_mk3 before small columns regrouped: 1.2e-8).

Hands with coupled fingers (issue 33 point 4; the packages are not in the bench extra):
      pip install dexmate-urdf icub-models
      python benchmarks/corpus.py --no-floating \
        --robots "$(python -c 'import dexmate_urdf, pathlib; print(pathlib.Path(dexmate_urdf.__file__).parent / "robots" / "hands")')" \
        --robots "$(python -c 'import icub_models; print(icub_models.get_models_path() / "left_hand_mk3")')" \
        --robots tests/data/hands

Floating base (columns "free-flyer"): the reference is the same with
buildModelFromUrdf(path, JointModelFreeFlyer()) and random configurations
(pinocchio.randomConfiguration: unit quaternions); minparam runs
``--floating-base`` (QR only: the projection route refuses a floating base).

minparam: ``derive_file`` with --method qr and --method projection, each timed
in this process (the first robot also pays the imports).  Verdicts:

* agree: QR equals the reference, and projection too or projection refused
  by its size guard (then the projection column says why);
* differ: a count differs from the reference;
* refused: floating: not supported yet (a floating joint inside the tree, planar joints);
* no moving joint: the file has no revolute, continuous or prismatic joint
  (pinocchio's model has nv = 0 too);
* invalid file: minparam refuses it with a description error (the message
  is shown) and pinocchio cannot build it either.

Run:  pip install ".[bench]"   (pin, example-robot-data)
      python benchmarks/corpus.py [--robots DIR ...] [--samples 100] [--markdown]
"""

from __future__ import annotations

import argparse
import sys
import time
import xml.etree.ElementTree as ET
from collections import Counter
from pathlib import Path

import numpy as np
from common import ROOT
from tabulate import tabulate

sys.path.insert(0, str(ROOT / "src"))

from minparam_cli.errors import ComputationError, DescriptionError, MinparamError, UnsupportedError  # noqa: E402
from minparam_cli.api.derivation import derive_file  # noqa: E402
from minparam_cli.api.options.derive import DeriveOptions  # noqa: E402

REFERENCE_RTOL = 1e-8


def find_robots() -> Path:
    """The robots/ folder example-robot-data installs under cmeel.prefix/share."""
    for entry in sys.path:
        p = Path(entry) / "cmeel.prefix" / "share" / "example-robot-data" / "robots"
        if p.is_dir():
            return p
    raise SystemExit("example-robot-data not found: pip install '.[bench]' (or pass --robots DIR)")


def joint_summary(path: Path) -> tuple[str, Counter]:
    """'6R 1P 2C 5F' (revolute, prismatic, continuous, fixed), plus mimic and floating counts."""
    root = ET.parse(path).getroot()
    count = Counter(j.get("type") for j in root.iter("joint"))
    count["mimic"] = sum(1 for j in root.iter("joint") if j.find("mimic") is not None)
    parts = [f"{count[k]}{s}" for k, s in (("revolute", "R"), ("prismatic", "P"), ("continuous", "C"), ("fixed", "F")) if count[k]]
    if count["floating"] or count["planar"]:
        parts.append(f"{count['floating'] + count['planar']} floating/planar")
    if count["mimic"]:
        parts.append(f"{count['mimic']} mimic")
    return " ".join(parts) or "none", count


def mimic_map(path: Path) -> dict[str, tuple[str, float, float]]:
    """{mimic joint: (independent joint, multiplier, offset)} from the URDF text, chains followed."""
    root = ET.parse(path).getroot()
    direct = {}
    for j in root.iter("joint"):
        el = j.find("mimic")
        if el is not None and j.get("type") != "fixed":
            direct[j.get("name")] = (el.get("joint"), float(el.get("multiplier", 1)), float(el.get("offset", 0)))
    out = {}
    for name, (master, m, o) in direct.items():
        for _ in range(len(direct)):
            if master not in direct:
                break
            nxt, m2, o2 = direct[master]
            master, m, o = nxt, m * m2, m * o2 + o
        out[name] = (master, m, o)
    return out


def reference_rank(path: Path, samples: int, seed: int = 0, free_flyer: bool = False):
    """(rank, (kept gap, dropped gap), nv) from pinocchio, or (None, error text, 0); mimic joints
    through their coupling, the base a free-flyer when asked."""
    import pinocchio as pin
    import scipy.linalg

    try:
        model = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer()) if free_flyer else pin.buildModelFromUrdf(str(path))
    except Exception as e:  # pinocchio raises ValueError/RuntimeError on malformed files
        return None, "pinocchio: " + str(e).strip().splitlines()[0].replace(str(path), path.name), 0
    if model.nv == 0:
        return None, "nv = 0", 0
    data = model.createData()
    rng = np.random.default_rng(seed)
    mimic = mimic_map(path)
    names = list(model.names)
    for name, (master, _, _) in mimic.items():
        if master not in names:  # pinocchio builds the model but the coupling cannot be applied
            return None, f"reference: mimic joint '{master}' of '{name}' is not in the model", 0
    joints = list(model.joints)
    indep = [k for k in range(1, model.njoints) if names[k] not in mimic]
    # G: every velocity index of the model from the independent ones (a free-flyer's 6 included)
    cols = {}
    for k in indep:
        for i in range(joints[k].nv):
            cols[(k, i)] = len(cols)
    G = np.zeros((model.nv, len(cols)))
    for k in range(1, model.njoints):
        jm = joints[k]
        if names[k] in mimic:
            master, m, _ = mimic[names[k]]
            G[jm.idx_v, cols[(names.index(master), 0)]] = m
        else:
            for i in range(jm.nv):
                G[jm.idx_v + i, cols[(k, i)]] = 1.0
    lower, upper = -np.pi * np.ones(model.nq), np.pi * np.ones(model.nq)
    rows = []
    for _ in range(samples):
        q = pin.randomConfiguration(model, lower, upper) if free_flyer else pin.neutral(model)
        angle = {}
        for k in indep:
            joint = joints[k]
            if joint.nq == 7:  # the free-flyer: randomConfiguration's
                continue
            angle[names[k]] = rng.uniform(-np.pi, np.pi, joint.nq if joint.nq != 2 else 1)
        for k in range(1, model.njoints):
            joint = joints[k]
            if joint.nq == 7:
                continue
            if names[k] in mimic:
                master, m, o = mimic[names[k]]
                a = m * angle[master] + o
            else:
                a = angle[names[k]]
            if joint.nq == 2 and joint.nv == 1:  # continuous: (cos, sin)
                q[joint.idx_q : joint.idx_q + 2] = np.cos(a[0]), np.sin(a[0])
            else:
                q[joint.idx_q : joint.idx_q + joint.nq] = a
        v, a = G @ rng.standard_normal(G.shape[1]), G @ rng.standard_normal(G.shape[1])
        rows.append(G.T @ pin.computeJointTorqueRegressor(model, data, q, v, a))
    W = np.vstack(rows)
    R = scipy.linalg.qr(W, mode="r", pivoting=True)[0]
    r = np.abs(np.diagonal(R))
    rank = int(np.sum(r > REFERENCE_RTOL * r[0]))
    if not free_flyer:
        LAST_REFERENCE.update(W=W, names=names)
    return rank, (r[rank - 1] / r[0], r[rank] / r[0] if rank < len(r) else 0.0), model.nv


# the last fixed-base reference's coupled regressor and pinocchio's joint names (regrouping_error)
LAST_REFERENCE: dict = {}
# minparam's XX XY XZ YY YZ ZZ MX MY MZ M -> pinocchio's (m, m·c, I about the joint frame) column
PIN_ORDER = [4, 5, 7, 6, 8, 9, 1, 2, 3, 0]


def regrouping_error(path: Path, samples: int) -> float | None:
    """max over columns |W - W_kept K| / largest column on pinocchio's coupled regressor W (the last
    reference_rank), K and the kept columns from ``derive --method qr``: the regrouping holds where it
    is below the cut (REFERENCE_RTOL).  None where no reference or the joints do not match."""
    from minparam_cli.api.options.derive import DeriveOptions as Opts
    from minparam_cli.base.qr import derive_qr
    from minparam_cli.robot import load_chain

    if "W" not in LAST_REFERENCE:
        return None
    W, names = LAST_REFERENCE.pop("W"), LAST_REFERENCE.pop("names")
    try:
        chain = load_chain(path, Opts())[1]
        base = derive_qr(chain, samples)
        cols = [10 * (names.index(j) - 1) + p for j in chain.joint_names for p in PIN_ORDER]
    except (MinparamError, ValueError):
        return None
    if chain.layout.size != len(cols) or W.shape[1] != len(cols):
        return None
    Wm = W[:, cols]
    res = Wm - Wm[:, list(base.kept)] @ base.K
    return float(np.linalg.norm(res, axis=0).max() / np.linalg.norm(Wm, axis=0).max())


def run_minparam(path: Path, method: str, samples: int, floating_base: bool = False) -> tuple[object, float, str]:
    """(count or refusal text, seconds, weak summary)."""
    t0 = time.perf_counter()
    try:
        rep = derive_file(path, DeriveOptions(method=method, samples=samples, floating_base=floating_base)).to_dict()
    except UnsupportedError as e:
        msg = str(e)
        kind = "mimic" if "mimic" in msg else "floating" if ("floating" in msg or "planar" in msg) else "unsupported"
        return f"refused: {kind}", time.perf_counter() - t0, ""
    except DescriptionError as e:
        msg = str(e).split(": ", 1)[-1]
        kind = "no moving joint" if "no revolute" in msg else f"invalid: {msg}"
        return kind, time.perf_counter() - t0, ""  # the caller moves the message under the table
    except ComputationError as e:
        msg = str(e)
        refused = "use --method qr" in msg
        return ("refused: size" if refused else f"failed: {msg.split(': ', 1)[-1]}"), time.perf_counter() - t0, ""
    except MinparamError as e:  # pragma: no cover - any other error is shown as it is
        return f"error: {e}", time.perf_counter() - t0, ""
    weak = rep.get("weakly_identifiable") or []
    summary = f"{len(weak)} ({min(w['margin'] for w in weak):.1e})" if weak else ""
    return rep["n_base"], time.perf_counter() - t0, summary


def verdict(ref, qr, proj, count: Counter) -> str:
    if isinstance(qr, str):
        if qr.startswith("refused: floating"):
            return "refused: floating"
        if qr == "no moving joint" and ref is None:
            return "no moving joint"
        if qr.startswith("invalid") and ref is None:
            return "invalid file"
        return "differ"
    if qr != ref:
        return "differ"
    if isinstance(proj, int) and proj != ref:
        return "differ"
    if isinstance(proj, str) and proj not in ("refused: size", "refused: mimic", "skipped"):
        return "differ"
    return "agree"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robots", type=Path, action="append", default=None,
                    help="folder of URDFs, repeatable (default: example-robot-data's)")
    ap.add_argument("--samples", type=int, default=100, help="random states, both for the reference and for --method qr")
    ap.add_argument("--no-projection", action="store_true", help="skip --method projection")
    ap.add_argument("--no-floating", action="store_true", help="skip the free-flyer columns")
    ap.add_argument("--markdown", action="store_true", help="GitHub table instead of plain text")
    args = ap.parse_args(argv)
    folders = args.robots or [find_robots()]
    files = [(f, root) for root in folders for f in sorted(root.rglob("*.urdf"))]
    table, verdicts, notes, floating = [], Counter(), [], Counter()
    t_all = time.perf_counter()
    for path, robots in files:
        joints, count = joint_summary(path)
        ref, gap, _ = reference_rank(path, args.samples)
        qr, t_qr, weak = run_minparam(path, "qr", args.samples)
        proj, t_proj = ("skipped", 0.0) if args.no_projection else run_minparam(path, "projection", args.samples)[:2]
        v = verdict(ref, qr, proj, count)
        err = regrouping_error(path, args.samples) if isinstance(qr, int) else None
        if v == "agree" and err is not None and err > REFERENCE_RTOL:
            v = "differ"  # the counts agree but the regrouping does not hold on pinocchio's regressor
        verdicts[v] += 1
        ff_text, ff_qr = "skipped", "skipped"
        if not args.no_floating:
            ff_ref, ff_gap, _ = reference_rank(path, args.samples, free_flyer=True)
            ff_qr = run_minparam(path, "qr", args.samples, floating_base=True)[0]
            ff_text = f"{ff_ref}" if ff_ref is not None else "-"
            fv = "agree" if ff_ref is not None and ff_qr == ff_ref else ("differ" if ff_ref is not None else "-")
            floating[fv] += 1
            ff_qr = f"{ff_qr} ({fv})" if fv != "-" else ff_qr
        name = str(path.relative_to(robots if len(folders) == 1 else robots.parent))
        if isinstance(qr, str) and qr.startswith("invalid: "):
            # gap is pinocchio's error text, or its (kept, dropped) gap when it reads the file
            ref_note = gap if ref is None else f"pinocchio reads it: rank {ref}"
            notes.append(f"{name}: minparam: {qr[len('invalid: '):]}; {ref_note}")
            qr = proj = "invalid (below)"
        ref_text = f"{ref} ({gap[0]:.0e} / {gap[1]:.0e})" if ref is not None else "-"
        regroup = "-" if err is None else f"{err:.0e}"
        table.append((name, joints, ref_text, qr, f"{t_qr:.2f}", proj, f"{t_proj:.2f}", weak, regroup, v, ff_text, ff_qr))
        print(f"{v:18s} {name}", file=sys.stderr, flush=True)
    headers = ["robot", "joints", "reference (kept / dropped gap)", "qr", "qr s", "projection", "proj s", "weak (min margin)", "regrouping", "verdict", "free-flyer ref", "--floating-base"]
    print(tabulate(table, headers=headers, tablefmt="github" if args.markdown else "simple"))
    print()
    for n in notes:
        print(n)
    order = ["agree", "differ", "refused: mimic", "refused: floating", "no moving joint", "invalid file"]
    print(f"{len(files)} URDFs: " + ", ".join(f"{verdicts[k]} {k}" for k in order if verdicts[k] or k in ("agree", "differ")))
    if not args.no_floating:
        print(f"floating base (free-flyer reference vs --floating-base): {floating['agree']} agree, {floating['differ']} differ"
              + (f", {floating['-']} without a reference" if floating["-"] else ""))
    print(f"total time {time.perf_counter() - t_all:.1f} s (reference included)")
    return 0 if verdicts["differ"] == 0 and floating["differ"] == 0 else 1


if __name__ == "__main__":
    raise SystemExit(main())
