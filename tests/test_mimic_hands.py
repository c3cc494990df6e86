"""Hands with many coupled fingers (issue 33 point 4): the rank decision and the regrouping.

tests/data/hands/mimic_hand.urdf: five fingers on one palm, the distal joints mimicking the
proximal ones (multipliers 1, 0.8, 1.13, 1.15, 1.35, offsets, one mimic of a mimic), small
rotations in the origins (1e-4, 2e-5 rad) as in dexmate-urdf's f5d6 hand: a few real effects
sit below the rank cut.  tests/data/hands/tilted_axes_hand.urdf: finger axes written as
normalised floats, tilted by 1e-8..3e-7 rad as in icub-models' left_hand_mk3: XY and YZ of the
first finger's links have an effect of 2e-9..2e-8 of the largest column that the kept columns
carry exactly; they regroup (before the fix they were called "no effect" and the regrouping
missed them by 2e-8).

Independent reference: minparam's per-joint regressor (every joint its own coordinate) at the
coupled states, its rows combined by the coupling Gᵀ read here from the URDF text (virtual
work); and pinocchio's regressor of the same file (its model keeps every joint independent).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from minparam_cli.api.options.derive import DeriveOptions
from minparam_cli.base.qr import chain_scales, derive_qr
from minparam_cli.dynamics.regressor import joint_regressor
from minparam_cli.robot import load_chain

HANDS = Path(__file__).parent / "data" / "hands"
FILES = ["mimic_hand.urdf", "tilted_axes_hand.urdf"]
# pinocchio's parameter order (m, mc, I about the frame origin) for minparam's XX XY XZ YY YZ ZZ MX MY MZ M
PIN_ORDER = [4, 5, 7, 6, 8, 9, 1, 2, 3, 0]


def coupling(path: Path, joints: tuple[str, ...]):
    """G (joints x independent) and offsets from the URDF text, mimics of mimics followed."""
    direct = {}
    for j in ET.parse(path).getroot().iter("joint"):
        el = j.find("mimic")
        if el is not None:
            direct[j.get("name")] = (el.get("joint"), float(el.get("multiplier", 1)), float(el.get("offset", 0)))
    indep = [j for j in joints if j not in direct]
    G, o = np.zeros((len(joints), len(indep))), np.zeros(len(joints))
    for k, name in enumerate(joints):
        master, m, off = name, 1.0, 0.0
        while master in direct:
            nxt, m2, o2 = direct[master]
            master, m, off = nxt, m * m2, m * o2 + off
        G[k, indep.index(master)], o[k] = m, off
    return G, o, indep


def coupled_regressor(chain, G, o, samples=60, seed=5):
    rng = np.random.default_rng(seed)
    q = rng.uniform(-np.pi, np.pi, (samples, G.shape[1]))
    qd, qdd = rng.standard_normal((2, samples, G.shape[1]))
    Yj = joint_regressor(chain, *(np.ascontiguousarray(x) for x in (q @ G.T + o, qd @ G.T, qdd @ G.T)))
    return np.matmul(G.T, Yj).reshape(-1, chain.layout.size)


def regrouping_error(W: np.ndarray, base) -> float:
    """max over columns |W - W_kept K| / largest column: 0 where the regrouping holds."""
    res = W - W[:, list(base.kept)] @ base.K
    return float(np.linalg.norm(res, axis=0).max() / np.linalg.norm(W, axis=0).max())


def load(name):
    return load_chain(HANDS / name, DeriveOptions())[1]


@pytest.mark.parametrize("name", FILES)
def test_count_is_the_rank_of_the_coupled_joint_regressor(name):
    chain = load(name)
    G, _, indep = coupling(HANDS / name, chain.joint_names)
    assert chain.dof == len(indep) and chain.coupling is not None
    W = coupled_regressor(chain, G, _) * chain_scales(chain)[0]  # derive's physical units
    sv = np.linalg.svd(W, compute_uv=False)
    # the cut is 1e-8 of the largest column; the largest singular value is within √P of it
    largest = np.linalg.norm(W, axis=0).max()
    assert derive_qr(chain).n_base == int(np.sum(sv > 1e-8 * largest))


@pytest.mark.parametrize("name", FILES)
def test_the_regrouping_holds_on_the_coupled_joint_regressor(name):
    chain = load(name)
    G, o, _ = coupling(HANDS / name, chain.joint_names)
    base = derive_qr(chain)
    W = coupled_regressor(chain, G, o)
    # mimic_hand keeps real effects below the cut (~1e-9 of the largest column): the regrouping holds
    # to the cut; tilted_axes_hand has none left once its small columns regroup
    bound = {"mimic_hand.urdf": 1e-8, "tilted_axes_hand.urdf": 1e-9}[name]
    assert regrouping_error(W, base) < bound


def test_small_columns_the_kept_ones_carry_regroup_instead_of_having_no_effect():
    chain = load("tilted_axes_hand.urdf")
    base = derive_qr(chain)
    names = list(base.standard_names)
    W = coupled_regressor(chain, *coupling(HANDS / "tilted_axes_hand.urdf", chain.joint_names)[:2])
    size = np.linalg.norm(W, axis=0) / np.linalg.norm(W, axis=0).max()
    for p in ("XY1", "YZ1", "XY2", "YZ2"):
        c = names.index(p)
        assert 1e-10 < size[c] < 1e-7  # small but real (the axes' tilt)
        assert c not in base.unidentifiable
        assert np.count_nonzero(base.K[:, c]) >= 1  # some base parameter carries it
    # link 1 turns about a = (ax, ay, az) (the file's axis, normalised): its torque holds aᵀ I a =
    # ay² (YY + 2 (ax/ay) XY + 2 (az/ay) YZ + ...), so YY1 carries XY1 and YZ1 with these coefficients
    ax, ay, az = (-1.0351589974869193e-08, -0.9999999809599038, 3.3136763531130714e-08)
    row = list(base.kept).index(names.index("YY1"))
    assert base.K[row, names.index("XY1")] == pytest.approx(2 * ax / ay, rel=1e-5)
    assert base.K[row, names.index("YZ1")] == pytest.approx(2 * az / ay, rel=1e-5)
    # what stays without effect has a column at rounding level or one the kept columns do not carry
    for c in base.unidentifiable:
        assert size[c] < 1e-8


@pytest.mark.parametrize("name", FILES)
def test_count_and_regrouping_against_pinocchio(name):
    pin = pytest.importorskip("pinocchio")
    import scipy.linalg

    path = HANDS / name
    chain = load(name)
    base = derive_qr(chain)
    G, o, _ = coupling(path, chain.joint_names)
    model = pin.buildModelFromUrdf(str(path))  # every joint independent: the mimic tags are not applied
    data = model.createData()
    pin_joint = [list(model.names).index(j) for j in chain.joint_names]
    assert all(model.joints[k].nv == 1 and model.joints[k].nq == 1 for k in pin_joint)
    idx = [model.joints[k].idx_v for k in pin_joint]
    cols = [10 * (k - 1) + p for k in pin_joint for p in PIN_ORDER]
    rng = np.random.default_rng(11)
    rows = []
    for _ in range(60):
        qi, vi, ai = rng.uniform(-np.pi, np.pi, G.shape[1]), rng.standard_normal(G.shape[1]), rng.standard_normal(G.shape[1])
        q, v, a = pin.neutral(model), np.zeros(model.nv), np.zeros(model.nv)
        q[idx], v[idx], a[idx] = G @ qi + o, G @ vi, G @ ai
        rows.append(G.T @ pin.computeJointTorqueRegressor(model, data, q, v, a)[idx][:, cols])
    W = np.vstack(rows)
    r = np.abs(np.diagonal(scipy.linalg.qr(W, mode="r", pivoting=True)[0]))
    assert base.n_base == int(np.sum(r > 1e-8 * r[0]))
    bound = {"mimic_hand.urdf": 1e-8, "tilted_axes_hand.urdf": 1e-9}[name]
    assert regrouping_error(W, base) < bound
