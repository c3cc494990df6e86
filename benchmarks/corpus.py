"""`minparam derive` over every URDF of example-robot-data, against pinocchio.

Reference count per robot: pinocchio's computeJointTorqueRegressor of the
fixed-base model (buildModelFromUrdf, no free-flyer) at random states, stacked,
then pivoted QR (scipy.linalg.qr, pivoting=True); rank = #{|R_kk| > 1e-8 |R_00|}.
The table also prints the reference's gap (smallest kept and largest dropped
|R_kk| / |R_00|), so a reader sees how clean each reference decision is.

minparam: ``derive_file`` with --method qr and --method projection, each timed
in this process (the first robot also pays the imports).  Verdicts:

* agree: QR equals the reference, and projection too or projection refused
  by its size guard (then the projection column says why);
* differ: a count differs from the reference;
* refused: mimic / floating: not supported yet (mimic joints, a floating root);
* no moving joint: the file has no revolute, continuous or prismatic joint
  (pinocchio's model has nv = 0 too);
* invalid file: minparam refuses it with a description error (the message
  is shown) and pinocchio cannot build it either.

Run:  pip install ".[bench]"   (pin, example-robot-data)
      python benchmarks/corpus.py [--robots DIR] [--samples 100] [--markdown]
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
from minparam_cli.pipeline import DeriveOptions, derive_file  # noqa: E402

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


def reference_rank(path: Path, samples: int, seed: int = 0):
    """(rank, (kept gap, dropped gap), nv) from pinocchio, or (None, error text, 0)."""
    import pinocchio as pin
    import scipy.linalg

    try:
        model = pin.buildModelFromUrdf(str(path))
    except Exception as e:  # pinocchio raises ValueError/RuntimeError on malformed files
        return None, "pinocchio: " + str(e).strip().splitlines()[0].replace(str(path), path.name), 0
    if model.nv == 0:
        return None, "nv = 0", 0
    data = model.createData()
    rng = np.random.default_rng(seed)
    rows = []
    for _ in range(samples):
        q = pin.neutral(model)
        for joint in model.joints[1:]:
            if joint.nq == 2 and joint.nv == 1:  # continuous: (cos, sin)
                a = rng.uniform(-np.pi, np.pi)
                q[joint.idx_q : joint.idx_q + 2] = np.cos(a), np.sin(a)
            else:
                q[joint.idx_q : joint.idx_q + joint.nq] = rng.uniform(-np.pi, np.pi, joint.nq)
        v, a = rng.standard_normal(model.nv), rng.standard_normal(model.nv)
        rows.append(pin.computeJointTorqueRegressor(model, data, q, v, a).copy())
    R = scipy.linalg.qr(np.vstack(rows), mode="r", pivoting=True)[0]
    r = np.abs(np.diagonal(R))
    rank = int(np.sum(r > REFERENCE_RTOL * r[0]))
    return rank, (r[rank - 1] / r[0], r[rank] / r[0] if rank < len(r) else 0.0), model.nv


def run_minparam(path: Path, method: str, samples: int) -> tuple[object, float, str]:
    """(count or refusal text, seconds, weak summary)."""
    t0 = time.perf_counter()
    try:
        rep = derive_file(path, DeriveOptions(method=method, samples=samples))
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
        if qr.startswith("refused: mimic") or (count["mimic"] and ref is not None and qr.startswith("refused")):
            return "refused: mimic"
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
    if isinstance(proj, str) and proj != "refused: size":
        return "differ"
    return "agree"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robots", type=Path, default=None, help="folder of URDFs (default: example-robot-data's)")
    ap.add_argument("--samples", type=int, default=100, help="random states, both for the reference and for --method qr")
    ap.add_argument("--no-projection", action="store_true", help="skip --method projection")
    ap.add_argument("--markdown", action="store_true", help="GitHub table instead of plain text")
    args = ap.parse_args(argv)
    robots = args.robots or find_robots()
    files = sorted(robots.rglob("*.urdf"))
    table, verdicts, notes = [], Counter(), []
    t_all = time.perf_counter()
    for path in files:
        joints, count = joint_summary(path)
        ref, gap, _ = reference_rank(path, args.samples)
        qr, t_qr, weak = run_minparam(path, "qr", args.samples)
        proj, t_proj = ("skipped", 0.0) if args.no_projection else run_minparam(path, "projection", args.samples)[:2]
        v = verdict(ref, qr, proj, count)
        verdicts[v] += 1
        name = str(path.relative_to(robots))
        if isinstance(qr, str) and qr.startswith("invalid: "):
            notes.append(f"{name}: minparam: {qr[len('invalid: '):]}; {gap}")
            qr = proj = "invalid (below)"
        ref_text = f"{ref} ({gap[0]:.0e} / {gap[1]:.0e})" if ref is not None else "-"
        table.append((name, joints, ref_text, qr, f"{t_qr:.2f}", proj, f"{t_proj:.2f}", weak, v))
        print(f"{v:18s} {path.relative_to(robots)}", file=sys.stderr, flush=True)
    headers = ["robot", "joints", "reference (kept / dropped gap)", "qr", "qr s", "projection", "proj s", "weak (min margin)", "verdict"]
    print(tabulate(table, headers=headers, tablefmt="github" if args.markdown else "simple"))
    print()
    for n in notes:
        print(n)
    order = ["agree", "differ", "refused: mimic", "refused: floating", "no moving joint", "invalid file"]
    print(f"{len(files)} URDFs: " + ", ".join(f"{verdicts[k]} {k}" for k in order if verdicts[k] or k in ("agree", "differ")))
    print(f"total time {time.perf_counter() - t_all:.1f} s (reference included)")
    return 0 if verdicts["differ"] == 0 else 1


if __name__ == "__main__":
    raise SystemExit(main())
