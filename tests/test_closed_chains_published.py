"""Closed chains against published base-parameter sets (issue 35 point 2), and the Delta robot.

Published sources (facts only): Schappler's hybrid-robot library, github.com/SchapplM/robsynth-serhybroblib
(Schappler, Lilge & Haddadin, "Kinematics and Dynamics Model via Explicit Direct and Trigonometric
Elimination of Kinematic Constraints", IFToMM World Congress 2019), whose generated minimal parameter
vectors (``systems/<robot>/matlabfcn_<robot>TE/<robot>TE_convert_par2_MPV_fixb.m``) state the counts and
the regroupings compared here.  docs/methods/closed_chains.md has the table and the discussion."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from minparam_cli.api.derivation import derive_file
from minparam_cli.api.options.derive import DeriveOptions
from minparam_cli.errors import DescriptionError

ROOT = Path(__file__).resolve().parents[1]
FOURBAR = ROOT / "robots" / "fourbar_hybroblib.yaml"
PARALLELOGRAM = ROOT / "robots" / "parallelogram_hybroblib.yaml"
DELTA = ROOT / "robots" / "delta.yaml"


def _row(base, name):
    """The regrouping row of the base parameter kept at column ``name`` as {standard name: coefficient} (zeros dropped)."""
    i = [base.standard_names[k] for k in base.kept].index(name)
    return {base.standard_names[c]: float(v) for c, v in enumerate(base.K[i]) if abs(v) > 1e-9}


def test_parallelogram_four_bar_matches_the_hybroblib_minimal_parameters():
    """Schappler's library, systems/fourbar2 (parallelogram, l1 = 4, l2 = 2): MPV of 3 entries,
    ZZ2 + ZZ4 + l2²·M3, MX2 + MX4 + l2·M3, MY2 + MY4 (its links 2, 3, 4 are our links 1, 2, 3)."""
    base = derive_file(PARALLELOGRAM, DeriveOptions())
    assert base.n_base == 3
    assert _row(base, "ZZ1") == pytest.approx({"ZZ1": 1.0, "M2": 4.0, "ZZ3": 1.0})
    assert _row(base, "MX1") == pytest.approx({"MX1": 1.0, "M2": 2.0, "MX3": 1.0})
    assert _row(base, "MY1") == pytest.approx({"MY1": 1.0, "MY3": 1.0})


def test_crank_rocker_four_bar_has_one_parameter_fewer_than_the_hybroblib_vector():
    """Schappler's library, systems/fourbar1 (l1 = 4.5, l2 = 2, l3 = 3, l4 = 4): MPV of 9 entries, the
    open tree's regrouping (ZZ2 + l2²·M3, MX2 + l2·M3, MY2, and ZZ, MX, MY of the coupler and the rocker).
    The loop adds one relation the tree rules cannot see: a point mass at the coupler–rocker joint moves
    as a point of either body, so δ on the rocker (MX3 += 4δ, ZZ3 += 16δ) equals δ on the coupler's tip
    (MX2 += 3δ, ZZ2 += 9δ, carried by the crank: M2 += δ).  Rank 8; the dropped column is the rocker's MX."""
    base = derive_file(FOURBAR, DeriveOptions())
    assert base.n_base == 8
    names = [base.standard_names[k] for k in base.kept]
    assert "MX3" not in names and "MY3" in names
    # the point mass δ at the joint: (ZZ3, MX3) = (16δ, 4δ) on the rocker gives the coupler's (9δ, 3δ)
    # and the crank's l2²δ, l2·δ — exactly the regrouping of MX3
    assert _row(base, "ZZ3") == pytest.approx({"ZZ3": 1.0, "MX3": -4.0})
    assert _row(base, "ZZ2") == pytest.approx({"ZZ2": 1.0, "MX3": 9.0 / 4.0})
    assert _row(base, "MX2") == pytest.approx({"MX2": 1.0, "MX3": 3.0 / 4.0})
    assert _row(base, "ZZ1") == pytest.approx({"ZZ1": 1.0, "M2": 4.0, "MX3": 1.0})
    check = base.extra["closed_chain"]["energy_check"]
    assert check["rank_energy"] == 8 and check["agrees"]


def test_the_point_mass_relation_is_what_separates_the_two_counts():
    """Without the loop (the open tree of the library's 'OL' model: the same three links, every joint
    free) the rank is the library's 9, so the one parameter fewer comes from the loop."""
    from minparam_cli.base.qr import base_from_regressor
    from minparam_cli.dynamics.regressor import joint_regressor
    from minparam_cli.robot import load_chain

    _, chain = load_chain(FOURBAR, DeriveOptions().stage(), loops=True)
    rng = np.random.default_rng(0)
    q, qd, qdd = (rng.uniform(-np.pi, np.pi, (60, 3)), rng.standard_normal((60, 3)), rng.standard_normal((60, 3)))
    kept, _, _, _ = base_from_regressor(joint_regressor(chain, q, qd, qdd).reshape(-1, chain.layout.size))
    assert len(kept) == 9


def test_delta_base_set_agrees_with_the_energy_route():
    """The Delta (3-RUU equivalent, massive rods, massless U-joint crosses): 34 base parameters of 70,
    the same rank and regrouping from the energy rows; the platform only translates, so its first
    moments and inertia have no effect and its mass regroups onto leg 1's rod (a point mass at its tip)."""
    base = derive_file(DELTA, DeriveOptions())
    check = base.extra["closed_chain"]["energy_check"]
    assert base.n_base == 34 and len(base.standard_names) == 70
    assert check["rank_energy"] == 34 and check["agrees"]
    assert base.extra["closed_chain"]["mobility"] == 3
    unident = {base.standard_names[c] for c in base.unidentifiable}
    assert {"XX5", "YY5", "ZZ5", "MX5", "MY5", "MZ5"} <= unident


def test_delta_with_lumped_forearms_has_the_classic_ten_parameters(tmp_path):
    """Codourey's simplification of the Delta (forearms lumped into the arms and the platform, so the
    rods carry no parameters): per arm the inertia about the motor axis and the two first moments in the
    plane normal to it, and the platform's mass — 3 × 3 + 1 = 10."""
    text = DELTA.read_text()
    lumped = []
    for line in text.splitlines():
        if line.lstrip().startswith("inertial:") and lumped and "name: r" in lumped[-1]:
            lumped[-1] = lumped[-1] + " massless: true}"
            continue
        lumped.append(line)
    path = tmp_path / "delta_lumped.yaml"
    path.write_text("\n".join(lumped) + "\n")
    base = derive_file(path, DeriveOptions())
    assert len(base.standard_names) == 40  # three arms and the platform
    assert base.n_base == 10
    kept = [base.standard_names[k] for k in base.kept]
    assert "M5" in kept and not any(n.endswith("5") and n != "M5" for n in kept)  # the plate: only its mass
    arms = [n for n in kept if n != "M5"]
    assert len(arms) == 9 and {n[-1] for n in arms} == {"1", "6", "0"}  # links a1, a2 (6), a3 (10)


def test_a_massless_link_with_inertial_data_is_refused(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text(DELTA.read_text().replace("name: e1, parent: a1, type: revolute,", "name: e1, parent: a1, type: revolute, "
                                             "inertial: {mass: 1, com: [0, 0, 0], inertia: [1, 0, 0, 1, 0, 1]},"))
    with pytest.raises(DescriptionError, match="massless link has no inertial"):
        derive_file(bad, DeriveOptions())


def test_an_identified_block_that_is_not_a_mapping_is_refused(tmp_path):
    """identify --export-yaml writes an 'identified' mapping, which a closed_chain file may carry; anything else is an error."""
    bad = tmp_path / "bad.yaml"
    bad.write_text(DELTA.read_text() + "identified: [1, 2]\n")
    with pytest.raises(DescriptionError, match="identify --export-yaml found"):
        derive_file(bad, DeriveOptions())


# Schappler's parallel-robot library (github.com/SchapplM/robsynth-parroblib, snapshot 01c8d77) gives each
# robot's minimal parameter vector under its own assumption: all legs identical (one parameter set per leg
# link, in the leg's own frames) and the platform's own ten parameters
# (sym_<dof>/<robot>/hd_G1A0/<robot>G1A0_minimal_parameter_para.m).  Under that assumption the torque
# route's columns of the legs' links add up (rotated into the leg's frame where the legs' frames differ).

def _rotation_map(theta):
    """10×10 map from a link's parameters in a frame turned by theta about z to the same link's parameters
    in the base-aligned frame (inertia R I Rᵀ, first moment R ms, mass)."""
    c, s = np.cos(theta), np.sin(theta)
    R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    out = np.zeros((10, 10))
    for k in range(10):
        e = np.eye(10)[k]
        inertia = R @ np.array([[e[0], e[1], e[2]], [e[1], e[3], e[4]], [e[2], e[4], e[5]]]) @ R.T
        out[:, k] = [inertia[0, 0], inertia[0, 1], inertia[0, 2], inertia[1, 1], inertia[1, 2], inertia[2, 2], *(R @ e[6:9]), e[9]]
    return out


def _shared_legs(path, groups, platform, turns=None, gravity=None, samples=150):
    """Base set of the actuated torques when the links of each group (one per leg) share one parameter
    set: (count, K rows by kept column) over [group 1, group 2, ..., platform] columns."""
    from minparam_cli.base.qr import base_from_regressor
    from minparam_cli.loops.derive import actuated_regressor
    from minparam_cli.loops.model import closed_model
    from minparam_cli.loops.sample import manifold_states
    from minparam_cli.robot import load_chain

    opts = DeriveOptions(gravity=gravity) if gravity else DeriveOptions()
    desc, chain = load_chain(path, opts.stage(), loops=True)
    model = closed_model(desc, chain)
    q, qd, qdd, G = manifold_states(model, samples, 0)
    W = actuated_regressor(model, q, qd, qdd, G).reshape(-1, chain.layout.size)
    slot = {j: i for i, j in enumerate(chain.layout.links_with_columns)}
    names = chain.joint_names

    def cols(link, k=0):
        block = W[:, 10 * slot[names.index(link)]:10 * slot[names.index(link)] + 10]
        return block @ _rotation_map(turns[k]) if turns is not None else block

    blocks = [sum(cols(link, k) for k, link in enumerate(group)) for group in groups] + [cols(platform)]
    kept, K, _, margin = base_from_regressor(np.concatenate(blocks, axis=1))
    assert margin["first_dropped"] < 1e-12 < margin["last_kept"]
    return len(kept), kept, K


def test_3rrr_with_identical_legs_has_one_parameter_fewer_than_the_parroblib_vector():
    """parroblib sym_2T1R/P3RRR1 (planar 3-RRR, identical legs): MPV of 10 — the leg's 6 (ZZ1 + a2²·M2,
    MX1 + a2·M2, MY1, ZZ2, MX2, MY2) and the platform's ZZ, MX, MY, M.  Gravity in the plane, as the
    vector's first moments need.  With identical legs a point mass δ/3 at each platform joint moves with
    the platform or with each leg's tip: the platform's mass regroups onto the legs and 9 remain."""
    n, kept, K = _shared_legs(ROOT / "robots" / "planar_3rrr.yaml", [("a1", "a2", "a3"), ("b1", "b2", "b3")], "c1",
                              gravity=(0.0, -9.81, 0.0))
    assert n == 9
    assert 29 not in kept  # the platform's M (column 10·2 + 9)
    # the point mass δ/3 at the three joints: 0.3 m along each distal link (MX) and its square (ZZ)
    ZZb, MXb = list(kept).index(15), list(kept).index(16)
    assert K[MXb, 29] == pytest.approx(0.3 / 3) and K[ZZb, 29] == pytest.approx(0.09 / 3)


def test_gough_stewart_with_identical_legs_has_one_parameter_fewer_than_the_parroblib_vector():
    """parroblib sym_3T3R/P6RRPRRR14V3 (6-UPS Gough–Stewart, identical legs): MPV of 24 — 14 of the leg
    (the universal joint's first cross carries MX1 and adds to two others) and the platform's 10; with a
    massless cross, as robots/platforms/hexapod_6_6.yaml has, 13 + 10 = 23 entries remain.  minparam: 22,
    the leg's 13 and the platform's 9 (its mass regroups onto the pistons: δ/6 at each ball joint)."""
    legs = [tuple(f"L{i}_u2" for i in range(1, 7)), tuple(f"L{i}" for i in range(1, 7))]
    n, kept, K = _shared_legs(ROOT / "robots" / "platforms" / "hexapod_6_6.yaml", legs, "L1_s3")
    assert n == 22
    assert 29 not in kept  # the platform's mass
    assert len([k for k in kept if k < 20]) == 13 and len([k for k in kept if k >= 20]) == 9


def test_delta_with_identical_legs_has_one_parameter_fewer_than_the_parroblib_vector():
    """parroblib sym_3T0R/P3RRRRR2 (3-RUU Delta equivalent, joint groups 1-1-2-2-1, identical legs): MPV of
    14 — arm 3, elbow cross 2 (MX2 and MY2 − MZ3; Izz2 adds to the rod's Iyy3), rod 8, the platform's mass;
    with a massless elbow cross, as robots/delta.yaml has, 13 remain.  minparam: 12, arm 3 and rod 9, the
    platform's mass regrouped onto the rods' tips (δ/3 each).  robots/delta.yaml's legs are turned copies
    (0, 120, 240 deg about z) in base-aligned frames: each leg's columns are mapped into leg 1's frames."""
    turns = np.radians([0.0, 120.0, 240.0])
    n, kept, K = _shared_legs(DELTA, [("a1", "a2", "a3"), ("r1", "r2", "r3")], "platform", turns=turns, samples=200)
    assert n == 12
    assert 29 not in kept
    assert len([k for k in kept if k < 10]) == 3 and len([k for k in kept if 10 <= k < 20]) == 9


def test_delta_with_the_librarys_massive_elbow_cross_is_still_one_below(tmp_path):
    """The same Delta with a massive elbow cross (the library's own body split, its 14 entries): 13 —
    the relation at the platform joints does not depend on the crosses."""
    import re

    text = re.sub(r"(name: e\d[^\n]*)massless: true", r"\1inertial: {mass: 0.05, com: [0.003, 0.002, -0.004], "
                  r"inertia: [0.00002, 0.000001, 0, 0.00003, 0, 0.00004]}", DELTA.read_text())
    path = tmp_path / "delta_cross.yaml"
    path.write_text(text)
    turns = np.radians([0.0, 120.0, 240.0])
    n, _, _ = _shared_legs(path, [("a1", "a2", "a3"), ("e1", "e2", "e3"), ("r1", "r2", "r3")], "platform", turns=turns,
                           samples=250)
    assert n == 13
