"""Rank decisions on what real URDF files contain (issue 24): rounded angles, millimetre offsets,
continuous joints, empty files, robots the method of projections cannot finish.

Each URDF is made here, small, after a class of file found in example-robot-data 6.0.0
(kinova.urdf writes pi as 3.14159265359 and puts joint 2 1.6 mm off joint 1's axis;
so100.urdf writes pi/2 as 1.57079; ur3.urdf is an empty <robot>)."""

from __future__ import annotations

import json
import math

import pytest
from typer.testing import CliRunner

from minparam_cli.base.projection import MAX_ROWS, MAX_WORK, derive_projection, projection_cost
from minparam_cli.base.qr import derive_qr
from minparam_cli.base.result import RANK_RTOL, WEAK_RTOL
from minparam_cli.cli.app import app
from minparam_cli.errors import ComputationError, DescriptionError
from minparam_cli.robot import load_chain
from minparam_cli.api.derivation import derive_file as _derive_file
from minparam_cli.api.options.derive import DeriveOptions


def derive_file(path, opts):
    """The derive JSON of one robot file (the API's base set, as a dict)."""
    return _derive_file(path, opts).to_dict()


LINK = (
    '<link name="{n}"><inertial><origin xyz="0.01 0.02 0.03" rpy="0 0 0"/><mass value="1.0"/>'
    '<inertia ixx="0.01" ixy="0.001" ixz="0.002" iyy="0.02" iyz="0.003" izz="0.03"/></inertial></link>\n'
)
PI, HALF_PI = repr(math.pi), repr(math.pi / 2)


def urdf(tmp_path, name, joints, fixed=()):
    """joints: (parent, child, type, xyz, rpy, axis) per actuated joint; fixed: (parent, child, xyz, rpy)."""
    links = {"base"} | {j[1] for j in joints} | {f[1] for f in fixed}
    body = "".join(LINK.format(n=n) for n in sorted(links))
    for i, (parent, child, kind, xyz, rpy, axis) in enumerate(joints):
        limit = "" if kind == "continuous" else '<limit lower="-3" upper="3" effort="1" velocity="1"/>'
        body += (
            f'<joint name="j{i + 1}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
            f'<origin xyz="{xyz}" rpy="{rpy}"/><axis xyz="{axis}"/>{limit}</joint>\n'
        )
    for i, (parent, child, xyz, rpy) in enumerate(fixed):
        body += f'<joint name="f{i + 1}" type="fixed"><parent link="{parent}"/><child link="{child}"/><origin xyz="{xyz}" rpy="{rpy}"/></joint>\n'
    path = tmp_path / f"{name}.urdf"
    path.write_text(f'<?xml version="1.0"?>\n<robot name="{name}">\n{body}</robot>\n')
    return path


def kinova_like(tmp_path, name, pi=PI, half_pi=HALF_PI, offset="0.0016", kind="revolute"):
    """Six joints after kinova.urdf: pitch pi on joint 1, joint 2's origin `offset` m along its own axis."""
    p, h = pi, half_pi
    return urdf(
        tmp_path,
        name,
        [
            ("base", "l1", kind, "0 0 0.15675", f"0 {p} 0", "0 0 1"),
            ("l1", "l2", kind, f"0 {offset} -0.11875", f"-{h} 0 {p}", "0 0 1"),
            ("l2", "l3", kind, "0 -0.410 0", f"0 {p} 0", "0 0 1"),
            ("l3", "l4", kind, "0 0.2073 -0.0114", f"-{h} 0 {p}", "0 0 1"),
            ("l4", "l5", kind, "0 0 -0.10375", f"{h} 0 {p}", "0 0 1"),
            ("l5", "l6", kind, "0 0.10375 0", f"-{h} 0 {p}", "0 0 1"),
        ],
        fixed=[("l6", "tool", "0 0 -0.16", f"{p} {h} 0")],
    )


def base_of(path, method="qr", **kw):
    _, chain = load_chain(path, DeriveOptions(**kw))
    b = derive_projection(chain) if method == "projection" else derive_qr(chain)
    return b, [b.standard_names[c] for c in b.kept]


@pytest.mark.parametrize("method", ["qr", "projection"])
def test_pi_rounded_to_eleven_digits_gives_the_exact_count(tmp_path, method):
    exact, exact_kept = base_of(kinova_like(tmp_path, "exact"), method)
    rounded, rounded_kept = base_of(kinova_like(tmp_path, "rounded", pi="3.14159265359", half_pi="1.57079632679"), method)
    assert rounded_kept == exact_kept
    assert exact.n_base == 36  # the count pinocchio's regressor gives kinova.urdf
    m = rounded.rank_margin
    assert m["last_kept"] > 1e4 * RANK_RTOL and m["first_dropped"] < 1e-4 * RANK_RTOL  # a clean gap on both sides
    assert not m["weak"]


@pytest.mark.parametrize("method", ["qr", "projection"])
def test_a_link_mass_that_is_an_exact_multiple_of_zz1_regroups_into_it(tmp_path, method):
    # joint 2's origin 1.6 mm off joint 1's axis, along joint 2's own axis: link 2's mass sits on
    # joint 2's axis at 1.6 mm from joint 1's, so its column is exactly 0.0016**2 times ZZ1's
    b, kept = base_of(kinova_like(tmp_path, "offset"), method)
    _, kept_on_axis = base_of(kinova_like(tmp_path, "on_axis", offset="0"), method)
    assert "M2" not in kept
    assert kept == kept_on_axis
    zz1 = b.terms[kept.index("ZZ1")]
    assert zz1["M2"] == pytest.approx(0.0016**2, rel=1e-9)


def so100_like(tmp_path, name, half_pi):
    """After so100.urdf: joint 1's axis y turned by roll `half_pi`, vertical when that is pi/2."""
    return urdf(
        tmp_path,
        name,
        [
            ("base", "l1", "revolute", "0 -0.0452 0.0165", f"{half_pi} 0 0", "0 1 0"),
            ("l1", "l2", "revolute", "0 0.1025 0.0306", "-1.8 0 0", "1 0 0"),
            ("l2", "l3", "revolute", "0 0.11257 0.028", "1.3 0 0", "1 0 0"),
        ],
    )


def test_pi_over_two_written_1_57079_keeps_two_weak_parameters_named_with_the_tilt(tmp_path):
    exact = derive_file(so100_like(tmp_path, "exact", HALF_PI), DeriveOptions())
    rounded = derive_file(so100_like(tmp_path, "rounded", "1.57079"), DeriveOptions())
    # the file's axis is 6.3e-6 rad from vertical: gravity reaches link 1's first moments, weakly
    assert rounded["n_base"] == exact["n_base"] + 2
    assert "weakly_identifiable" not in exact
    weak = rounded["weakly_identifiable"]
    assert len(weak) == 2
    for w in weak:
        assert w["parameter"] in ("MX1", "MY1", "MZ1")
        assert RANK_RTOL < w["margin"] < 1e-5 < WEAK_RTOL
        assert w["geometry"] == ["joint 1 (j1) axis 6.3e-06 rad from parallel to gravity"]


def test_snap_angles_restores_the_exact_count_and_reports_every_change(tmp_path):
    path = so100_like(tmp_path, "rounded", "1.57079")
    exact = derive_file(so100_like(tmp_path, "exact", HALF_PI), DeriveOptions())
    snapped = derive_file(path, DeriveOptions(snap_angles=1e-4))
    assert snapped["n_base"] == exact["n_base"]
    assert [b["name"] for b in snapped["base_parameters"]] == [b["name"] for b in exact["base_parameters"]]
    changed = snapped["snap_angles"]["changed"]
    # -1.8 and 1.3 rad are 0.03 and 0.009 rad from a multiple of 15 degrees: left alone
    assert [(c["where"], c["from"], c["degrees"]) for c in changed] == [("joint[j1]/origin@rpy roll", 1.57079, 90)]
    assert changed[0]["to"] == math.pi / 2
    # a tolerance that does not reach 6.3e-6 rad changes nothing
    assert derive_file(path, DeriveOptions(snap_angles=1e-6))["snap_angles"]["changed"] == []


def test_snap_angles_through_the_cli_prints_the_values_it_changed(tmp_path):
    path = so100_like(tmp_path, "rounded", "1.57079")
    r = CliRunner().invoke(app, ["derive", str(path), "--snap-angles", "1e-4"])
    assert r.exit_code == 0, r.output
    assert "--snap-angles 0.0001 rad changed 1 value:" in r.output
    assert "joint[j1]/origin@rpy roll: 1.57079 -> 1.5707963267948966 (90 deg)" in r.output
    r = CliRunner().invoke(app, ["derive", str(path), "--snap-angles", "0.2"])
    assert r.exit_code == 2 and "--snap-angles" in r.output
    r = CliRunner().invoke(app, ["derive", str(path)])
    assert "weakly identifiable (2" in r.output and "6.3e-06 rad from parallel to gravity" in r.output


def parallel_axes(tmp_path, name, offset, reach):
    """Joints 1 and 2 vertical, joint 2 `offset` m off joint 1's axis; joint 3 `reach` m further out."""
    return urdf(
        tmp_path,
        name,
        [
            ("base", "l1", "revolute", "0 0 0.3", "0 0 0", "0 0 1"),
            ("l1", "l2", "revolute", f"{offset} 0 0.5", "0 0 0", "0 0 1"),
            ("l2", "l3", "revolute", f"{reach} 0 0", "0 0 0", "0 1 0"),
        ],
    )


def test_a_1_6_mm_offset_is_weak_on_a_10_m_robot_and_named(tmp_path):
    coaxial = derive_file(parallel_axes(tmp_path, "coaxial", 0, 10.0), DeriveOptions())
    offset = derive_file(parallel_axes(tmp_path, "offset", 0.0016, 10.0), DeriveOptions())
    # the offset makes link 2's first moments felt by joint 1, through 1.6 mm against 10 m
    assert offset["n_base"] == coaxial["n_base"] + 2
    weak = {w["parameter"]: w for w in offset["weakly_identifiable"]}
    assert set(weak) == {"MX2", "MY2"}
    for w in weak.values():
        assert RANK_RTOL < w["margin"] < WEAK_RTOL
        assert w["geometry"] == ["joint 2 (j2) axis 1.6 mm (0.00016 of the robot's size) from coaxial with joint 1 (j1)'s axis"]


def test_the_same_offset_on_a_half_metre_robot_is_not_weak(tmp_path):
    rep = derive_file(parallel_axes(tmp_path, "offset", 0.0016, 0.5), DeriveOptions())
    assert rep["n_base"] == 11
    assert "weakly_identifiable" not in rep
    assert WEAK_RTOL < rep["rank_margin"]["last_kept"] < 1e-2


def romeo_like_hand(tmp_path, name, axis_z):
    """After romeo.urdf's left arm: seven joints, then a hand joint whose axis is written
    (0.121869, -0.992546, `axis_z`); the file has -4.37114e-08 there, float32's cos(pi/2)."""
    return urdf(
        tmp_path,
        name,
        [
            ("base", "sp", "revolute", "0.005 0.19 0.2", "0 0 0", "0 1 0"),
            ("sp", "sy", "revolute", "0 0 0", "0 0 0", "0 0 1"),
            ("sy", "er", "revolute", "0.205 0 0", "0 0 0", "1 0 0"),
            ("er", "ey", "revolute", "0 0 0", "0 0 0", "0 0 1"),
            ("ey", "wr", "revolute", "0.1823 0 0", "0 0 0", "1 0 0"),
            ("wr", "wy", "revolute", "0 0 0", "0 0 0", "0 0 1"),
            ("wy", "wp", "revolute", "0 0 0", "0 0 0", "0 1 0"),
            ("wp", "hand", "revolute", "0.10937 0.02468 0.00329", "0 1.06465 0.122173", f"0.121869 -0.992546 {axis_z}"),
        ],
    )


@pytest.mark.parametrize("method", ["qr", "projection"])
def test_an_axis_tilted_by_float32_rounding_does_not_make_the_scan_too_close_to_call(tmp_path, method):
    exact = derive_file(romeo_like_hand(tmp_path, "exact", "0"), DeriveOptions(method=method))
    tilted = derive_file(romeo_like_hand(tmp_path, "tilted", "-4.37114e-08"), DeriveOptions(method=method))
    # the 4.4e-8 rad tilt gives the hand's MY a residual of ~4e-8 against the columns before it,
    # just above RANK_RTOL, in a direction its MZ (next in the scan) carries at full size.  Keeping
    # MY there left MZ a combination of MY and the rest to within eps/4e-8 ~ 1e-8, the cut itself:
    # the one-pass scan kept 53 columns where the singular values give 52 ("too close to call").
    # Pinocchio's regressor + pivoted QR gives 52 with a clean gap (4e-2 / 4e-16).
    assert exact["n_base"] == tilted["n_base"] == 52
    kept = [[next(iter(b["terms"])) for b in rep["base_parameters"]] for rep in (exact, tilted)]
    assert kept[0] == kept[1]  # the same columns kept (a coefficient of ~4e-8 may regroup into one)
    assert "weakly_identifiable" not in tilted
    assert tilted["rank_margin"]["last_kept"] > 1e-3 and tilted["rank_margin"]["first_dropped"] < 1e-12


@pytest.mark.parametrize("method", ["qr", "projection"])
def test_continuous_joints_give_the_revolute_base_set(tmp_path, method):
    _, revolute = base_of(kinova_like(tmp_path, "rev", pi="3.14159265359"), method)
    _, continuous = base_of(kinova_like(tmp_path, "cont", pi="3.14159265359", kind="continuous"), method)
    assert continuous == revolute


def test_an_empty_robot_is_refused_with_what_is_missing(tmp_path):
    empty = tmp_path / "empty.urdf"
    empty.write_text('<?xml version="1.0"?>\n<robot xmlns:xacro="http://wiki.ros.org/xacro">\n</robot>\n')
    with pytest.raises(DescriptionError, match="no name attribute"):
        load_chain(empty, DeriveOptions())
    r = CliRunner().invoke(app, ["derive", str(empty)])
    assert r.exit_code == 2
    assert len(r.output.strip().splitlines()) == 1 and "no name attribute" in r.output
    named = tmp_path / "named.urdf"
    named.write_text('<?xml version="1.0"?>\n<robot name="r">\n</robot>\n')
    with pytest.raises(DescriptionError, match="no <link> element"):
        load_chain(named, DeriveOptions())


def generic_tree(tmp_path):
    """A trunk of 5 joints and 2 arms of 5, every origin turned by a generic angle (no zero products)."""
    turns = ["0.3 0.5 0.7", "0.2 -0.4 0.9", "-0.6 0.1 0.3", "0.8 0.2 -0.5"]
    joints, prev = [], "base"
    for i in range(5):
        joints.append((prev, f"t{i}", "revolute", "0.1 0.02 0.3", turns[i % 4], "0 0 1"))
        prev = f"t{i}"
    for b in range(2):
        parent = prev
        for i in range(5):
            joints.append((parent, f"b{b}_{i}", "revolute", "0.1 0.03 0.2", turns[(i + b) % 4], "0 0 1"))
            parent = f"b{b}_{i}"
    return urdf(tmp_path, "tree", joints)


def test_projection_refuses_before_computing_what_it_cannot_finish_in_a_minute(tmp_path):
    path = generic_tree(tmp_path)
    _, chain = load_chain(path, DeriveOptions())
    assert projection_cost(chain)["rows"] <= MAX_ROWS  # the row count alone would let it run
    with pytest.raises(ComputationError, match=r"matrices for 15 joints \(limit 4e\+08, about 60 s.*use --method qr"):
        derive_projection(chain)
    r = CliRunner().invoke(app, ["derive", str(path), "--method", "projection"])
    assert r.exit_code == 1 and "use --method qr" in r.output
    assert MAX_WORK == 4 * 10**8


def test_weak_parameters_are_in_the_json_contract(tmp_path):
    r = CliRunner().invoke(app, ["derive", str(so100_like(tmp_path, "rounded", "1.57079")), "--format", "json"])
    rep = json.loads(r.stdout)  # stderr may hold a warning about the nominal bodies
    assert {w["parameter"] for w in rep["weakly_identifiable"]} <= {"MX1", "MY1", "MZ1"}
    assert rep["rank_margin"]["weak_bound"] == WEAK_RTOL
