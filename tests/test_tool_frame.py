"""The URDF tool point (issue 15, point 6): the fixed link farthest out on the last moving link is
the default tool of ``singular``, ``--tool LINK`` picks any link rigidly attached to a moving link,
bad names are one line and exit 2; checked against a hand computation."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from typer.testing import CliRunner

runner = CliRunner()

# world -(fixed)- base -j1(z)- link1 -j2(y)- link2 -j3(y)- link3;  link3 carries flange (0.1 m
# beyond joint 3 along x), sensor (0.02 m along y, nearer) and, through the flange (turned 90°
# about y), tip (0.05 m along the flange's -z = link3's -x: 0.05 m along x in link3);
# link2 carries camera.
ARM = """<?xml version="1.0"?>
<robot name="arm3">
  <link name="world"/>
  <link name="base"/>
  <joint name="world_joint" type="fixed"><parent link="world"/><child link="base"/></joint>
  <link name="link1"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="link1"/>
    <origin xyz="0 0 0.2"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <link name="link2"/>
  <joint name="j2" type="revolute"><parent link="link1"/><child link="link2"/>
    <origin xyz="0 0 0.3"/><axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <link name="camera"/>
  <joint name="camera_joint" type="fixed"><parent link="link2"/><child link="camera"/>
    <origin xyz="0.2 0.05 0" rpy="0 0 0.3"/></joint>
  <link name="link3"/>
  <joint name="j3" type="revolute"><parent link="link2"/><child link="link3"/>
    <origin xyz="0.4 0 0"/><axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <link name="flange"/>
  <joint name="flange_joint" type="fixed"><parent link="link3"/><child link="flange"/>
    <origin xyz="0.1 0 0" rpy="0 1.5707963267948966 0"/></joint>
  <link name="tip"/>
  <joint name="tip_joint" type="fixed"><parent link="flange"/><child link="tip"/>
    <origin xyz="0 0 -0.05"/></joint>
  <link name="sensor"/>
  <joint name="sensor_joint" type="fixed"><parent link="link3"/><child link="sensor"/>
    <origin xyz="0 0.02 0"/></joint>
</robot>
"""

# a tree: link1 carries two branches, each with a fixed gripper
TREE = """<?xml version="1.0"?>
<robot name="twoarms">
  <link name="base"/>
  <link name="link1"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="link1"/>
    <origin xyz="0 0 0.2"/><axis xyz="0 0 1"/></joint>
  <link name="a2"/>
  <joint name="ja" type="revolute"><parent link="link1"/><child link="a2"/>
    <origin xyz="0 0.1 0"/><axis xyz="1 0 0"/></joint>
  <link name="gripper_a"/>
  <joint name="ga" type="fixed"><parent link="a2"/><child link="gripper_a"/><origin xyz="0 0.3 0"/></joint>
  <link name="b2"/>
  <joint name="jb" type="revolute"><parent link="link1"/><child link="b2"/>
    <origin xyz="0 -0.1 0"/><axis xyz="1 0 0"/></joint>
  <link name="gripper_b"/>
  <joint name="gb" type="fixed"><parent link="b2"/><child link="gripper_b"/><origin xyz="0 -0.3 0"/></joint>
</robot>
"""


@pytest.fixture(scope="module")
def app():
    from minparam_cli.cli.app import app as real_app

    return real_app


@pytest.fixture()
def arm(tmp_path):
    p = tmp_path / "arm3.urdf"
    p.write_text(ARM)
    return str(p)


def _rz(t):
    c, s = math.cos(t), math.sin(t)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])


def _ry(t):
    c, s = math.cos(t), math.sin(t)
    return np.array([[c, 0, s], [0, 1.0, 0], [-s, 0, c]])


def _hand_frames(q):
    """(R, p) of link1, link2, link3 in the base frame, by hand."""
    R1, p1 = _rz(q[0]), np.array([0, 0, 0.2])
    R2, p2 = R1 @ _ry(q[1]), p1 + R1 @ [0, 0, 0.3]
    R3, p3 = R2 @ _ry(q[2]), p2 + R2 @ [0.4, 0, 0]
    return (R1, p1), (R2, p2), (R3, p3)


def _singular_json(app, *args):
    r = runner.invoke(app, ["singular", *args, "--format", "json"])
    assert r.exit_code == 0, r.output
    return json.loads(r.stdout)


Q_DEG = (30.0, 45.0, -60.0)
Q = np.radians(Q_DEG)
QD = np.array([0.3, -0.7, 1.1])


def test_loader_default_tool_is_the_farthest_fixed_link(arm):
    from pathlib import Path

    from minparam_cli.describe.urdf import load_urdf

    desc = load_urdf(Path(arm))
    assert desc.tool_link == "flange"
    assert np.allclose(desc.tool, (0.1, 0, 0))
    names = [name for name, _, _ in desc.tool_links]
    assert set(names) == {"link1", "link2", "camera", "link3", "flange", "tip", "sensor"}
    tip = {name: (body, xyz) for name, body, xyz in desc.tool_links}["tip"]
    assert tip[0] == 2 and np.allclose(tip[1], (0.05, 0, 0), atol=1e-12)


def test_flange_is_the_default_tool_point_and_its_velocity_matches_a_hand_computation(app, arm):
    doc = _singular_json(app, arm, "--q", ",".join(map(str, Q_DEG)))
    assert doc["tool"]["link"] == "flange" and doc["tool"]["frame"] == "link3"
    assert np.allclose(doc["tool"]["point"], (0.1, 0, 0))
    (R1, p1), (R2, p2), (R3, p3) = _hand_frames(Q)
    c = p3 + R3 @ [0.1, 0, 0]
    assert np.allclose(doc["tool_point"], c, atol=1e-12)
    # tool twist from the screw matrix (moments about the base origin) moved to O_c ...
    P = np.array(doc["plucker_matrix"])
    w = P[:3] @ QD
    v = P[3:] @ QD + np.cross(w, c)
    # ... equals the hand sum of z_i × (c - o_i) q̇_i
    axes = [(R1 @ [0, 0, 1], p1), (R2 @ [0, 1, 0], p2), (R3 @ [0, 1, 0], p3)]
    v_hand = sum(qd * np.cross(z, c - o) for qd, (z, o) in zip(QD, axes, strict=True))
    w_hand = sum(qd * z for qd, (z, _) in zip(QD, axes, strict=True))
    assert np.allclose(w, w_hand, atol=1e-12) and np.allclose(v, v_hand, atol=1e-12)


def test_table_says_which_tool_point(app, arm):
    r = runner.invoke(app, ["singular", arm, "--q", "30,45,-60"])
    assert r.exit_code == 0, r.output
    assert "tool       link flange: (0.1, 0, 0) m in the link3 frame" in r.stdout


@pytest.mark.parametrize(("link", "local"), [("sensor", (0, 0.02, 0)), ("tip", (0.05, 0, 0)), ("link3", (0, 0, 0))])
def test_tool_option_picks_another_link_on_the_last_body(app, arm, link, local):
    doc = _singular_json(app, arm, "--q", "30,45,-60", "--tool", link)
    assert doc["tool"]["link"] == link and doc["tool"]["frame"] == "link3"
    _, _, (R3, p3) = _hand_frames(Q)
    assert np.allclose(doc["tool_point"], p3 + R3 @ np.array(local, float), atol=1e-12)


def test_tool_on_an_earlier_body_cuts_the_chain_there(app, arm):
    doc = _singular_json(app, arm, "--q", "30,45", "--tool", "camera")
    assert doc["joint_names"] == ["j1", "j2"]
    assert doc["tool"]["frame"] == "link2"
    _, (R2, p2), _ = _hand_frames(np.append(Q[:2], 0.0))
    assert np.allclose(doc["tool_point"], p2 + R2 @ [0.2, 0.05, 0], atol=1e-12)


@pytest.mark.parametrize("bad", ["nope", "world", "base", ""])
def test_bad_tool_names_are_one_line_exit_2(app, arm, bad):
    r = runner.invoke(app, ["singular", arm, "--q", "30,45,-60", "--tool", bad])
    assert r.exit_code == 2
    lines = [ln for ln in r.output.splitlines() if ln.strip()]
    assert len(lines) == 1, r.output
    assert "allowed: link1, link2, camera, link3, flange, tip, sensor" in lines[0]


def test_tool_on_a_yaml_file_is_one_line_exit_2(app):
    r = runner.invoke(app, ["singular", "robots/ur5.yaml", "--q", "10,-30,40,20,30,15", "--tool", "ee_link"])
    assert r.exit_code == 2
    assert len([ln for ln in r.output.splitlines() if ln.strip()]) == 1
    assert "'tool' entry" in r.output


def test_tree_branch_is_chosen_by_tool(app, tmp_path):
    p = tmp_path / "tree.urdf"
    p.write_text(TREE)
    from minparam_cli.describe.urdf import load_urdf

    desc = load_urdf(p)
    assert desc.tool_link == "gripper_b"  # the last joint in depth-first order is jb
    r = runner.invoke(app, ["singular", str(p), "--q", "0,0"])
    assert r.exit_code != 0  # a tree without --tool: singular needs a serial chain
    doc = _singular_json(app, str(p), "--q", "90,0", "--tool", "gripper_a")
    assert doc["joint_names"] == ["j1", "ja"]
    assert np.allclose(doc["tool_point"], (-0.4, 0, 0.2), atol=1e-12)


def test_shipped_ur5_urdf_uses_ee_link(app):
    q = "10,-30,40,20,30,15"
    doc = _singular_json(app, "robots/ur5.urdf", "--q", q)
    assert doc["tool"]["link"] == "ee_link" and doc["tool"]["frame"] == "wrist_3_link"
    assert np.allclose(doc["tool"]["point"], (0, 0.0823, 0))
    w3 = _singular_json(app, "robots/ur5.urdf", "--q", q, "--tool", "wrist_3_link")
    assert np.linalg.norm(np.array(doc["tool_point"]) - w3["tool_point"]) == pytest.approx(0.0823, abs=1e-12)


def test_shipped_iiwa14_urdf_uses_its_tool_link(app):
    doc = _singular_json(app, "robots/iiwa14.urdf", "--q", "10,-30,40,20,30,15,5")
    # iiwa_link_ee_kuka and iiwa_link_ee sit at the same point; the one written last wins the tie
    assert doc["tool"]["link"] == "iiwa_link_ee"
    assert np.allclose(doc["tool"]["point"], (0, 0, 0.045))
