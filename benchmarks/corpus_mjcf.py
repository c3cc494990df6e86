"""`minparam derive` over MJCF files, against pinocchio's own MJCF reader (issue 33).

Reference count per model: pinocchio.buildModelFromMJCF (a body with several joints is one
composite joint, a free joint a free-flyer), computeJointTorqueRegressor at random
configurations (neutral configuration integrated by a random velocity), stacked, pivoted QR,
rank = #{|R_kk| > 1e-8 |R_00|}.  minparam: the description with the file's extras left out
(pinocchio's regressor has no armature or friction columns), derive_qr.  pinocchio reads only the
first tree below the world body: a model where it has fewer joints than minparam is listed as
"pinocchio has fewer joints" and not compared.

Run:  pip install ".[bench,mujoco]"
      python benchmarks/corpus_mjcf.py DIR_OR_FILE ...   (e.g. the dm_control package's suite/ folder)
"""

from __future__ import annotations

import argparse
import sys
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
from common import ROOT
from tabulate import tabulate

sys.path.insert(0, str(ROOT / "src"))

from minparam_cli.base.qr import derive_qr  # noqa: E402
from minparam_cli.chain import build_chain  # noqa: E402
from minparam_cli.describe import load_description  # noqa: E402
from minparam_cli.errors import MinparamError, MinparamWarning  # noqa: E402


def pinocchio_rank(model, samples: int, seed: int = 0) -> int:
    import pinocchio as pin
    import scipy.linalg

    data = model.createData()
    rng = np.random.default_rng(seed)
    rows = []
    for _ in range(samples):
        q = pin.integrate(model, pin.neutral(model), rng.uniform(-1.5, 1.5, model.nv))
        rows.append(pin.computeJointTorqueRegressor(model, data, q, rng.standard_normal(model.nv), rng.standard_normal(model.nv)))
    r = np.abs(np.diagonal(scipy.linalg.qr(np.vstack(rows), mode="r", pivoting=True)[0]))
    return int(np.sum(r > 1e-8 * r[0]))


def row(path: Path, samples: int) -> list:
    import pinocchio as pin

    try:
        with warnings.catch_warnings():  # a benchmark script's own process
            warnings.simplefilter("ignore", MinparamWarning)
            desc = load_description(path)
    except MinparamError as e:
        return [path.name, "-", "-", "-", f"minparam: {str(e).split(': ', 1)[-1][:90]}"]
    chain = build_chain(replace(desc, joints=tuple(replace(j, extras=()) for j in desc.joints)))
    ours = derive_qr(chain).n_base
    try:
        model = pin.buildModelFromMJCF(str(path))
    except Exception as e:  # pinocchio raises ValueError/RuntimeError on what it cannot read
        return [path.name, chain.n, ours, "-", f"pinocchio: {str(e).strip().splitlines()[0][:80]}"]
    if model.nv != chain.n:
        return [path.name, chain.n, ours, "-", f"pinocchio has fewer joints ({model.nv})"]
    theirs = pinocchio_rank(model, samples)
    return [path.name, chain.n, ours, theirs, "agree" if ours == theirs else "differ"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("paths", nargs="+", type=Path)
    ap.add_argument("--samples", type=int, default=60)
    args = ap.parse_args(argv)
    files = [f for p in args.paths for f in (sorted(p.glob("*.xml")) if p.is_dir() else [p])]
    rows = [row(f, args.samples) for f in files]
    print(tabulate(rows, headers=["model", "joints", "minparam base", "pinocchio base", "verdict"], tablefmt="github"))
    return 1 if any(r[-1] == "differ" for r in rows) else 0


if __name__ == "__main__":
    raise SystemExit(main())
