"""`minparam derive` and `minparam check` through the real entry point."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys

import numpy as np
import pytest
from conftest import cli

import minparam

CONTRACT = {
    "robot", "source", "method", "dof", "convention", "gravity", "seed", "samples", "standard_parameters",
    "base_parameters", "unidentifiable", "n_standard", "n_base", "rank_margin", "links", "elapsed_s",
}


def test_table_output_names_the_puma_groupings():
    r = cli("derive", "robots/puma560_mdh.yaml")
    assert r.exit_code == 0, r.output
    assert "base         36" in r.output
    assert "ZZR1" in r.output and "XXR2" in r.output and "MXR2" in r.output
    assert "seed 0" in r.output


def test_json_contract_and_terms_reproduce_the_base_parameters():
    r = cli("derive", "robots/puma560_mdh.yaml", "--friction", "coulomb,viscous", "--rotor-inertia", "--format", "json")
    assert r.exit_code == 0
    rep = json.loads(r.output)
    assert CONTRACT <= set(rep)
    assert rep["n_base"] == 52 and rep["n_standard"] == 78 and len(rep["base_parameters"]) == 52
    names = rep["standard_parameters"]
    assert names[:10] == ["XX1", "XY1", "XZ1", "YY1", "YZ1", "ZZ1", "MX1", "MY1", "MZ1", "M1"]
    assert names[60:64] == ["Ia1", "Fc1", "Fv1", "Ia2"]
    # terms: base = sum coefficient * standard, kept parameter itself at coefficient 1
    from minparam_cli.base.qr import derive_qr
    from minparam_cli.robot import DeriveOptions, load_chain

    _, chain = load_chain("robots/puma560_mdh.yaml", DeriveOptions(friction=("coulomb", "viscous"), rotor_inertia=True))
    b = derive_qr(chain)
    phi = np.random.default_rng(1).standard_normal(len(names))
    for i, bp in enumerate(rep["base_parameters"]):
        kept = names[b.kept[i]]
        assert bp["terms"][kept] == 1.0
        value = sum(c * phi[names.index(n)] for n, c in bp["terms"].items())
        assert value == pytest.approx(b.K[i] @ phi, rel=1e-12, abs=1e-12)


def test_one_base_set_renders_every_format_as_the_command_prints_it():
    b = minparam.derive("robots/ur5.yaml")
    rep = json.loads(cli("derive", "robots/ur5.yaml", "--format", "json").output)
    assert rep["schema"] == "minparam.derive/1" and list(rep)[0] == "schema"
    assert {**rep, "elapsed_s": 0} == {**b.to_dict(), "elapsed_s": 0}
    table = cli("derive", "robots/ur5.yaml").output
    assert b.table().rsplit("elapsed", 1)[0] == table.rsplit("elapsed", 1)[0]
    md = cli("derive", "robots/ur5.yaml", "--format", "markdown").output
    assert b.markdown() in md
    tex = cli("derive", "robots/ur5.yaml", "--format", "latex").output
    assert tex.count(r"\\") == rep["n_base"] - 1
    assert r"\begin{align*}" in tex and r"\end{align*}" in tex


def test_urdf_states_its_gravity_and_maps_names():
    rep = json.loads(cli("derive", "robots/iiwa14.urdf", "--format", "json").output)
    assert rep["gravity"] == [0.0, 0.0, -9.81] and rep["gravity_source"] == "default"
    assert rep["links"][0]["joint"] == "iiwa_joint_1" and rep["links"][0]["link"] == "iiwa_link_1"
    rep2 = json.loads(cli("derive", "robots/iiwa14.urdf", "--gravity", "0,0,-1", "--format", "json").output)
    assert rep2["gravity"] == [0.0, 0.0, -1.0] and rep2["gravity_source"] == "cli"
    r = cli("derive", "robots/iiwa14.urdf")
    assert "[default]" in r.output


def test_folder_jsonl_gives_one_object_per_robot():
    from conftest import CLOSED_FILES, ROBOT_FILES

    r = cli("derive", "robots", "--format", "jsonl")
    assert r.exit_code == 0, r.output
    lines = [json.loads(ln) for ln in r.output.strip().splitlines()]
    robots = [ln for ln in lines if "n_base" in ln]
    assert len(robots) == len(ROBOT_FILES) + len(CLOSED_FILES)
    assert {ln["source"] for ln in robots} == {f"robots/{p.name}" for p in ROBOT_FILES + CLOSED_FILES}


def test_batch_keeps_going_past_a_failed_robot_and_exits_non_zero(tmp_path):
    shutil.copy("robots/planar2r.yaml", tmp_path / "a.yaml")
    (tmp_path / "b.yaml").write_text("convention: dh\njoints: []\n")
    shutil.copy("robots/scara.yaml", tmp_path / "c.yaml")
    r = cli("derive", tmp_path, "--jobs", "2")
    assert r.exit_code == 2
    assert r.output.count(" ok") >= 2
    assert "error" in r.output and "b.yaml" in r.output


def test_output_file_is_written(tmp_path):
    out = tmp_path / "puma.json"
    r = cli("derive", "robots/puma560.yaml", "-f", "json", "-o", out)
    assert r.exit_code == 0 and r.output == ""
    assert json.loads(out.read_text())["n_base"] == 36


def test_check_validates_a_folder():
    r = cli("check", "robots")
    assert r.exit_code == 0, r.output
    assert "puma560.yaml" in r.output


def test_console_script_runs_as_a_real_process():
    exe = shutil.which("minparam")
    cmd = [exe] if exe else [sys.executable, "-m", "minparam_cli"]
    p = subprocess.run(cmd + ["derive", "robots/planar2r.yaml", "-f", "json"], capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    assert json.loads(p.stdout)["n_base"] == 6
    p = subprocess.run(cmd + ["derive", "robots/does-not-exist.yaml"], capture_output=True, text=True, timeout=120)
    assert p.returncode == 2 and p.stderr.count("\n") == 1 and "Traceback" not in p.stderr
