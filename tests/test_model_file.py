"""identify --save-model and minparam evaluate: the model file, its round trip, its refusals."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
from conftest import ROOT, cli, cli_ok

pytest.importorskip("cvxpy")

ROBOT = ROOT / "robots" / "puma560_mdh.yaml"


def refused(*args, needle: str = "") -> str:
    """Exit 2 with one line (no usage text, no traceback) containing ``needle``."""
    r = cli(*args)
    lines = [ln for ln in r.output.strip().splitlines() if ln.strip()]
    assert r.exit_code == 2 and len(lines) == 1 and "Traceback" not in r.output, r.output
    assert needle in lines[0], lines[0]
    return lines[0]


def split_csv(src, first, second):
    """The record's first and second halves (by rows) as two files: one motion, one robot."""
    text = src.read_text().splitlines()
    half = 1 + (len(text) - 1) // 2
    first.write_text("\n".join(text[:half]) + "\n")
    second.write_text("\n".join([text[0]] + text[half:]) + "\n")


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """A simulated PUMA with friction the description lacks: identify --physical on the first half,
    the second half as its --test file, the model saved."""
    d = tmp_path_factory.mktemp("model")
    sim, fit, test, model = d / "sim.csv", d / "fit.csv", d / "test.csv", d / "model.json"
    cli_ok("simulate", ROBOT, "--effects", "coulomb,viscous", "--noise", 0.02, "--duration", 30, "--seed", 3, "-o", sim, "-q")
    split_csv(sim, fit, test)
    report = json.loads(cli_ok("identify", ROBOT, fit, "--test", test, "--physical", "--save-model", model, "-f", "json", "-q").output)
    return {"dir": d, "fit": fit, "test": test, "model": model, "report": report}


def close(a, b, rtol=1e-9):
    return np.allclose(np.asarray(a, dtype=float), np.asarray(b, dtype=float), rtol=rtol, atol=0)


def test_evaluate_on_the_test_file_reproduces_identify_test_figures(run):
    """evaluate reads the --test file whole with the model's settings, as identify did: its figures are
    identify's test figures to 1e-9, for the unconstrained and for the physical parameters."""
    rep = run["report"]
    assert rep["effects"], "the diagnosis should have added the friction"
    for which, expected in (("fit", rep["test"]["final"]), ("physical", rep["physical"]["test"]["test1"])):
        ev = json.loads(cli_ok("evaluate", run["model"], run["test"], "--model", which, "-f", "json").output)
        got = ev["pooled"]
        assert ev["model"] == which and ev["files"][0]["samples"] == rep["roles"]["test"][0]["samples"]
        for key in ("rms_total", "relative_error"):
            assert close(got[key], expected[key]), (which, key, got[key], expected[key])
        assert close(got["rms_per_joint"], expected["rms_per_joint"])


def test_pooled_figures_sum_the_files_squares(run):
    one = json.loads(cli_ok("evaluate", run["model"], run["fit"], "-f", "json").output)["pooled"]
    two = json.loads(cli_ok("evaluate", run["model"], run["test"], "-f", "json").output)["pooled"]
    both = json.loads(cli_ok("evaluate", run["model"], run["fit"], run["test"], "-f", "json").output)
    assert len(both["files"]) == 2 and both["model"] == "physical"  # the default when the model has one
    rows = one["samples"] + two["samples"]
    ms = (np.square(one["rms_per_joint"]) * one["samples"] + np.square(two["rms_per_joint"]) * two["samples"]) / rows
    assert both["pooled"]["samples"] == rows and close(both["pooled"]["rms_per_joint"], np.sqrt(ms))


def test_predictions_csv_holds_measured_and_predicted_torques(run):
    out = run["dir"] / "pred.csv"
    ev = json.loads(cli_ok("evaluate", run["model"], run["test"], "--model", "fit", "--predictions", out, "-f", "json").output)
    header = out.read_text().splitlines()[0].split(",")
    assert header == ["t"] + [f"tau_meas{j}" for j in range(1, 7)] + [f"tau_pred{j}" for j in range(1, 7)]
    a = np.loadtxt(out, delimiter=",", skiprows=1)
    assert len(a) == ev["pooled"]["samples"]
    rms = np.sqrt(np.mean((a[:, 1:7] - a[:, 7:13]) ** 2, axis=0))
    assert close(rms, ev["pooled"]["rms_per_joint"], rtol=1e-8)  # 12 digits written
    refused("evaluate", run["model"], run["test"], run["fit"], "--predictions", out, needle="--predictions writes one file")


def test_model_file_contents_and_json_round_trip(run):
    from minparam_cli.model.file import dumps
    from minparam_cli.model.parse import parse_model

    text = run["model"].read_text()
    doc = json.loads(text)
    assert doc["format"] == "minparam-model" and doc["version"] == 2
    assert doc["robot"]["path"] == str(ROBOT) and len(doc["robot"]["sha256"]) == 64
    assert doc["load"] == {"friction": [], "rotor_inertia": False, "gravity": None, "coulomb_smoothing": 0.0,
                           "mimic": "coupled", "floating_base": False}
    rep = run["report"]
    assert doc["parameters"]["names"] == list(rep["parameters"])
    assert close(doc["parameters"]["theta"], [v["value"] for v in rep["parameters"].values()], rtol=0)
    assert {t["effect"] for t in doc["design"]["terms"]} == {e["effect"] for e in rep["effects"]}
    # every saved effect says its evidence, as the report does (ΔBIC_eff on N_eff effective samples)
    assert [t["evidence"] for t in doc["design"]["terms"]] == [e["evidence"] for e in rep["effects"]]
    assert all(t["evidence"]["n_eff"] > 0 and "delta_bic_eff" in t["evidence"] for t in doc["design"]["terms"])
    assert doc["physical"]["phi_names"] == list(rep["physical"]["phi"])
    assert doc["figures"]["test"]["final"] == rep["test"]["final"]
    assert doc["data"]["cutoff_hz"] == 5.0 and doc["data"]["columns"] == {}
    again = parse_model(text, "m")
    assert dumps(again) == text  # JSON out -> in -> out


def _tampered(run, name, edit) -> str:
    doc = json.loads(run["model"].read_text())
    edit(doc)
    p = run["dir"] / name
    p.write_text(json.dumps(doc))
    return p


@pytest.mark.parametrize("edit, needle", [
    (lambda d: d.pop("base"), "missing key 'base'"),
    (lambda d: d["base"].pop("kept"), "base: missing key 'kept'"),
    (lambda d: d.update(version=7), "format version 7 is not supported"),
    (lambda d: d.update(format="other"), "not a minparam model file"),
    (lambda d: d["parameters"]["theta"].pop(), "parameters.theta: expected a list of"),
    (lambda d: d["design"]["terms"][0].update(effect="warp"), "unknown effect 'warp'"),
    (lambda d: d["design"]["terms"][0].update(evidence=3), "design.terms[0].evidence: expected a JSON object or null"),
    (lambda d: d["robot"].update(sha256="xyz"), "robot.sha256: expected 64 lower-case hex digits"),
    (lambda d: d["data"].update(cutoff_hz="fast"), "data.cutoff_hz: expected a finite number"),
    (lambda d: d["base"].update(kept=d["base"]["kept"][1:] + [d["base"]["kept"][0] + 1], names=d["base"]["names"]),
     "keeps other base columns"),
])
def test_a_broken_model_file_is_one_line_exit_2(run, edit, needle):
    refused("evaluate", _tampered(run, "bad.json", edit), run["test"], needle=needle)


def test_not_json_and_missing_files(run, tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text("{ not json")
    refused("evaluate", bad, run["test"], needle="not a JSON document")
    refused("evaluate", tmp_path / "none.json", run["test"], needle="cannot read the model file")
    refused("evaluate", run["model"], tmp_path / "none.csv", needle="data file not found")
    moved = _tampered(run, "moved.json", lambda d: d["robot"].update(path=str(tmp_path / "gone.yaml")))
    refused("evaluate", moved, run["test"], needle="not found (give it with --robot)")


def test_a_model_is_refused_on_another_robot_or_a_changed_file(run, tmp_path):
    line = refused("evaluate", run["model"], run["test"], "--robot", ROOT / "robots" / "puma560.yaml", needle="was made for")
    sha = json.loads(run["model"].read_text())["robot"]["sha256"]
    assert f"{run['model']} was made for {ROBOT} (sha256 {sha[:12]}…), not for {ROOT / 'robots' / 'puma560.yaml'}" in line
    # the same robot under another name is accepted: the bytes decide
    copy = tmp_path / "copy.yaml"
    shutil.copy(ROBOT, copy)
    cli_ok("evaluate", run["model"], run["test"], "--robot", copy)
    moved = _tampered(run, "changed.json", lambda d: d["robot"].update(path=str(copy)))
    copy.write_text(copy.read_text() + "\n# edited\n")
    refused("evaluate", moved, run["test"], needle="has changed since")


def test_data_with_the_wrong_joint_count(run, tmp_path):
    data = tmp_path / "planar.csv"
    cli_ok("simulate", ROOT / "robots" / "planar2r.yaml", "-o", data, "--duration", 2, "-q")
    refused("evaluate", run["model"], data, needle="the data have 2 joints")


def test_physical_parameters_need_a_physical_model(tmp_path, run):
    model = tmp_path / "m.json"
    cli_ok("identify", ROBOT, run["fit"], "--test", run["test"], "--no-diagnose", "--save-model", model, "-q")
    assert json.loads(model.read_text())["physical"] is None
    refused("evaluate", model, run["test"], "--model", "physical", needle="has no physical fit")
    assert json.loads(cli_ok("evaluate", model, run["test"], "-f", "json").output)["model"] == "fit"


def test_exports_need_physical_and_yaml_needs_a_table(tmp_path, run):
    refused("identify", ROBOT, run["fit"], "--export-urdf", tmp_path / "x.urdf", needle="--export-urdf needs --physical")
    refused("identify", ROBOT, run["fit"], "--export-yaml", tmp_path / "x.yaml", needle="--export-yaml needs --physical")
    refused("identify", ROOT / "robots" / "ur5.urdf", run["fit"], "--physical", "--export-yaml", tmp_path / "x.yaml",
            needle="--export-yaml needs a YAML (DH/MDH) robot")
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("kind", ["fifo", "device", "folder"])
def test_evaluate_refuses_a_model_that_is_not_a_regular_file(tmp_path, kind):
    """A FIFO given as the model used to wait for a writer forever, /dev/zero never ended."""
    import os
    import subprocess
    import sys

    model = {"fifo": tmp_path / "model.json", "device": "/dev/zero", "folder": tmp_path}[kind]
    if kind == "fifo":
        os.mkfifo(model)
    data = tmp_path / "d.csv"
    data.write_text("t,q1,q2,dq1,dq2,tau1,tau2\n0,0,0,0,0,0,0\n")
    r = subprocess.run([sys.executable, "-m", "minparam_cli", "evaluate", str(model), str(data)],
                       capture_output=True, text=True, timeout=20)
    assert r.returncode == 2 and "expected a regular file" in r.stderr and r.stderr.count("\n") == 1


def test_a_version_1_model_file_still_evaluates(run, tmp_path):
    """A model saved before evidence was kept (format version 1, no evidence) gives the same predictions."""
    def v1(doc):
        doc["version"] = 1
        for t in doc["design"]["terms"]:
            t.pop("evidence")
    old = _tampered(run, "v1.json", v1)
    new = json.loads(cli_ok("evaluate", run["model"], run["test"], "-f", "json").output)
    again = json.loads(cli_ok("evaluate", old, run["test"], "-f", "json").output)
    assert again["files"] == new["files"]


def test_a_version_1_spring_keeps_its_columns(run):
    """Version 1's spring had the columns q, sin q, cos q: such a file is read with the legacy effect (the
    same columns, the same parameter names), never as K·(q − q₀); version 2 saves the new spring."""
    from minparam_cli.dynamics.effects import EFFECT_IDS, EFFECTS, LEGACY_SPRING, Signals
    from minparam_cli.model.parse import parse_model

    doc = json.loads(run["model"].read_text())
    doc["version"] = 1
    for t in doc["design"]["terms"]:
        t.pop("evidence")
    doc["design"]["terms"].append({"effect": "spring", "joints": [2], "hyper": None})
    doc["parameters"]["names"] += ["Kq2", "Ks2", "Kc2"]
    doc["parameters"]["theta"] += [0.1, 0.2, 0.3]
    doc["parameters"]["std_percent"] += [None, None, None]
    doc["physical"]["theta"] += [0.1, 0.2, 0.3]
    m = parse_model(json.dumps(doc), "v1")
    spring = m.terms[-1]
    assert spring.effect == LEGACY_SPRING and spring.names() == ["Kq2", "Ks2", "Kc2"]
    assert m.term_evidence(len(m.terms) - 1) is None
    q = np.linspace(-1, 2, 7)[:, None]
    s = Signals(q[:, 0], q, q, q)
    assert np.allclose(EFFECTS[LEGACY_SPRING].columns(s, 0), np.column_stack([q, np.sin(q), np.cos(q)]))
    assert np.allclose(EFFECTS["spring"].columns(s, 0), np.column_stack([q, np.ones_like(q)]))
    assert LEGACY_SPRING not in EFFECT_IDS  # neither searched nor injected
