"""``minparam singular`` through the real entry point: exit codes and text."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import cli

ROBOTS = Path(__file__).resolve().parents[1] / "robots"
PUMA = str(ROBOTS / "puma560.yaml")
U15 = str(ROBOTS / "universal15_glazunov.yaml")


def test_help_states_units():
    r = cli("singular", "--help")
    assert r.exit_code == 0
    text = " ".join(r.output.split())
    assert "degrees for revolute joints" in text and "--rad" in text and "metres for prismatic" in text
    assert "O_c" in text and "Examples" in text


def test_wrist_singularity_table():
    r = cli("singular", PUMA, "--q", "10,-30,40,20,0,15")
    assert r.exit_code == 0, r.output
    assert "rank       5 of 6: SINGULAR" in r.output
    assert "dependent  joints [4, 6]" in r.output
    assert "H1" in r.output


def test_generic_configuration_table():
    r = cli("singular", PUMA, "--q", "10,-30,40,20,30,15")
    assert r.exit_code == 0
    assert "not singular" in r.output and "dependent" not in r.output


def test_json_keys_and_units():
    r = cli("singular", PUMA, "--q", "10,-30,40,20,0,15", "--twist", "0.1,0.2,0.3,0.1,0.1,0.1", "--format", "json", "--seed", "5")
    assert r.exit_code == 0, r.output
    doc = json.loads(r.stdout)
    for key in ("robot", "q", "det", "sigma_min", "epsilon", "rank", "singular", "dependent_joints",
                "reciprocal_screws", "requested_twist", "nearest_twist", "joint_rates", "twist_convention"):
        assert key in doc
    assert doc["singular"] is True and doc["dependent_joints"] == [4, 6]
    assert doc["q"][4] == 0.0 and doc["q"][0] == pytest.approx(np.radians(10))
    assert len(doc["reciprocal_screws"]) == 1 and len(doc["reciprocal_screws"][0]) == 6
    assert doc["seed"] == 5 and doc["nearest_check"]["seed"] == 5
    assert doc["joint_rates"][5] == 0.0 and doc["held_joints"] == [6]


def test_rad_flag_gives_the_same_answer():
    deg = json.loads(cli("singular", PUMA, "--q", "10,-30,40,20,30,15", "--format", "json").stdout)
    q = ",".join(repr(float(v)) for v in np.radians([10, -30, 40, 20, 30, 15]))
    rad = json.loads(cli("singular", PUMA, "--q", q, "--rad", "--format", "json").stdout)
    assert rad["sigma_min"] == pytest.approx(deg["sigma_min"], rel=1e-12)


def test_paper_example_through_the_cli():
    # the YAML's base frame is the paper's relabelled: paper (x, y, z) -> base (y, z, x)
    r = cli("singular", U15, "--q", "0,0,0,0.4,0,0", "--twist", "0.1,0.1,0.2,0.2,0.4,0.4", "--format", "json")
    assert r.exit_code == 0, r.output
    doc = json.loads(r.stdout)
    assert doc["dependent_joints"] == [2, 6]
    assert doc["nearest_twist"] == pytest.approx([0.1, 0.0, 0.2, 0.2, 0.4, 0.4], abs=1e-12)
    assert doc["joint_rates"] == pytest.approx([0.4, 0.1, 0.9, 0.2, -0.7, 0.0], abs=1e-12)
    assert doc["reciprocal_screw_details"][0]["kind"] == "couple"


def test_output_file(tmp_path):
    out = tmp_path / "s.json"
    r = cli("singular", PUMA, "--q", "0,0,0,0,0,0", "--format", "json", "-o", str(out))
    assert r.exit_code == 0 and r.stdout == ""
    assert json.loads(out.read_text())["rank"] == 5


def test_scan_and_plot(tmp_path):
    png = tmp_path / "map.png"
    r = cli("singular", PUMA, "--scan", "--step", "45", "--plot", str(png), "--joints", "3,5", "--quiet")
    assert r.exit_code == 0, r.output
    assert "scan (Glazunov's global problem)" in r.output and "q5 in {0, 180}" in r.output
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_the_plot_maps_sigma_over_the_two_joints_of_a_planar_arm(tmp_path, monkeypatch):
    """singular --plot (render/singular_plot.py) on the planar 3R over joints 2 and 3, the fast tier's case
    of the PUMA map above: the PNG is written, and the figure saved is the map over the two joints in
    degrees, its colours log10(σ_min/σ_max) (floored at 1e-6), whose smallest σ is the JSON's."""
    from minparam_cli.cli import singular as command

    saved = []
    monkeypatch.setattr(command, "save_png", lambda fig, path, save=command.save_png: (saved.append(fig), save(fig, path)))
    planar, png = str(ROBOTS / "planar3r.yaml"), tmp_path / "map.png"
    r = cli("singular", planar, "--plot", png, "--joints", "2,3", "--format", "json", "--quiet")
    assert r.exit_code == 0, r.output
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    ax = saved[0].axes[0]
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("q2 (deg)", "q3 (deg)")
    x, y = ax.collections[0].get_coordinates()[0, :, 0], ax.collections[0].get_coordinates()[:, 0, 1]
    assert x.min() < -179 and x.max() > 179 and y.min() < -179 and y.max() > 179  # the whole turn of each joint
    colours = np.asarray(ax.collections[0].get_array())
    smallest = json.loads(r.stdout)["plot"]["sigma_min_on_map"]
    assert colours.min() == pytest.approx(np.log10(max(smallest, 1e-6))) and colours.max() <= 0


def test_scan_json():
    r = cli("singular", PUMA, "--scan", "--step", "60", "--format", "json", "--quiet")
    doc = json.loads(r.stdout)
    assert doc["scan"]["swept_joints"] == [2, 3, 4, 5]
    assert any(s["dependent_joints"] == [4, 6] for s in doc["scan"]["sets"])


def test_symbolic():
    r = cli("singular", str(ROBOTS / "planar3r.yaml"), "--symbolic")
    assert r.exit_code == 0, r.output
    assert "sin(q2) = 0   ->  q2 = 0, q2 = 180" in r.output


# --- one test per bad input -------------------------------------------------------------------------------


def test_malformed_q():
    r = cli("singular", PUMA, "--q", "1,x,3,4,5,6")
    assert r.exit_code == 2 and "--q" in r.output and "comma-separated numbers" in r.output


def test_wrong_q_count():
    r = cli("singular", PUMA, "--q", "1,2,3")
    assert r.exit_code == 2 and "has 6 joints, got 3 values" in r.output
    assert "Traceback" not in r.output


def test_malformed_twist():
    r = cli("singular", PUMA, "--q", "0,0,0,0,0,0", "--twist", "a,b,c,d,e,f")
    assert r.exit_code == 2 and "--twist" in r.output


def test_wrong_twist_count():
    r = cli("singular", PUMA, "--q", "0,0,0,0,0,0", "--twist", "1,2,3")
    assert r.exit_code == 2 and "expected 6 comma-separated numbers" in r.output


def test_non_finite_q():
    r = cli("singular", PUMA, "--q", "0,0,nan,0,0,0")
    assert r.exit_code == 2 and "finite" in r.output


def test_epsilon_out_of_range():
    r = cli("singular", PUMA, "--q", "0,0,0,0,0,0", "--epsilon", "1.5")
    assert r.exit_code == 2 and "--epsilon" in r.output


def test_bad_step():
    r = cli("singular", PUMA, "--scan", "--step", "0")
    assert r.exit_code == 2 and "--step" in r.output


def test_bad_joints_for_map(tmp_path):
    r = cli("singular", PUMA, "--plot", str(tmp_path / "m.png"), "--joints", "2,9")
    assert r.exit_code == 2 and "joint 9 does not exist" in r.output


def test_malformed_joints(tmp_path):
    r = cli("singular", PUMA, "--plot", str(tmp_path / "m.png"), "--joints", "two,three")
    assert r.exit_code == 2 and "--joints" in r.output


def test_hold_outside_group():
    r = cli("singular", PUMA, "--q", "0,0,0,0,0,0", "--hold", "1")
    assert r.exit_code == 2 and "hold joints from {4, 6}" in r.output


def test_missing_robot_file(tmp_path):
    r = cli("singular", str(tmp_path / "none.yaml"), "--q", "0")
    assert r.exit_code == 2


def test_malformed_robot_file(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\nconvention: dh\njoints: [\n")
    r = cli("singular", str(bad), "--q", "0")
    assert r.exit_code == 2 and "malformed YAML" in r.output


def test_nothing_to_do():
    r = cli("singular", PUMA)
    assert r.exit_code == 2 and "give --q" in r.output


def test_twist_without_q():
    r = cli("singular", PUMA, "--twist", "1,1,1,1,1,1", "--scan")
    assert r.exit_code == 2 and "need a configuration --q" in r.output


def test_missing_output_folder(tmp_path):
    r = cli("singular", PUMA, "--q", "0,0,0,0,0,0", "-o", str(tmp_path / "no" / "out.txt"))
    assert r.exit_code == 2 and "does not exist" in r.output


def test_symbolic_on_seven_joints():
    r = cli("singular", str(ROBOTS / "panda.yaml"), "--symbolic")
    assert r.exit_code == 2 and "at most 6 joints" in r.output
