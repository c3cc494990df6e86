"""``minparam singular`` through the real entry point: exit codes and text."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

ROBOTS = Path(__file__).resolve().parents[1] / "robots"
PUMA = str(ROBOTS / "puma560.yaml")
U15 = str(ROBOTS / "universal15_glazunov.yaml")
runner = CliRunner()


@pytest.fixture(scope="module")
def app():
    from minparam_cli.cli.app import app as real_app

    return real_app


def run(app, *args):
    return runner.invoke(app, ["singular", *args])


def test_help_states_units(app):
    r = run(app, "--help")
    assert r.exit_code == 0
    text = " ".join(r.output.split())
    assert "degrees for revolute joints" in text and "--rad" in text and "metres for prismatic" in text
    assert "O_c" in text and "Examples" in text


def test_wrist_singularity_table(app):
    r = run(app, PUMA, "--q", "10,-30,40,20,0,15")
    assert r.exit_code == 0, r.output
    assert "rank       5 of 6: SINGULAR" in r.output
    assert "dependent  joints [4, 6]" in r.output
    assert "H1" in r.output


def test_generic_configuration_table(app):
    r = run(app, PUMA, "--q", "10,-30,40,20,30,15")
    assert r.exit_code == 0
    assert "not singular" in r.output and "dependent" not in r.output


def test_json_keys_and_units(app):
    r = run(app, PUMA, "--q", "10,-30,40,20,0,15", "--twist", "0.1,0.2,0.3,0.1,0.1,0.1", "--format", "json", "--seed", "5")
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


def test_rad_flag_gives_the_same_answer(app):
    deg = json.loads(run(app, PUMA, "--q", "10,-30,40,20,30,15", "--format", "json").stdout)
    q = ",".join(repr(float(v)) for v in np.radians([10, -30, 40, 20, 30, 15]))
    rad = json.loads(run(app, PUMA, "--q", q, "--rad", "--format", "json").stdout)
    assert rad["sigma_min"] == pytest.approx(deg["sigma_min"], rel=1e-12)


def test_paper_example_through_the_cli(app):
    # the YAML's base frame is the paper's relabelled: paper (x, y, z) -> base (y, z, x)
    r = run(app, U15, "--q", "0,0,0,0.4,0,0", "--twist", "0.1,0.1,0.2,0.2,0.4,0.4", "--format", "json")
    assert r.exit_code == 0, r.output
    doc = json.loads(r.stdout)
    assert doc["dependent_joints"] == [2, 6]
    assert doc["nearest_twist"] == pytest.approx([0.1, 0.0, 0.2, 0.2, 0.4, 0.4], abs=1e-12)
    assert doc["joint_rates"] == pytest.approx([0.4, 0.1, 0.9, 0.2, -0.7, 0.0], abs=1e-12)
    assert doc["reciprocal_screw_details"][0]["kind"] == "couple"


def test_output_file(app, tmp_path):
    out = tmp_path / "s.json"
    r = run(app, PUMA, "--q", "0,0,0,0,0,0", "--format", "json", "-o", str(out))
    assert r.exit_code == 0 and r.stdout == ""
    assert json.loads(out.read_text())["rank"] == 5


def test_scan_and_plot(app, tmp_path):
    png = tmp_path / "map.png"
    r = run(app, PUMA, "--scan", "--step", "45", "--plot", str(png), "--joints", "3,5", "--quiet")
    assert r.exit_code == 0, r.output
    assert "scan (Glazunov's global problem)" in r.output and "q5 in {0, 180}" in r.output
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_scan_json(app):
    r = run(app, PUMA, "--scan", "--step", "60", "--format", "json", "--quiet")
    doc = json.loads(r.stdout)
    assert doc["scan"]["swept_joints"] == [2, 3, 4, 5]
    assert any(s["dependent_joints"] == [4, 6] for s in doc["scan"]["sets"])


def test_symbolic(app):
    r = run(app, str(ROBOTS / "planar3r.yaml"), "--symbolic")
    assert r.exit_code == 0, r.output
    assert "sin(q2) = 0   ->  q2 = 0, q2 = 180" in r.output


# --- one test per bad input -------------------------------------------------------------------------------


def test_malformed_q(app):
    r = run(app, PUMA, "--q", "1,x,3,4,5,6")
    assert r.exit_code == 2 and "--q" in r.output and "comma-separated numbers" in r.output


def test_wrong_q_count(app):
    r = run(app, PUMA, "--q", "1,2,3")
    assert r.exit_code == 2 and "has 6 joints, got 3 values" in r.output
    assert "Traceback" not in r.output


def test_malformed_twist(app):
    r = run(app, PUMA, "--q", "0,0,0,0,0,0", "--twist", "a,b,c,d,e,f")
    assert r.exit_code == 2 and "--twist" in r.output


def test_wrong_twist_count(app):
    r = run(app, PUMA, "--q", "0,0,0,0,0,0", "--twist", "1,2,3")
    assert r.exit_code == 2 and "expected 6 comma-separated numbers" in r.output


def test_non_finite_q(app):
    r = run(app, PUMA, "--q", "0,0,nan,0,0,0")
    assert r.exit_code == 2 and "finite" in r.output


def test_epsilon_out_of_range(app):
    r = run(app, PUMA, "--q", "0,0,0,0,0,0", "--epsilon", "1.5")
    assert r.exit_code == 2 and "--epsilon" in r.output


def test_bad_step(app):
    r = run(app, PUMA, "--scan", "--step", "0")
    assert r.exit_code == 2 and "--step" in r.output


def test_bad_joints_for_map(app, tmp_path):
    r = run(app, PUMA, "--plot", str(tmp_path / "m.png"), "--joints", "2,9")
    assert r.exit_code == 2 and "joint 9 does not exist" in r.output


def test_malformed_joints(app, tmp_path):
    r = run(app, PUMA, "--plot", str(tmp_path / "m.png"), "--joints", "two,three")
    assert r.exit_code == 2 and "--joints" in r.output


def test_hold_outside_group(app):
    r = run(app, PUMA, "--q", "0,0,0,0,0,0", "--hold", "1")
    assert r.exit_code == 2 and "hold joints from {4, 6}" in r.output


def test_missing_robot_file(app, tmp_path):
    r = run(app, str(tmp_path / "none.yaml"), "--q", "0")
    assert r.exit_code == 2


def test_malformed_robot_file(app, tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\nconvention: dh\njoints: [\n")
    r = run(app, str(bad), "--q", "0")
    assert r.exit_code == 2 and "malformed YAML" in r.output


def test_nothing_to_do(app):
    r = run(app, PUMA)
    assert r.exit_code == 2 and "give --q" in r.output


def test_twist_without_q(app):
    r = run(app, PUMA, "--twist", "1,1,1,1,1,1", "--scan")
    assert r.exit_code == 2 and "need a configuration --q" in r.output


def test_missing_output_folder(app, tmp_path):
    r = run(app, PUMA, "--q", "0,0,0,0,0,0", "-o", str(tmp_path / "no" / "out.txt"))
    assert r.exit_code == 2 and "does not exist" in r.output


def test_symbolic_on_seven_joints(app):
    r = run(app, str(ROBOTS / "panda.yaml"), "--symbolic")
    assert r.exit_code == 2 and "at most 6 joints" in r.output
