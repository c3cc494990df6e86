"""`minparam platform ik|fk|workspace` through the real entry point: exit codes, text, JSON, files."""

from __future__ import annotations

import json

import numpy as np
import pytest

from conftest import ROBOTS, cli

PAPER = ROBOTS / "dodekapod_dang2013.yaml"
TRUSS = ROBOTS / "platforms" / "dodekapod_truss.yaml"
HEXAPOD = ROBOTS / "platforms" / "hexapod_6_6.yaml"
L = "238.6357,269.3776,256.0046,247.4046,185.4388,190.2705"


def assert_one_line_error(r, *needles):
    assert r.exit_code == 2, r.output
    assert "Traceback" not in r.output
    text = r.stderr.strip()
    for n in needles:
        assert n in text, text


def test_fk_json_has_the_documented_shape():
    r = cli("platform", "fk", PAPER, "--lengths", L, "--format", "json", "--seed", "3")
    assert r.exit_code == 0, r.output
    d = json.loads(r.stdout)
    assert d["seed"] == 3 and d["elapsed_s"] >= 0 and d["method"] == "exact"
    assert len(d["solutions"]) == 8
    target = np.array([float(x) for x in L.split(",")])
    for s in d["solutions"]:
        assert set(s["pose"]) == {"x", "y", "z", "roll", "pitch", "yaw"}
        assert 0 <= s["residual"] <= 1e-9
        assert "starts" in s
    assert np.allclose(d["lengths"], target, rtol=0, atol=0)
    assert d["certificate"]["complete"] is True and d["certificate"]["verified_roots"] == 16


def test_fk_solutions_reproduce_the_lengths_through_ik():
    """Feed every FK pose back through `platform ik` (degrees in, degrees out)."""
    d = json.loads(cli("platform", "fk", PAPER, "-l", L, "-f", "json", "--side", "above").stdout)
    assert len(d["solutions"]) == 4 and all(s["pose"]["z"] > 0 for s in d["solutions"])
    for s in d["solutions"]:
        p = s["pose"]
        pose = ",".join(repr(p[k]) for k in ("x", "y", "z", "roll", "pitch", "yaw"))
        ik = json.loads(cli("platform", "ik", PAPER, "--pose", pose, "-f", "json").stdout)
        assert np.max(np.abs(np.array(ik["lengths"]) - [float(x) for x in L.split(",")])) <= 1e-9


def test_fk_table():
    r = cli("platform", "fk", PAPER, "--lengths", L)
    assert r.exit_code == 0
    assert "8 real assembly modes" in r.stdout and "16 of 16 roots" in r.stdout and "seed 0" in r.stdout


def test_fk_pso_reports_starts_and_seed(tmp_path):
    out = tmp_path / "fk.json"
    r = cli("platform", "fk", PAPER, "-l", L, "-m", "pso", "--seed", "1", "-f", "json", "-o", out, "-q")
    assert r.exit_code == 0 and r.stdout == ""
    d = json.loads(out.read_text())
    assert d["seed"] == 1 and d["method"] == "pso" and d["starts_run"] == 30
    assert sum(s["starts"] for s in d["solutions"]) + d["failed_starts"] == 30
    assert d["settings"]["inertia"] == 0.7298 and d["settings"]["particles"] == 50


def test_fk_no_real_assembly_exits_0():
    r = cli("platform", "fk", PAPER, "-l", "10,10,10,10,10,10")
    assert r.exit_code == 0 and "0 real assembly modes" in r.stdout and "no real assembly" in r.stdout


def test_fk_wrong_number_of_lengths():
    assert_one_line_error(cli("platform", "fk", PAPER, "-l", "1,2,3"), "expected 6")


def test_fk_negative_length():
    assert_one_line_error(cli("platform", "fk", PAPER, "-l", "1,2,3,4,5,-6"), "positive")


def test_fk_exact_on_a_6_6_hexapod_is_bad_input(tmp_path):
    out = tmp_path / "o.json"
    r = cli("platform", "fk", HEXAPOD, "-l", "160,160,160,160,160,160", "-m", "exact", "-o", out)
    assert_one_line_error(r, str(HEXAPOD), "legs", "octahedral")
    assert not out.exists()


def test_missing_file():
    assert_one_line_error(cli("platform", "fk", "no/such.yaml", "-l", L), "no/such.yaml", "cannot read")


def test_arm_table_is_not_a_platform():
    assert_one_line_error(cli("platform", "ik", ROBOTS / "puma560.yaml", "--pose", "0,0,1,0,0,0"), "kind: platform")


def test_ik_pose_and_normal_agree():
    a = json.loads(cli("platform", "ik", PAPER, "--pose", "5,-10,200,4,-6,10", "-f", "json").stdout)
    n = ",".join(repr(v) for v in a["normal"])
    b = json.loads(cli("platform", "ik", PAPER, "--position", "5,-10,200", "--normal", n, "--yaw", "10",
                       "-f", "json").stdout)
    assert np.allclose(a["lengths"], b["lengths"], rtol=1e-13)
    assert b["pose"]["roll"] == pytest.approx(4) and b["pose"]["pitch"] == pytest.approx(-6)


def test_ik_table_flags_legs_outside_limits():
    r = cli("platform", "ik", PAPER, "--pose", "0,0,20,0,0,0")
    assert r.exit_code == 0 and "NO" in r.stdout  # 20 mm above the base: legs below 150


def test_ik_needs_a_pose():
    assert_one_line_error(cli("platform", "ik", PAPER), "--pose")


def test_ik_zero_normal():
    assert_one_line_error(cli("platform", "ik", PAPER, "--position", "0,0,200", "--normal", "0,0,0"), "zero")


def test_truss_ik_fk_round_trip_through_the_cli():
    ik = json.loads(cli("platform", "ik", TRUSS, "-f", "json").stdout)
    assert len(ik["lengths"]) == 12
    lengths = ",".join(repr(v) for v in ik["lengths"])
    d = json.loads(cli("platform", "fk", TRUSS, "-l", lengths, "--frame", "B1,B2,B3", "-f", "json").stdout)
    assert d["frame"] == ["B1", "B2", "B3"] and d["certificate"]["complete"]
    given = np.array([ik["nodes"][n] for n in ("B1", "B2", "B3", "P1", "P2", "P3")])
    # the file's B-triangle lies in z = 0, so the frame differs from the file by a planar motion only
    heights = sorted(abs(s["nodes"]["P1"][2]) for s in d["solutions"])
    assert min(abs(h - given[3, 2]) for h in heights) <= 1e-8


def test_truss_bad_frame():
    ik = json.loads(cli("platform", "ik", TRUSS, "-f", "json").stdout)
    lengths = ",".join(repr(v) for v in ik["lengths"])
    assert_one_line_error(cli("platform", "fk", TRUSS, "-l", lengths, "--frame", "B1,B2,P1"), "not a face")
    r = cli("platform", "fk", TRUSS, "-l", lengths, "--frame", "B1,B2,Z9")
    assert r.exit_code == 2


def test_workspace_json_and_plot(tmp_path):
    png = tmp_path / "ws.png"
    r = cli("platform", "workspace", PAPER, "--samples", "3000", "--seed", "4", "--plot", png, "-f", "json")
    assert r.exit_code == 0, r.output
    d = json.loads(r.stdout)
    assert d["seed"] == 4 and d["samples"] == 3000 and 0 < d["reachable"] < 3000
    assert d["fraction"] == pytest.approx(d["reachable"] / 3000)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # every rejected sample is rejected by at least one leg
    assert sum(leg["too_short"] + leg["too_long"] for leg in d["legs"]) >= 3000 - d["reachable"]


def test_workspace_seed_is_reproducible():
    a = json.loads(cli("platform", "workspace", PAPER, "-n", "2000", "--seed", "9", "-f", "json").stdout)
    b = json.loads(cli("platform", "workspace", PAPER, "-n", "2000", "--seed", "9", "-f", "json").stdout)
    assert a["reachable"] == b["reachable"] and a["centroid"] == b["centroid"]


def test_workspace_of_a_truss_is_bad_input(tmp_path):
    png = tmp_path / "t.png"
    assert_one_line_error(cli("platform", "workspace", TRUSS, "--plot", png), str(TRUSS), "nodes")
    assert not png.exists()


def test_workspace_needs_limits(tmp_path):
    text = PAPER.read_text().replace("leg_limits: [150, 300]\n", "")
    p = tmp_path / "nolimits.yaml"
    p.write_text(text)
    assert_one_line_error(cli("platform", "workspace", p), "legs[1]", "no length limits")


@pytest.mark.parametrize("cmd", ["ik", "fk", "workspace"])
def test_help_has_examples(cmd):
    r = cli("platform", cmd, "--help")
    assert r.exit_code == 0 and "Examples:" in r.stdout and f"minparam platform {cmd}" in r.stdout
