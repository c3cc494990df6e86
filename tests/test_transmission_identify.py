"""Motor-side data (issue 16, points 2, 6 and 7): simulate --side motor, identify --side motor,
the coupled-motor effects of the diagnosis, currents with declared drive gains."""

from __future__ import annotations

import json

import numpy as np
import pytest
import yaml
from conftest import ROBOTS, cli as run, cli_ok as ok


TRUE_MOTOR = {"Fcm6": 0.06, "Fvm6": 6e-4, "Iam6": 1e-5}
GAINS = [0.8, 0.9, 1.1, 0.7, 1.3, 0.6]




def tx40_variant(tmp_path, name, motor_columns=True, gains=None):
    doc = yaml.safe_load((ROBOTS / "tx40.yaml").read_text())
    tr = doc["transmission"]
    if not motor_columns:
        for k in ("motor_friction", "motor_inertia", "motors"):
            tr.pop(k)
    if gains is not None:
        tr["drive_gains"] = gains
    path = tmp_path / name
    path.write_text(yaml.safe_dump(doc))
    return path


def simulate(tmp_path, robot, out, *extra):
    args = ["simulate", robot, "--effects", "coulomb,viscous", "--noise", "0.01", "--duration", "12", "--seed", "1", "-q",
            "-o", tmp_path / out, "--motor-params", ",".join(f"{k}={v}" for k, v in TRUE_MOTOR.items()), *extra]
    ok(*args)
    return tmp_path / out


def identify(robot, data, *extra) -> dict:
    r = ok("identify", robot, data, "--friction", "coulomb,viscous", "-q", "-f", "json", *extra)
    return json.loads(r.output)


@pytest.fixture(scope="module")
def motor_data(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("motor")
    return tmp, simulate(tmp, ROBOTS / "tx40.yaml", "m.csv", "--side", "motor"), simulate(tmp, ROBOTS / "tx40.yaml", "j.csv")


def test_motor_side_data_recover_motor6_friction_and_inertia(motor_data):
    _, motor_csv, _ = motor_data
    r = identify(ROBOTS / "tx40.yaml", motor_csv, "--side", "motor", "--no-diagnose")
    p = r["parameters"]
    assert p["Fcm6"]["value"] == pytest.approx(TRUE_MOTOR["Fcm6"], rel=0.02)
    assert p["Fvm6"]["value"] == pytest.approx(TRUE_MOTOR["Fvm6"], rel=0.02)
    assert p["Iam6"]["value"] == pytest.approx(TRUE_MOTOR["Iam6"], rel=0.03)
    # motor 6 on joints 5 and 6: the CSV's motor angle 6 is 32 (q5 + q6) (zero offsets only on 2, 3)
    motor = np.loadtxt(motor_csv, delimiter=",", skiprows=1, max_rows=50)
    joint = np.loadtxt(motor_data[2], delimiter=",", skiprows=1, max_rows=50)
    np.testing.assert_allclose(motor[:, 6], 32 * (joint[:, 5] + joint[:, 6]), rtol=1e-12)
    np.testing.assert_allclose(motor[:, 2], 32 * (joint[:, 2] + np.pi / 2), rtol=1e-12)


def test_motor_side_equals_joint_side(motor_data):
    """The same simulation read on the motor side (converted by identify) and on the joint side."""
    _, motor_csv, joint_csv = motor_data
    a = identify(ROBOTS / "tx40.yaml", motor_csv, "--side", "motor", "--no-diagnose")["parameters"]
    b = identify(ROBOTS / "tx40.yaml", joint_csv, "--no-diagnose")["parameters"]
    assert a.keys() == b.keys()
    for k in a:
        assert a[k]["value"] == pytest.approx(b[k]["value"], rel=1e-6, abs=1e-9), k


def test_saved_model_evaluates_motor_side_data(tmp_path, motor_data):
    """--save-model records the conversion: evaluate reads the motor-side file as identify did."""
    _, motor_csv, _ = motor_data
    model = tmp_path / "m.json"
    r = identify(ROBOTS / "tx40.yaml", motor_csv, "--side", "motor", "--no-diagnose", "--save-model", model)
    saved = json.loads(model.read_text())
    assert saved["data"]["motor_side"]["matrix"][5][4] == 32
    e = json.loads(ok("evaluate", model, motor_csv, "-f", "json").output)
    assert e["pooled"]["relative_error"] < 0.01, e["pooled"]
    assert r["test"]["final"]["relative_error"] < 0.01


def test_diagnosis_finds_coupled_motor_friction(tmp_path, motor_data):
    """Without declared motor columns, the diagnosis adds the coupled motor's viscous friction on joints 5 and 6."""
    _, motor_csv, _ = motor_data
    robot = tx40_variant(tmp_path, "plain.yaml", motor_columns=False)
    r = identify(robot, motor_csv, "--side", "motor", "--effects", "motor_coulomb,motor_viscous,motor_inertia,coulomb")
    added = [(s["effect"], tuple(s["joints"])) for s in r["steps"][1:]]
    assert ("motor_viscous", (5, 6)) in added or ("motor_coulomb", (5, 6)) in added, added
    assert all(e.startswith("motor_") for e, _ in added), added


def test_currents_with_declared_gains(tmp_path, motor_data):
    _, _, joint_csv = motor_data
    robot = tx40_variant(tmp_path, "gains.yaml", gains=GAINS)
    cur = simulate(tmp_path, robot, "c.csv", "--side", "motor", "--current")
    a = identify(robot, cur, "--side", "motor", "--current", "--no-diagnose")
    b = identify(ROBOTS / "tx40.yaml", joint_csv, "--no-diagnose")
    for k in ("Fcm6", "Fv1", "ZZR1"):
        assert a["parameters"][k]["value"] == pytest.approx(b["parameters"][k]["value"], rel=1e-6)
    assert not any("arbitrary" in f for f in a["flags"])  # without gains: tests/test_payload_gains.py


@pytest.mark.parametrize("args,needle", [
    (("identify", ROBOTS / "puma560.yaml", "DATA", "--side", "motor"), "needs a transmission"),
    # joint-side currents are read now (tests/test_joint_currents.py); simulating them needs gains
    (("simulate", ROBOTS / "tx40.yaml", "--current", "-o", "OUT"), "--current needs drive gains"),
    (("simulate", ROBOTS / "tx40.yaml", "--side", "motor", "--current", "-o", "OUT"), "needs drive_gains"),
    (("simulate", ROBOTS / "tx40.yaml", "--motor-params", "Fcm5=1", "-o", "OUT"), "not a motor-side parameter"),
    (("simulate", ROBOTS / "tx40.yaml", "--motor-params", "Fcm6=abc", "-o", "OUT"), "not a finite number"),
])
def test_bad_side_options_are_one_line_exit_2(tmp_path, motor_data, args, needle):
    args = [motor_data[2] if a == "DATA" else tmp_path / "o.csv" if a == "OUT" else a for a in args]
    r = run(*args)
    assert r.exit_code == 2, r.output
    lines = [ln for ln in r.output.strip().splitlines() if ln.strip()]
    assert len(lines) == 1 and needle in lines[0] and "Traceback" not in r.output, r.output
