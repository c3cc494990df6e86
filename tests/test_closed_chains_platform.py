"""Platform files with a ``dynamics:`` section (issue 35 point 1): the legs and the platform as a
closed chain for derive; the kinematics commands still read the file; bad sections are one line."""

from __future__ import annotations

from pathlib import Path

import pytest

from minparam_cli.api.derivation import derive_file
from minparam_cli.api.options.derive import DeriveOptions
from minparam_cli.describe import load_description
from minparam_cli.describe.platform_yaml import load_platform
from minparam_cli.errors import DescriptionError, UnsupportedError

ROOT = Path(__file__).resolve().parents[1]
DODEKAPOD = ROOT / "robots" / "dodekapod_dang2013.yaml"


def test_dodekapod_with_leg_masses_has_six_motors_and_the_energy_route_agrees():
    base = derive_file(DODEKAPOD, DeriveOptions(samples=60))
    info = base.extra["closed_chain"]
    assert info["mobility"] == 6 and info["closure_equations"] == 15 and info["tree_joints"] == 21
    assert info["actuated"] == ["l12", "l13", "l21", "l23", "l31", "l32"]  # the paper's leg order
    assert info["energy_check"]["agrees"]
    # 13 bodies (6 cylinders, 6 pistons, the platform) and a viscous and a Coulomb column per leg
    assert base.n_standard == 13 * 10 + 12


def test_the_platform_reference_is_the_home_pose_leg_lengths():
    """At the reference the prismatic joints are the leg lengths of the home pose (the kinematics
    of ``minparam platform``, computed here from the node coordinates)."""
    import numpy as np

    desc = load_description(DODEKAPOD)
    plat = load_platform(DODEKAPOD)
    base = dict(zip(plat.base_names, np.array(plat.base_coords) * 1e-3, strict=True))
    top = dict(zip(plat.platform_names, np.array(plat.platform_coords) * 1e-3 + [0, 0, 0.2], strict=True))
    for k, leg in zip(desc.loops.actuated, plat.legs, strict=True):
        assert desc.loops.reference[k] == pytest.approx(np.linalg.norm(top[leg.platform] - base[leg.base]), abs=1e-12)


def _bad(tmp_path, old, new):
    p = tmp_path / "bad.yaml"
    text = DODEKAPOD.read_text()
    assert old in text
    p.write_text(text.replace(old, new))
    return p


def test_an_unknown_dynamics_key_is_one_line(tmp_path):
    with pytest.raises(DescriptionError, match="unknown key"):
        load_description(_bad(tmp_path, "  home: [0, 0, 200, 0, 0, 0]", "  home: [0, 0, 200, 0, 0, 0]\n  motors: 6"))


def test_a_negative_leg_mass_is_one_line(tmp_path):
    with pytest.raises(DescriptionError, match="non-negative"):
        load_description(_bad(tmp_path, "cylinder: {mass: 0.35", "cylinder: {mass: -0.35"))


def test_a_truss_with_dynamics_is_refused(tmp_path):
    truss = ROOT / "robots" / "platforms" / "dodekapod_truss.yaml"
    p = tmp_path / "truss.yaml"
    p.write_text(truss.read_text() + "\ndynamics: {home: [0, 0, 0, 0, 0, 0]}\n")
    with pytest.raises(UnsupportedError, match="free truss"):
        load_description(p)


def test_platform_commands_still_read_the_file():
    plat = load_platform(DODEKAPOD)
    assert len(plat.legs) == 6 and plat.structure == "platform"
