"""Glazunov's global problem: the grid scan, the sigma map and the symbolic minors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from minparam_cli.chain import build_chain
from minparam_cli.describe import load_description
from minparam_cli.errors import InputError, UnsupportedError
from minparam_cli.kinematics.serial.plucker import plucker_matrices
from minparam_cli.kinematics.serial.screws import analyse
from minparam_cli.kinematics.serial.singular_grid import grid_plucker, sigma_map, swept_joints
from minparam_cli.kinematics.serial.singular_scan import scan

ROBOTS = Path(__file__).resolve().parents[1] / "robots"
D = np.radians


def chain(name: str):
    return build_chain(load_description(ROBOTS / name))


def _set(result, dependent):
    return next(s for s in result.sets if s.dependent_joints == dependent)


def test_grid_frames_equal_forward_kinematics():
    arm = chain("puma560.yaml")
    values = [np.array([0.3]), np.array([-1.0, 0.5]), np.array([0.2, 1.1, 2.0]), np.array([0.7]), np.array([-0.4, 0.9]), np.array([0.1])]
    J, c = grid_plucker(arm, values)
    Q = np.array(np.meshgrid(*values, indexing="ij")).reshape(6, -1).T
    J_ref, c_ref = plucker_matrices(arm, Q)
    assert np.allclose(J, J_ref, atol=1e-13) and np.allclose(c, c_ref, atol=1e-13)


def test_puma_scan_finds_wrist_elbow_and_shoulder():
    arm = chain("puma560.yaml")
    r = scan(arm, np.zeros(6), step=D(45))
    assert [a.joint for a in r.axes] == [1, 2, 3, 4]  # joints 2..5
    assert r.nodes == 8**4
    wrist = _set(r, (3, 5))
    assert wrist.constant[4] == pytest.approx((0.0, np.pi))
    elbow = _set(r, (1, 2, 3, 4, 5))
    assert elbow.constant[2] == pytest.approx((np.arctan2(0.4331, -0.0203),), abs=1e-9)
    shoulder = _set(r, (0, 1, 3, 4, 5))
    assert shoulder.count > 0 and 2 not in shoulder.constant
    assert np.all(r.sigma <= r.epsilon)
    # every reported point passes the local test
    for k in np.linspace(0, r.points.shape[0] - 1, 25).astype(int):
        assert analyse(arm, r.points[k]).singular


def test_ur5_scan_elbow_and_wrist_sets():
    r = scan(chain("ur5.yaml"), np.zeros(6), step=D(45))
    assert _set(r, (1, 2, 3)).constant[2] == pytest.approx((0.0, np.pi))
    assert _set(r, (1, 2, 3, 5)).constant[4] == pytest.approx((0.0, np.pi))


def test_scan_without_determinant_planar_3r():
    r = scan(chain("planar3r.yaml"), np.zeros(3), step=D(7))
    assert [a.joint for a in r.axes] == [1]
    (s,) = r.sets
    assert s.dependent_joints == (0, 1, 2)
    assert s.constant[1] == pytest.approx((0.0, np.pi), abs=1e-6)


def test_scan_prismatic_needs_limits(tmp_path):
    text = (ROBOTS / "universal15_glazunov.yaml").read_text().replace(", limits: [0.1, 0.6]", "")
    f = tmp_path / "nolimits.yaml"
    f.write_text(text)
    with pytest.raises(InputError, match="prismatic and has no limits"):
        scan(build_chain(load_description(f)), np.zeros(6), step=D(45))


def test_scan_refuses_huge_grid():
    with pytest.raises(InputError, match="use a larger step"):
        scan(chain("puma560.yaml"), np.zeros(6), step=D(2))


def test_sigma_map_shape_and_zero_line():
    arm = chain("puma560.yaml")
    m = sigma_map(arm, np.zeros(6), (3, 4), points=37)
    assert m.sigma.shape == (37, 37) and m.det is not None
    row = int(np.argmin(np.abs(m.y)))  # q5 = 0: singular for every q4
    assert np.all(m.sigma[row] < 1e-12)
    with pytest.raises(InputError, match="two different joints"):
        sigma_map(arm, np.zeros(6), (2, 2))


def test_swept_joints():
    assert swept_joints(chain("planar2r.yaml")) == ()
    assert swept_joints(chain("panda.yaml")) == (1, 2, 3, 4, 5)


# --- symbolic ---------------------------------------------------------------------------------------------


def test_symbolic_planar_3r():
    from minparam_cli.kinematics.serial.singular_symbolic import symbolic_conditions

    s = symbolic_conditions(chain("planar3r.yaml"))
    assert s.what == "3-minors"
    (c,) = s.conditions
    assert c.expression == "sin(q2) = 0" and c.joints == (1,)
    assert c.solutions == pytest.approx((0.0, np.pi))


def test_symbolic_universal15_matches_scan_branches():
    from minparam_cli.kinematics.serial.singular_symbolic import symbolic_conditions

    s = symbolic_conditions(chain("universal15_glazunov.yaml"))
    exprs = {c.expression for c in s.conditions}
    assert exprs == {"q4 = 0", "cos(q2) = 0", "sin(q3 + q5) = 0"}
    cos2 = next(c for c in s.conditions if c.expression == "cos(q2) = 0")
    assert cos2.solutions == pytest.approx((-np.pi / 2, np.pi / 2))
    pair = next(g for g in s.groups if g.group == (2, 4))  # axes 3 and 5 coincide when the slide is at zero
    assert pair.status == "when" and pair.conditions[0].expression == "q4 = 0"


def test_symbolic_refuses_seven_joints():
    from minparam_cli.kinematics.serial.singular_symbolic import symbolic_conditions

    with pytest.raises(UnsupportedError, match="at most 6 joints"):
        symbolic_conditions(chain("panda.yaml"))


def test_a_grid_too_large_for_a_machine_integer_is_refused(tmp_path):
    """numpy's product of the axes' sizes wrapped around past 2^63 (24 values on 33 joints gave 0): the
    node limit let the scan start, which then ran out of memory."""
    rows = "\n".join(f"  - {{type: revolute, a: 0.1, alpha: {(-90, 0, 0, 90)[j % 4]}, d: 0.05, theta: 0}}" for j in range(36))
    f = tmp_path / "arm36.yaml"
    f.write_text(f"name: arm36\nconvention: dh\nunits: {{length: m, angle: deg}}\njoints:\n{rows}\n")
    arm = build_chain(load_description(f))
    assert len(swept_joints(arm)) >= 33
    with pytest.raises(InputError, match=r"the grid has \d{40,} nodes"):
        scan(arm, np.zeros(36), step=D(15))
