"""derive --symbolic on mimic joints and floating bases (issue 18, point 3): the exact route
covers every robot the numeric routes take, compared with the numeric QR route at random
geometries (mimic offsets included) and random gravity, as in test_symbolic_exact.

Mimic joints: q_j = k·q_m + o; the offset joins the joint's fixed transform (a symbol
``<joint>_mimic_offset``), the multiplier stays the file's exact decimal.  The three ways of
drawing exact states are covered: free angles (k = 0.37, no two frequencies meet), angles on a
lattice (k = 2, −0.5, and 0.3333 with 0.6667: frequencies meet), and prismatic slaves of a
revolute master."""

from __future__ import annotations

from fractions import Fraction

import pytest
import test_floating_base as fb
import test_mimic as tm
from test_symbolic_exact import RTOL, compare_with_numeric

from minparam_cli.base.symbolic_coupled import Coupled, _collisions, _complement, _multiple_angle
from minparam_cli.api.derivation import derive_file as _derive_file
from minparam_cli.api.options.derive import DeriveOptions


def derive_file(path, opts):
    """The derive JSON of one robot file (the API's base set, as a dict)."""
    return _derive_file(path, opts).to_dict()


ALL = dict(friction=("coulomb", "viscous", "offset"), rotor_inertia=True)


def mixed_arm(tmp_path):
    """j3 follows j1 with k = 0.37 and offset 0.4 (free angles); the slide s1 follows j2 with
    k = 0.05 m/rad (a prismatic slave of a revolute master); j4 mimics j2 with k = 2 (a lattice: one angle and its double)."""
    j = tm.joint
    joints = [
        j("j1", "revolute", "base", "l1", "0 0 0.3", "0 0 1"),
        j("j2", "revolute", "l1", "l2", "0.05 0 0.1", "0 1 0"),
        j("s1", "prismatic", "l2", "l3", "0.3 0.02 0", "1 0 0", mimic=("j2", 0.05, 0.01)),
        j("j3", "revolute", "l3", "l4", "0.25 0 0.04", "0 1 0", mimic=("j1", 0.37, 0.4)),
        j("j4", "revolute", "l4", "l5", "0.1 0.03 0.02", "1 0 0", rpy="0.3 0 0", mimic=("j2", 2, 0)),
    ]
    return tm.write(tmp_path, "mixed_mimic", joints, ["base", "l1", "l2", "l3", "l4", "l5"])


def _check(path, opts):
    report, coef, worst, worst_beta = compare_with_numeric(path, opts)
    assert worst <= RTOL, worst
    assert worst_beta <= 1e-9, worst_beta
    return report, coef


@pytest.mark.parametrize("extras", [{}, ALL], ids=["inertial", "friction-rotor-offset"])
def test_parallel_gripper_prismatic_mimic(tmp_path, extras):
    report, coef = _check(tm.gripper_arm(tmp_path), DeriveOptions(symbolic=True, **extras))
    if extras:  # the right finger's viscous friction joins the left one's (k = 1: factor 1)
        assert any(t == "Fv6" for _, t in coef) or "Fv6" not in report["standard_parameters"]


def test_revolute_mimic_of_a_mimic_with_offsets(tmp_path):
    report, _ = _check(tm.revolute_mimic_arm(tmp_path), DeriveOptions(symbolic=True, **ALL))
    assert "j4_mimic_offset" in report["symbols"]


def test_mixed_mimic_free_angles_lattice_and_prismatic_slave(tmp_path):
    report, _ = _check(mixed_arm(tmp_path), DeriveOptions(symbolic=True, **ALL))
    assert {"j3_mimic_offset", "s1_mimic_offset"} <= set(report["symbols"])


@pytest.mark.parametrize("floating_joint", [True, False], ids=["floating-joint", "floating-base-flag"])
def test_floating_base_biped(tmp_path, floating_joint):
    path = fb.biped(tmp_path, per_leg=2, floating_joint=floating_joint)
    report, _ = _check(path, DeriveOptions(symbolic=True, floating_base=not floating_joint))
    assert report["floating_base"]


def test_exact_state_rules():
    # frequencies meet for k = 2 (2·1 − 1·2 = 0) and k = −1/2, not for k = 37/100
    assert (2, -1) in _collisions([Fraction(1), Fraction(2)])
    assert (1, 2) in _collisions([Fraction(1), Fraction(-1, 2)])
    assert not _collisions([Fraction(1), Fraction(37, 100)])
    # 0.3333 + 0.6667 = 1: one collision direction, two free angles left
    ks = [Fraction(1), Fraction(3333, 10000), Fraction(6667, 10000)]
    C = _collisions(ks)
    assert set(C) == {(-1, 1, 1), (1, -1, -1), (-2, 2, 2), (2, -2, -2), (-3, 3, 3), (3, -3, -3), (-4, 4, 4), (4, -4, -4)}
    M = _complement(C, 3)
    assert len(M[0]) == 2 and all(sum(d * M[j][col] for j, d in enumerate(C[0])) == 0 for col in range(2))
    c, s = Fraction(3, 5), Fraction(4, 5)
    for p in (-3, 0, 2, 5):
        cp, sp_ = _multiple_angle((c, s), p)
        assert cp * cp + sp_ * sp_ == 1
    c2, s2 = _multiple_angle((c, s), 2)
    assert (c2, s2) == (c * c - s * s, 2 * s * c)
    assert _multiple_angle((c, s), -1) == (c, -s)


def test_coupled_plan_reads_the_coupling(tmp_path):
    from minparam_cli.robot import load_chain

    _desc, chain = load_chain(mixed_arm(tmp_path), DeriveOptions())
    plan = Coupled(chain, "x")
    names = chain.joint_names
    assert plan.k[names.index("j3")] == Fraction(37, 100) and plan.master[names.index("j3")] == names.index("j1")
    assert plan.k[names.index("s1")] == Fraction(1, 20)
    joints, M = plan.lattice[names.index("j2")]  # j2 with its k = 2 slave j4: one angle and its double
    assert joints == [names.index("j2"), names.index("j4")] and M in ([[1], [2]], [[-1], [-2]])
    assert names.index("j1") not in plan.lattice  # j1 and its k = 0.37 slave j3: free angles


def test_former_refusal_now_gives_a_set():
    r = derive_file("benchmarks/data/symbolic/mimic_gripper.urdf", DeriveOptions(symbolic=True))
    assert r["symbolic_verification"]["passed"] is True and not r.get("symbolic_notes")


def test_multipliers_meeting_at_a_long_period(tmp_path):
    # k = 0.3333 and 0.6667 on one master: 0.3333 + 0.6667 = 1, so the angles θ2 = φ1, θ3 = φ2,
    # θ1 = φ1 + φ2 (not one angle t with 10000 t, 3333 t, 6667 t)
    j = tm.joint
    joints = [
        j("j1", "revolute", "base", "l1", "0 0 0.3", "0 0 1"),
        j("j2", "revolute", "l1", "l2", "0.2 0 0.1", "0 1 0", mimic=("j1", 0.3333, 0)),
        j("j3", "revolute", "l2", "l3", "0.25 0 0.04", "1 0 0", mimic=("j1", 0.6667, 0)),
    ]
    _check(tm.write(tmp_path, "long_period", joints, ["base", "l1", "l2", "l3"]), DeriveOptions(symbolic=True, **ALL))


def test_mimic_with_symbolic_numbers(tmp_path):
    # lengths and the slide's mimic offset as the file's exact decimals; the revolute offset stays an angle symbol
    report, _ = _check(mixed_arm(tmp_path), DeriveOptions(symbolic_numbers=True))
    assert "s1_mimic_offset" in report["symbolic_numbers"] and "j3_mimic_offset" in report["symbols"]
    assert set(report["symbols"]) == {"j3_mimic_offset", "j4_roll", "g"}


def parallelogram(tmp_path):
    """j2 turns back what j1 turns (k = −1, parallel horizontal axes): link 2 keeps its orientation,
    so its rotational columns and the gravity torque of its first moments vanish on the constraint
    (cos(θ1 + θ2) = 1) but not for independent angles."""
    j = tm.joint
    joints = [
        j("j0", "revolute", "base", "l0", "0 0 0.2", "0 0 1"),
        j("j1", "revolute", "l0", "l1", "0 0 0.3", "0 1 0"),
        j("j2", "revolute", "l1", "l2", "0.4 0 0", "0 1 0", mimic=("j1", -1, 0)),
        j("j3", "revolute", "l2", "l3", "0.1 0.05 0", "1 0 0"),
    ]
    return tm.write(tmp_path, "parallelogram", joints, ["base", "l0", "l1", "l2", "l3"])


def test_parallelogram_needs_the_coupled_angles(tmp_path, monkeypatch):
    path = parallelogram(tmp_path)
    _check(path, DeriveOptions(symbolic=True))
    # the angles drawn independently (no lattice) give no set: the exact check catches it
    monkeypatch.setattr("minparam_cli.base.symbolic_coupled._collisions", lambda ks: [])
    r = derive_file(path, DeriveOptions(symbolic=True))
    assert r["symbolic_verification"]["passed"] is False


def test_more_than_seven_joints_on_one_coordinate(tmp_path):
    """Nine revolute joints on one coordinate (beyond the collision search's MAX_COUPLED = 7): the
    angles are drawn as the constraint itself, θ_j = K_j φ, and the set is exact."""
    j = tm.joint
    joints = [j("j0", "revolute", "base", "l0", "0 0 0.2", "0 0 1")]
    for i in range(1, 9):  # a planar chain: eight joints about parallel axes, all driven by j0
        joints.append(j(f"j{i}", "revolute", f"l{i - 1}", f"l{i}", "0.3 0 0", "0 0 1", mimic=("j0", i / 2, 0)))
    path = tm.write(tmp_path, "snake", joints, ["base"] + [f"l{i}" for i in range(9)])
    from minparam_cli.robot import load_chain

    _desc, chain = load_chain(path, DeriveOptions())
    plan = Coupled(chain, "snake")
    (coupled, M), = plan.lattice.values()
    assert len(coupled) == 9 and M == [[2], [1], [2], [3], [4], [5], [6], [7], [8]]  # k = 1, 1/2, 1, ..., 4
    _check(path, DeriveOptions(symbolic=True))