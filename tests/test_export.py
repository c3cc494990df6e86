"""identify --export-urdf / --export-yaml: the exported robots carry the identified bodies.

The exported URDF is read back by this file's own small reader (xml.etree, fixed joints lumped
into the moving body they hang on) and its torques computed by tests/reference_dynamics.py
(Euler-Lagrange, nothing of the package), and by pinocchio's RNEA where pinocchio is installed.
They must equal the chain's regressor · φ at random states to 1e-9.
"""

from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET
from types import SimpleNamespace

import numpy as np
import pytest
import reference_dynamics
from conftest import ROOT
from typer.testing import CliRunner

from minparam_cli.cli.app import app
from minparam_cli.dynamics.regressor import regressor
from minparam_cli.dynamics.inertia import random_inertia
from minparam_cli.robot import DeriveOptions, load_chain
from minparam_cli.model import export_robot, export_urdf

TINY_URDF = """<?xml version="1.0"?>
<robot name="tiny">
  <link name="world"/>
  <joint name="fix0" type="fixed"><parent link="world"/><child link="base"/><origin xyz="0.1 0 0.2" rpy="0 0 0.3"/></joint>
  <link name="base"><inertial><mass value="3"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
  <joint name="a" type="revolute"><parent link="base"/><child link="l1"/><origin xyz="0 0.05 0.3" rpy="0.2 -0.4 0.1"/>
    <axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
  <link name="l1">
    <inertial><mass value="2"/><origin xyz="0.1 0 0.05" rpy="0.3 0.2 0.1"/>
      <inertia ixx="0.02" ixy="0.001" ixz="0" iyy="0.03" iyz="0" izz="0.025"/></inertial>
  </link>
  <joint name="f1" type="fixed"><parent link="l1"/><child link="cover"/><origin xyz="0.2 0 0" rpy="1.5707963 0 0"/></joint>
  <link name="cover"><inertial><mass value="0.5"/><origin xyz="0 0.01 0"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.001"/></inertial></link>
  <joint name="b" type="prismatic"><parent link="cover"/><child link="l2"/><origin xyz="0 0.1 0.2" rpy="0 0.5 0"/>
    <axis xyz="1 0 0"/><limit lower="0" upper="0.5" effort="1" velocity="1"/></joint>
  <link name="l2"/>
  <joint name="c" type="continuous"><parent link="l2"/><child link="l3"/><origin xyz="0.3 0 0" rpy="0 0 0"/>
    <axis xyz="0 0.6 0.8"/></joint>
  <link name="l3"><inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>
  <joint name="tool" type="fixed"><parent link="l3"/><child link="tip"/><origin xyz="0 0 0.1"/></joint>
  <link name="tip"><inertial><mass value="0.2"/><inertia ixx="0.0001" ixy="0" ixz="0" iyy="0.0001" iyz="0" izz="0.0001"/></inertial></link>
</robot>
"""


# --- an independent URDF reader: plain xml.etree, 4x4 products, fixed joints lumped ------------------


def _floats(text, default):
    return [float(x) for x in (text if text is not None else default).split()]


def _rpy(r, p, y):
    Rx = np.array([[1, 0, 0], [0, math.cos(r), -math.sin(r)], [0, math.sin(r), math.cos(r)]])
    Ry = np.array([[math.cos(p), 0, math.sin(p)], [0, 1, 0], [-math.sin(p), 0, math.cos(p)]])
    Rz = np.array([[math.cos(y), -math.sin(y), 0], [math.sin(y), math.cos(y), 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


def _origin(el):
    T = np.eye(4)
    o = el.find("origin") if el is not None else None
    if o is not None:
        T[:3, :3] = _rpy(*_floats(o.get("rpy"), "0 0 0"))
        T[:3, 3] = _floats(o.get("xyz"), "0 0 0")
    return T


def _link_params(inertial, X):
    """Standard parameters about the origin of the body frame, in its axes, of a URDF <inertial> whose
    link frame is X in the body frame."""
    if inertial is None:
        return np.zeros(10)
    m = float(inertial.find("mass").get("value"))
    a = {k: float(inertial.find("inertia").get(k)) for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
    Ic = np.array([[a["ixx"], a["ixy"], a["ixz"]], [a["ixy"], a["iyy"], a["iyz"]], [a["ixz"], a["iyz"], a["izz"]]])
    To = X @ _origin(inertial)
    R, c = To[:3, :3], To[:3, 3]
    I = R @ Ic @ R.T + m * (c @ c * np.eye(3) - np.outer(c, c))
    return np.array([I[0, 0], I[0, 1], I[0, 2], I[1, 1], I[1, 2], I[2, 2], *(m * c), m])


def read_urdf(text: str):
    """(chain-like record for reference_dynamics, φ, joint names, inertias about each CoM) of a URDF."""
    root = ET.fromstring(text)
    links = {el.get("name"): el for el in root.findall("link")}
    joints = root.findall("joint")
    children = {}
    for j in joints:
        children.setdefault(j.find("parent").get("link"), []).append(j)
    child_links = {j.find("child").get("link") for j in joints}
    (base,) = [k for k in links if k not in child_links]
    pre, axes, types, parents, names, phi = [], [], [], [], [], []
    inertias = [links[k].find("inertial") for k in links]

    def walk(link, body, X):
        if body >= 0:
            phi[body] = phi[body] + _link_params(links[link].find("inertial"), X)
        for j in children.get(link, []):
            child = j.find("child").get("link")
            if j.get("type") == "fixed":
                walk(child, body, X @ _origin(j))
                continue
            pre.append(X @ _origin(j))
            ax = np.array(_floats(j.find("axis").get("xyz") if j.find("axis") is not None else None, "1 0 0"))
            axes.append(ax / np.linalg.norm(ax))
            types.append("prismatic" if j.get("type") == "prismatic" else "revolute")
            parents.append(body)
            names.append(j.get("name"))
            phi.append(np.zeros(10))
            walk(child, len(pre) - 1, np.eye(4))

    walk(base, -1, np.eye(4))
    n = len(pre)
    chain = SimpleNamespace(n=n, pre=np.array(pre), axes=np.array(axes), post=np.array([np.eye(4)] * n),
                            types=tuple(types), parents=tuple(parents), gravity=np.array([0.0, 0.0, -9.81]))
    com_inertias = []
    for el in inertias:
        if el is not None:
            a = {k: float(el.find("inertia").get(k)) for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
            com_inertias.append(np.array([[a["ixx"], a["ixy"], a["ixz"]], [a["ixy"], a["iyy"], a["iyz"]], [a["ixz"], a["iyz"], a["izz"]]]))
    return chain, np.concatenate(phi), names, com_inertias


def states(chain, rng, count=4):
    n = chain.n
    return [(rng.uniform(-1.5, 1.5, n), rng.uniform(-2, 2, n), rng.uniform(-3, 3, n)) for _ in range(count)]


def model_torque(chain, phi, q, dq, ddq) -> np.ndarray:
    """regressor · φ of the chain (the rigid-body part: φ's inertial parameters)."""
    Y = regressor(chain, q[None], dq[None], ddq[None], include_extras=False)[0]
    return Y @ phi[: Y.shape[1]]


def assert_urdf_reproduces(text: str, chain, phi, seed=0):
    """The exported URDF's torques (reference Euler-Lagrange; pinocchio's RNEA if installed) equal
    regressor · φ to 1e-9 relative at random states."""
    ref_chain, ref_phi, names, _ = read_urdf(text)
    assert list(names) == list(chain.joint_names)
    pin = None
    try:
        import pinocchio

        pin = pinocchio.buildModelFromXML(_urdfdom_limits(text))
        pin_data = pin.createData()
    except ImportError:
        pass
    for q, dq, ddq in states(chain, np.random.default_rng(seed)):
        expected = model_torque(chain, phi, q, dq, ddq)
        scale = np.linalg.norm(expected)
        got = reference_dynamics.inverse_dynamics(ref_chain, ref_phi, q, dq, ddq)
        assert np.linalg.norm(got - expected) <= 1e-9 * scale, (got, expected)
        if pin is not None:
            tau = pinocchio.rnea(pin, pin_data, _pin_q(pin, q), dq, ddq)
            assert np.linalg.norm(tau - expected) <= 1e-9 * scale, (tau, expected)


def _urdfdom_limits(text: str) -> str:
    """pinocchio reads URDF with urdfdom, which refuses a <limit> without effort and velocity and a revolute
    or prismatic joint without <limit>; the export writes only the limits the description gave (docs/simulation.md).
    For this check (dynamics only), such elements get placeholder values in the copy pinocchio reads."""
    root = ET.fromstring(text)
    for j in root.findall("joint"):
        if j.get("type") not in ("revolute", "prismatic"):
            continue
        limit = j.find("limit")
        if limit is None:
            limit = ET.SubElement(j, "limit", {"lower": "-1e9", "upper": "1e9"})
        for key in ("effort", "velocity"):
            limit.set(key, limit.get(key) or "1")
    return ET.tostring(root, encoding="unicode")


def _pin_q(model, q):
    """pinocchio's configuration: a continuous joint is (cos q, sin q)."""
    out = []
    for joint, qj in zip(list(model.joints)[1:], q, strict=True):
        out += [math.cos(qj), math.sin(qj)] if joint.nq == 2 else [qj]
    return np.array(out)


def assert_triangle(text: str):
    """Every <inertial> of the file is a body: principal moments ≥ 0 and a + b ≥ c."""
    _, _, _, inertias = read_urdf(text)
    assert inertias
    for Ic in inertias:
        a, b, c = np.linalg.eigvalsh(Ic)
        tol = 1e-12 * (a + b + c)
        assert a >= -tol and a + b >= c - tol, (a, b, c)


def random_phi(chain, seed):
    return random_inertia(chain.n, chain.length_scale, np.random.default_rng(seed)).phi


# --- the exporters on random bodies (no solver needed) ----------------------------------------------


@pytest.mark.parametrize("robot", ["puma560.yaml", "puma560_mdh.yaml", "stanford.yaml", "scara.yaml", "ur5.yaml"])
def test_urdf_from_a_dh_table_moves_each_body_into_its_urdf_frame(robot):
    """Standard DH puts link j's frame at the end of the link (after Post_j); MDH at the joint.
    Prismatic joints (Stanford's third, SCARA's) included."""
    _, chain = load_chain(ROOT / "robots" / robot, DeriveOptions())
    phi = random_phi(chain, 1)
    text = export_urdf.urdf_from_chain(chain, phi, "test")
    assert_urdf_reproduces(text, chain, phi)
    assert_triangle(text)


def test_standard_dh_frames_are_at_the_end_of_the_link():
    """PUMA DH link 2 (a2 = 431.8 mm along x2): a mass at the chain frame's origin sits 0.4318 m out
    along the URDF link's x axis (the joint frame), and 0.15 m along z (d2)."""
    _, chain = load_chain(ROOT / "robots" / "puma560.yaml", DeriveOptions())
    phi = np.zeros(10 * chain.n)
    phi[9::10] = 1.0  # unit point masses at each chain frame's origin
    root = ET.fromstring(export_urdf.urdf_from_chain(chain, phi))
    com = [float(x) for x in root.find("link[@name='link2']/inertial/origin").get("xyz").split()]
    assert np.allclose(com, [0.4318, 0.0, 0.15], atol=1e-15)


@pytest.mark.parametrize("robot", ["ur5.urdf", "iiwa14.urdf", "tiny"])
def test_urdf_robot_keeps_its_file_with_the_inertials_replaced(robot, tmp_path):
    if robot == "tiny":
        path = tmp_path / "tiny.urdf"
        path.write_text(TINY_URDF)
    else:
        path = ROOT / "robots" / robot
    _, chain = load_chain(path, DeriveOptions())
    phi = random_phi(chain, 2)
    data = path.read_bytes()
    text = export_urdf.urdf_with_inertials(data, chain, phi, "test")
    assert_urdf_reproduces(text, chain, phi)
    assert_triangle(text)
    # every joint and every link of the original is still there, unchanged but for the inertials
    old, new = ET.fromstring(data), ET.fromstring(text)
    assert [ET.tostring(j) for j in old.findall("joint")] == [ET.tostring(j) for j in new.findall("joint")]
    assert [link.get("name") for link in old.findall("link")] == [link.get("name") for link in new.findall("link")]
    # and it loads back through minparam's own reader with the same φ
    back = tmp_path / "back.urdf"
    back.write_text(text)
    _, chain2 = load_chain(back, DeriveOptions())
    assert np.allclose(chain2.phi_nominal, phi, rtol=0, atol=1e-12 * np.abs(phi).max())


def test_fixed_links_lose_their_mass_to_the_identified_body(tmp_path):
    """tiny.urdf: 'cover' hangs on l1 by a fixed joint, 'tip' on l3: their <inertial> go (the identified
    body already holds them), the root link's stays."""
    path = tmp_path / "tiny.urdf"
    path.write_text(TINY_URDF)
    _, chain = load_chain(path, DeriveOptions())
    new = ET.fromstring(export_urdf.urdf_with_inertials(path.read_bytes(), chain, random_phi(chain, 3)))
    has = {link.get("name"): link.find("inertial") is not None for link in new.findall("link")}
    assert has == {"world": False, "base": True, "l1": True, "cover": False, "l2": True, "l3": True, "tip": False}


def test_yaml_export_loads_back_with_the_same_torques(tmp_path):
    for robot in ("puma560.yaml", "puma560_mdh.yaml", "stanford.yaml"):
        from minparam_cli.safety import read_yaml

        path = ROOT / "robots" / robot
        _, chain = load_chain(path, DeriveOptions())
        phi = random_phi(chain, 4)
        out = tmp_path / robot
        out.write_text(export_robot.yaml_with_inertials(read_yaml(path), chain, phi, "test"))
        _, chain2 = load_chain(out, DeriveOptions())
        for q, dq, ddq in states(chain, np.random.default_rng(5)):
            expected = model_torque(chain, phi, q, dq, ddq)
            got = model_torque(chain2, chain2.phi_nominal, q, dq, ddq)
            assert np.linalg.norm(got - expected) <= 1e-9 * np.linalg.norm(expected)


def test_standard_in_frame_is_the_parallel_axis_rule():
    rng = np.random.default_rng(7)
    phi = random_inertia(1, 0.5, rng).phi
    T = np.eye(4)
    T[:3, :3] = _rpy(0.3, -1.1, 2.0)
    T[:3, 3] = [0.2, -0.1, 0.4]
    back = np.linalg.inv(T)
    assert np.allclose(export_robot.standard_in_frame(export_robot.standard_in_frame(phi, T), back), phi, atol=1e-14)
    m, c, Ic = export_robot.body(phi)
    m2, c2, Ic2 = export_robot.body(export_robot.standard_in_frame(phi, T))
    assert m2 == m and np.allclose(c2, T[:3, :3] @ c + T[:3, 3]) and np.allclose(Ic2, T[:3, :3] @ Ic @ T[:3, :3].T)


def test_rpy_round_trip_including_gimbal_lock():
    for r, p, y in [(0.3, -1.1, 2.0), (0.0, math.pi / 2, 0.7), (1.0, -math.pi / 2, -0.2), (math.pi, 0.0, -math.pi / 2)]:
        R = _rpy(r, p, y)
        assert np.allclose(_rpy(*export_robot.rpy_from_matrix(R)), R, atol=1e-14)


# --- the command: the physical fit's bodies ----------------------------------------------------------


def test_identify_exports_the_physical_fit(tmp_path):
    """identify --physical on simulated PUMA (standard DH, mm) data: the URDF and YAML it writes
    reproduce regressor · φ of the physical fit, and every exported inertia is a body."""
    pytest.importorskip("cvxpy")
    robot = ROOT / "robots" / "puma560.yaml"
    data, model, urdf, yml = (tmp_path / x for x in ("d.csv", "m.json", "p.urdf", "p.yaml"))
    r = CliRunner().invoke(app, ["simulate", str(robot), "--random-inertia", "--noise", "0.01", "--seed", "4", "-o", str(data), "-q"])
    assert r.exit_code == 0, r.output
    # the description has no inertials: a mass bound lets the links' DH ellipsoids hold what the data leave free
    r = CliRunner().invoke(app, ["identify", str(robot), str(data), "--physical", "--no-diagnose", "--mass-bounds", "0,100", "-q", "--save-model", str(model),
                                 "--export-urdf", str(urdf), "--export-yaml", str(yml)])
    assert r.exit_code == 0, r.output
    phi = np.array(json.loads(model.read_text())["physical"]["phi"])
    _, chain = load_chain(robot, DeriveOptions())
    assert_urdf_reproduces(urdf.read_text(), chain, phi)
    assert_triangle(urdf.read_text())
    _, chain2 = load_chain(yml, DeriveOptions())
    for q, dq, ddq in states(chain, np.random.default_rng(6)):
        expected = model_torque(chain, phi, q, dq, ddq)
        assert np.linalg.norm(model_torque(chain2, chain2.phi_nominal, q, dq, ddq) - expected) <= 1e-9 * np.linalg.norm(expected)
