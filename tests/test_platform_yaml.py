"""Platform YAML: the shipped files load, and one test per kind of broken input.

Each broken file must raise DescriptionError naming the element, and through
the CLI give exit code 2 with one line on stderr, no traceback and no output
file.
"""

from __future__ import annotations

import copy
import math

import pytest
import yaml
from typer.testing import CliRunner

from minparam_cli.cli.app import app
from minparam_cli.describe.platform_yaml import load_platform
from minparam_cli.errors import DescriptionError
from conftest import ROBOTS

GOOD = {
    "kind": "platform",
    "name": "t",
    "units": {"length": "mm", "angle": "deg"},
    "base": {"radius": 90, "angles": [90, 210, 330]},
    "platform": {"radius": 81, "angles": [90, 30, 150]},
    "legs": [["B1", "P2"], ["B1", "P3"], ["B2", "P1"], ["B2", "P3"], ["B3", "P1"], ["B3", "P2"]],
    "leg_limits": [150, 300],
}
TRUSS = {
    "kind": "platform",
    "units": {"length": "mm"},
    "nodes": {"A": [0, 0, 0], "B": [1, 0, 0], "C": [0, 1, 0], "D": [0, 0, 1], "E": [1, 1, 1], "F": [1, 0, 1]},
    # octahedron on the pairs (A,E) (B,C) (D,F) not joined
    "legs": [["A", "B"], ["A", "C"], ["A", "D"], ["A", "F"], ["E", "B"], ["E", "C"], ["E", "D"], ["E", "F"],
             ["B", "D"], ["B", "F"], ["C", "D"], ["C", "F"]],
}


def write(tmp_path, doc, name="p.yaml"):
    p = tmp_path / name
    p.write_text(doc if isinstance(doc, str) else yaml.safe_dump(doc, sort_keys=False))
    return p


def variant(template=GOOD, **changes):
    doc = copy.deepcopy(template)
    for key, value in changes.items():
        if value is None:
            doc.pop(key, None)
        else:
            doc[key] = value
    return doc


def rejects(tmp_path, doc, match, element=None):
    """Loader raises with ``match``; the CLI exits 2 with one stderr line and writes no output file."""
    p = write(tmp_path, doc)
    with pytest.raises(DescriptionError, match=match) as info:
        load_platform(p)
    if element is not None:
        assert info.value.element == element
    out = tmp_path / "out.json"
    r = CliRunner().invoke(app, ["platform", "fk", str(p), "--lengths", "1,1,1,1,1,1", "-o", str(out)])
    assert r.exit_code == 2, r.output
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and str(p) in lines[0], r.stderr
    assert "Traceback" not in r.output
    assert not out.exists()
    return info.value


# ---------------------------------------------------------------- good files


def test_paper_file_loads_with_the_recorded_angles():
    d = load_platform(ROBOTS / "dodekapod_dang2013.yaml")
    assert d.structure == "platform" and d.angle_unit == "deg" and d.length_unit == "mm"
    assert [leg.name for leg in d.legs] == ["l12", "l13", "l21", "l23", "l31", "l32"]
    for (x, y, z), phi in zip(d.base_coords, (90, 210, 330), strict=True):
        assert x == pytest.approx(90 * math.cos(math.radians(phi)), abs=1e-12)
        assert y == pytest.approx(90 * math.sin(math.radians(phi)), abs=1e-12) and z == 0
    for (x, y, _), lam in zip(d.platform_coords, (90, 30, 150), strict=True):
        assert math.hypot(x, y) == pytest.approx(81) and math.degrees(math.atan2(y, x)) == pytest.approx(lam)
    assert all(leg.limits == (150.0, 300.0) for leg in d.legs)


def test_pi_expressions_match_degrees():
    a = load_platform(ROBOTS / "platforms" / "dodekapod_dang2013_equilateral.yaml")
    assert a.base_coords[1][0] == pytest.approx(90 * math.cos(7 * math.pi / 6), abs=1e-12)
    assert a.platform_coords[0][1] == pytest.approx(-81, abs=1e-12)


def test_every_shipped_platform_loads():
    files = [ROBOTS / "dodekapod_dang2013.yaml"] + sorted((ROBOTS / "platforms").glob("*.yaml"))
    assert len(files) >= 4
    for f in files:
        load_platform(f)


def test_truss_loads(tmp_path):
    d = load_platform(write(tmp_path, TRUSS))
    assert d.structure == "truss" and len(d.legs) == 12 and d.base_names == tuple("ABCDEF")


# ---------------------------------------------------------------- one test per broken input


def test_empty_file(tmp_path):
    rejects(tmp_path, "", "file is empty")


def test_malformed_yaml(tmp_path):
    rejects(tmp_path, "kind: platform\nbase: [1, 2\n", "malformed YAML")


def test_not_a_mapping(tmp_path):
    rejects(tmp_path, "- 1\n- 2\n", "expected a mapping")


def test_missing_kind(tmp_path):
    rejects(tmp_path, variant(kind=None), "kind: platform", element="kind")


def test_wrong_kind(tmp_path):
    rejects(tmp_path, variant(kind="robot"), "'robot'", element="kind")


def test_unknown_top_key(tmp_path):
    rejects(tmp_path, variant(joints=[]), r"unknown key\(s\) \['joints'\]")


def test_duplicate_key(tmp_path):
    text = yaml.safe_dump(GOOD, sort_keys=False) + "name: again\n"
    rejects(tmp_path, text, "duplicate key 'name'")


def test_missing_units(tmp_path):
    rejects(tmp_path, variant(units=None), "missing required field 'units'")


def test_unknown_length_unit(tmp_path):
    rejects(tmp_path, variant(units={"length": "furlong", "angle": "deg"}), "unknown length unit", "units.length")


def test_missing_angle_unit(tmp_path):
    rejects(tmp_path, variant(units={"length": "mm"}), "missing 'angle'", element="units")


def test_missing_legs(tmp_path):
    rejects(tmp_path, variant(legs=None), "missing required field 'legs'")


def test_no_nodes_at_all(tmp_path):
    rejects(tmp_path, variant(base=None, platform=None), "expected 'base' and 'platform'")


def test_missing_platform(tmp_path):
    rejects(tmp_path, variant(platform=None), "missing required field 'platform'")


def test_sides_and_nodes_together(tmp_path):
    rejects(tmp_path, variant(nodes=TRUSS["nodes"]), "not both")


def test_non_positive_radius(tmp_path):
    rejects(tmp_path, variant(base={"radius": 0, "angles": [0, 120, 240]}), "positive", "base.radius")


def test_radius_not_a_number(tmp_path):
    rejects(tmp_path, variant(base={"radius": "ninety", "angles": [0, 120, 240]}), "expected a number", "base.radius")


def test_non_finite_number(tmp_path):
    rejects(tmp_path, variant(base={"radius": float("nan"), "angles": [0, 120, 240]}), "finite", "base.radius")


def test_boolean_is_not_a_number(tmp_path):
    rejects(tmp_path, variant(base={"radius": 90, "angles": [0, True, 240]}), "expected a number", "base.angles[1]")


def test_angles_not_a_list(tmp_path):
    rejects(tmp_path, variant(base={"radius": 90, "angles": 90}), "list of polar angles", "base.angles")


def test_missing_radius(tmp_path):
    rejects(tmp_path, variant(base={"angles": [0, 120, 240]}), "missing required field 'radius'", "base")


def test_pi_expression_with_degrees(tmp_path):
    rejects(tmp_path, variant(base={"radius": 90, "angles": ["pi/2", 210, 330]}), "in radians", "base.angles[0]")


def test_bad_angle_expression(tmp_path):
    doc = variant(units={"length": "mm", "angle": "rad"}, base={"radius": 90, "angles": ["tau/4", 1, 2]})
    rejects(tmp_path, doc, "expression like", "base.angles[0]")


def test_names_count_mismatch(tmp_path):
    rejects(tmp_path, variant(base={"radius": 90, "angles": [90, 210, 330], "names": ["B1", "B2"]}),
            "3 node names", "base.names")


def test_duplicate_names(tmp_path):
    rejects(tmp_path, variant(base={"radius": 90, "angles": [90, 210, 330], "names": ["B1", "B1", "B3"]}),
            "unique", "base.names")


def test_name_on_both_sides(tmp_path):
    rejects(tmp_path, variant(platform={"radius": 81, "angles": [90, 30, 150], "names": ["B1", "P2", "P3"]}),
            "both base and platform")


def test_unknown_side_key(tmp_path):
    rejects(tmp_path, variant(base={"radius": 90, "angles": [90, 210, 330], "height": 3}), "unknown key", "base")


def test_explicit_node_wrong_length(tmp_path):
    rejects(tmp_path, variant(platform={"nodes": {"P1": [0, 81], "P2": [70, 40, 0], "P3": [-70, 40, 0]}}),
            "list of 3 numbers", "platform.nodes.P1")


def test_nodes_and_radius_together(tmp_path):
    spec = {"radius": 81, "angles": [0, 1, 2], "nodes": {"P1": [0, 0, 0]}}
    rejects(tmp_path, variant(platform=spec), "not both", "platform")


def test_collinear_platform(tmp_path):
    spec = {"nodes": {"P1": [0, 0, 0], "P2": [1, 1, 1], "P3": [2, 2, 2]}}
    rejects(tmp_path, variant(platform=spec), "collinear", "platform")


def test_too_few_base_nodes(tmp_path):
    rejects(tmp_path, variant(base={"radius": 90, "angles": [90, 210]}), "at least 3 nodes", "base")


def test_wrong_number_of_legs(tmp_path):
    rejects(tmp_path, variant(legs=GOOD["legs"][:5]), "six legs", "legs")


def test_leg_unknown_node(tmp_path):
    legs = copy.deepcopy(GOOD["legs"])
    legs[2] = ["B2", "P9"]
    rejects(tmp_path, variant(legs=legs), "unknown node 'P9'", "legs[3]")


def test_leg_joins_two_base_nodes(tmp_path):
    legs = copy.deepcopy(GOOD["legs"])
    legs[0] = ["B1", "B2"]
    rejects(tmp_path, variant(legs=legs), "two base nodes", "legs[1]")


def test_leg_joins_a_node_to_itself(tmp_path):
    legs = copy.deepcopy(GOOD["legs"])
    legs[0] = ["P2", "P2"]
    rejects(tmp_path, variant(legs=legs), "twice", "legs[1]")


def test_duplicate_leg(tmp_path):
    legs = copy.deepcopy(GOOD["legs"])
    legs[1] = ["P2", "B1"]
    rejects(tmp_path, variant(legs=legs), "joined twice", "legs[2]")


def test_leg_not_a_pair(tmp_path):
    legs = copy.deepcopy(GOOD["legs"])
    legs[0] = "B1-P2"
    rejects(tmp_path, variant(legs=legs), "pair of node names", "legs[1]")


def test_unknown_leg_key(tmp_path):
    legs = copy.deepcopy(GOOD["legs"])
    legs[0] = {"nodes": ["B1", "P2"], "stroke": 100}
    rejects(tmp_path, variant(legs=legs), "unknown key", "legs[1]")


def test_limits_reversed(tmp_path):
    rejects(tmp_path, variant(leg_limits=[300, 150]), "not below", "leg_limits")


def test_negative_lower_limit(tmp_path):
    legs = copy.deepcopy(GOOD["legs"])
    legs[3] = {"nodes": ["B2", "P3"], "limits": [-1, 10]}
    rejects(tmp_path, variant(legs=legs), "negative", "legs[4].limits")


def test_node_without_legs(tmp_path):
    doc = variant(base={"radius": 90, "angles": [90, 210, 330, 45]})
    rejects(tmp_path, doc, "'B4' is not joined", "legs")


def test_truss_not_octahedral(tmp_path):
    legs = copy.deepcopy(TRUSS["legs"])
    legs[0] = ["A", "E"]  # A keeps 4 legs, B drops to 3, E gets 5
    rejects(tmp_path, variant(TRUSS, legs=legs), "has 3 legs", "legs")


def test_truss_wrong_node_count(tmp_path):
    nodes = dict(TRUSS["nodes"], G=[2, 2, 2])
    rejects(tmp_path, variant(TRUSS, nodes=nodes), "six nodes", "nodes")


def test_workspace_unknown_key(tmp_path):
    rejects(tmp_path, variant(workspace={"w": [0, 1]}), "unknown key", "workspace")


def test_workspace_low_above_high(tmp_path):
    rejects(tmp_path, variant(workspace={"z": [300, 0]}), "above high", "workspace.z")
