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
