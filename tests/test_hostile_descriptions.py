"""Broken closed-chain descriptions found by an adversarial sweep of the robot readers: one test per kind,
each a one-line refusal (exit 2), before the long computation they would start."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml
from typer.testing import CliRunner

from minparam_cli.cli.app import app
from minparam_cli.describe import load_description
from minparam_cli.errors import DescriptionError

FOURBAR = Path(__file__).resolve().parents[1] / "robots" / "fourbar_hybroblib.yaml"


def _fourbar(tmp_path, change) -> Path:
    doc = yaml.safe_load(FOURBAR.read_text())
    change(doc)
    p = tmp_path / "fourbar.yaml"
    p.write_text(yaml.safe_dump(doc, sort_keys=False))
    return p


def test_more_loop_cuts_than_joints_is_refused_at_once(tmp_path):
    """1000 copies of the four-bar's one cut: derive took 48 s and codegen over a minute before the refusal."""
    p = _fourbar(tmp_path, lambda d: d.__setitem__("loops", [{**d["loops"][0], "name": f"c{i}"} for i in range(1000)]))
    r = CliRunner().invoke(app, ["derive", str(p)])
    assert r.exit_code == 2 and len(r.stderr.strip().splitlines()) == 1, r.output
    assert "loops: 1000 loop-closing cuts for 3 joints: at most one cut per joint" in r.stderr


def test_loop_cut_name_used_twice(tmp_path):
    p = _fourbar(tmp_path, lambda d: d["loops"].append(dict(d["loops"][0])))
    with pytest.raises(DescriptionError, match=r"loops\[2\]\.name: cut name 'coupler-rocker' is used twice"):
        load_description(p)


def test_one_symbol_for_two_different_values_is_refused(tmp_path):
    """The symbol table is keyed by name: 'L' on a1 = 1 and a2 = 2 printed 'L = 2' for both, and a chosen
    'd2' on a1 lost a1 to joint 2's d (now the loader's d2 takes a suffix).  The same symbol on equal values
    stays one shared quantity."""
    joint = "  - {{type: revolute, alpha: 0, a: {a}, d: {d}, theta: 0}}\n"
    head = "convention: dh\njoints:\n"
    bad = tmp_path / "bad.yaml"
    bad.write_text(head + joint.format(a="{symbol: L, value: 1.0}", d=0) + joint.format(a="{symbol: L, value: 2.0}", d=0))
    with pytest.raises(DescriptionError, match=r"joints\[2\]\.a: symbol 'L' names two different values: joints\[1\]\.a = 1 and joints\[2\]\.a = 2"):
        load_description(bad)
    auto = tmp_path / "auto.yaml"  # the file's d2 wins; the loader's own d2 (joint 2's d) takes a suffix
    auto.write_text(head + joint.format(a="{symbol: d2, value: 1.0}", d=0) + joint.format(a=0.5, d=0.3))
    geometry = load_description(auto).geometry()
    assert geometry["d2"].value == 1.0 and geometry["d2_2"].value == 0.3
    craig = tmp_path / "craig.yaml"  # Craig's MDH numbering: a2 on row 3, the loader's a2 (0) on row 2
    craig.write_text("convention: mdh\njoints:\n" + joint.format(a=0, d=0) + joint.format(a=0, d=0.2)
                     + joint.format(a="{symbol: a2, value: 0.4318}", d=0))
    desc = load_description(craig)
    assert desc.geometry()["a2"].value == 0.4318 and desc.joints[1].dh["a"].symbol == "a2_2"
    shared = tmp_path / "shared.yaml"
    shared.write_text(head + joint.format(a="{symbol: L, value: 1.0}", d=0) + joint.format(a="{symbol: L, value: 1.0}", d=0))
    assert load_description(shared).geometry()["L"].value == 1.0


def test_urdf_joint_names_that_map_to_one_symbol_get_distinct_symbols(tmp_path):
    """Joints 'a-b' and 'a_b' both gave the symbols a_b_x, a_b_z: the first joint's origin was lost from the table."""
    link = '<link name="{n}"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>\n'
    joint = ('<joint name="{n}" type="revolute"><parent link="{p}"/><child link="{c}"/><origin xyz="{xyz}"/><axis xyz="{ax}"/>'
             '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>\n')
    p = tmp_path / "r.urdf"
    p.write_text('<?xml version="1.0"?>\n<robot name="r">\n<link name="base"/>\n' + link.format(n="l1") + link.format(n="l2")
                 + joint.format(n="a-b", p="base", c="l1", xyz="0 0 0.1", ax="0 0 1") + joint.format(n="a_b", p="l1", c="l2", xyz="0.7 0 0.3", ax="0 1 0")
                 + "</robot>\n")
    desc = load_description(p)
    geometry = desc.geometry()
    first, second = (j.origin for j in desc.joints)
    assert {gv.symbol for gv in first.values()}.isdisjoint(gv.symbol for gv in second.values())
    assert geometry[first["z"].symbol].value == 0.1 and geometry[second["z"].symbol].value == 0.3


def test_platform_home_with_legs_at_their_stroke_end_is_accepted(tmp_path):
    """A parked pose, every leg fully retracted: its length is the limit to rounding (119.99999999999999 mm)."""
    from minparam_cli.chain import build_chain

    doc = yaml.safe_load((FOURBAR.parent / "platforms" / "hexapod_6_6.yaml").read_text())
    doc["dynamics"]["home"] = [0, 0, 99.96265961561714, 0, 0, 0]  # every leg 120 mm, the lower limit
    p = tmp_path / "parked.yaml"
    p.write_text(yaml.safe_dump(doc, sort_keys=False))
    shipped = build_chain(load_description(FOURBAR.parent / "platforms" / "hexapod_6_6.yaml"))
    assert build_chain(load_description(p)).dof == shipped.dof == 21  # the tree joints of the six legs, as at the shipped home


def test_platform_home_that_no_leg_can_reach(tmp_path):
    """dynamics.home 100 m above the dodekapod (legs 150..300 mm): derive closed the loops from there for minutes."""
    doc = yaml.safe_load((FOURBAR.parent / "dodekapod_dang2013.yaml").read_text())
    doc["dynamics"]["home"] = [0, 0, 1e5, 0, 0, 0]
    p = tmp_path / "dodekapod.yaml"
    p.write_text(yaml.safe_dump(doc, sort_keys=False))
    r = CliRunner().invoke(app, ["derive", str(p)])
    assert r.exit_code == 2 and len(r.stderr.strip().splitlines()) == 1, r.output
    assert "dynamics.home: leg l12 is 100000.0369 mm long at the home pose, outside its limits [150, 300]" in r.stderr
