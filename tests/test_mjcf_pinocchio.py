"""MJCF base counts against pinocchio (issue 33 point 3): pinocchio's own MJCF reader
(buildModelFromMJCF; bodies with several joints become composite joints, a free joint a free-flyer),
its joint torque regressor at random states, stacked, pivoted QR, rank = #{|R_kk| > 1e-8 |R_00|};
minparam's derive (QR) on the same file.  pinocchio ignores the pose of the first body below the
world, which changes nothing here: the models' first bodies are only translated, or have no gravity."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("mujoco")
pin = pytest.importorskip("pinocchio")

DATA = Path(__file__).parent / "data" / "mjcf"


def _pinocchio_rank(model, samples: int = 60, seed: int = 0) -> int:
    import scipy.linalg

    data = model.createData()
    rng = np.random.default_rng(seed)
    rows = []
    for _ in range(samples):
        q = pin.integrate(model, pin.neutral(model), rng.uniform(-1.5, 1.5, model.nv))
        v, a = rng.standard_normal(model.nv), rng.standard_normal(model.nv)
        rows.append(pin.computeJointTorqueRegressor(model, data, q, v, a))
    R = scipy.linalg.qr(np.vstack(rows), mode="r", pivoting=True)[0]
    r = np.abs(np.diagonal(R))
    return int(np.sum(r > 1e-8 * r[0]))


@pytest.mark.parametrize("name", ["gymnasium_reacher.xml", "gymnasium_pusher.xml", "gymnasium_ant.xml", "gymnasium_humanoid.xml"])
def test_base_count_equals_pinocchio(name):
    """The inertial parameters only: pinocchio's regressor has no armature or friction columns, so the
    chain's extras (from armature, damping, frictionloss) are left out.  pinocchio reads only the
    first tree below the world (reacher's target and pusher's object and goal, bodies on slide
    joints of their own, are not in its model): minparam's description is cut to the joints
    pinocchio has."""
    from dataclasses import replace

    from minparam_cli.base.qr import derive_qr
    from minparam_cli.chain import build_chain
    from minparam_cli.describe import load_description

    path = DATA / name
    model = pin.buildModelFromMJCF(str(path))
    desc = load_description(path)
    names = set(model.names)
    keep = [k for k, j in enumerate(desc.joints) if j.name in names or j.virtual or len(desc.joints) == model.nv]
    new = {old: i for i, old in enumerate(keep)}
    assert all(desc.joints[k].parent in new or desc.joints[k].parent < 0 for k in keep)
    desc = replace(desc, joints=tuple(replace(desc.joints[k], parent=new.get(desc.joints[k].parent, -1), extras=()) for k in keep))
    chain = build_chain(desc)
    assert chain.n == model.nv  # every joint pinocchio has: one each, a composite's as several, the free-flyer as 6
    assert derive_qr(chain).n_base == _pinocchio_rank(model)
