"""Currents without a transmission (issue 31, point 5): joint angles with currents, tau_j = k_j i_j.

The PUMA 560 (MDH, the file's inertias) with per-joint drive gains declared at the top of its YAML:
``simulate --current`` writes i_j = tau_j / k_j on the joint side, and ``identify --current`` reads them
back through the declared gains, through ``--drive-gains``, or identifies the gains from a second
recording with a known payload mass (Gautier & Briot 2014, as the motor-side path does)."""

from __future__ import annotations

import json

import numpy as np
import pytest
import yaml
from conftest import ROBOTS, cli as run, cli_ok as ok

GAINS = [8.0, 12.0, 6.5, 1.5, 1.2, 0.9]
MASS, COM = 2.8, (0.02, -0.01, 0.05)
COMMON = ["--noise", "0.02", "--duration", "10", "-q"]


@pytest.fixture(scope="module")
def robots(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("joint_currents")
    doc = yaml.safe_load((ROBOTS / "puma560_mdh.yaml").read_text())
    doc["drive_gains"] = GAINS
    with_gains = tmp / "puma_gains.yaml"
    with_gains.write_text(yaml.safe_dump(doc))
    doc.pop("drive_gains")
    without = tmp / "puma.yaml"
    without.write_text(yaml.safe_dump(doc))
    return tmp, with_gains, without


def simulate(robot, out, *extra):
    ok("simulate", robot, *COMMON, *extra, "-o", out)
    return out


def identify(robot, data, *extra) -> dict:
    return json.loads(ok("identify", robot, data, "--no-diagnose", "-q", "-f", "json", *extra).output)


def base_truth(phi) -> dict:
    """The base parameters K·φ of the derive stage (the PUMA's base set), for the simulated φ."""
    from minparam_cli.base.qr import derive_qr
    from minparam_cli.robot import DeriveOptions, load_chain

    _, chain = load_chain(ROBOTS / "puma560_mdh.yaml", DeriveOptions())
    base = derive_qr(chain, seed=0)
    return dict(zip(base.base_names, base.K @ np.asarray(phi), strict=True))


def test_simulated_currents_are_the_torques_over_the_gains(robots):
    tmp, with_gains, _ = robots
    cur = np.genfromtxt(simulate(with_gains, tmp / "c.csv", "--seed", "4", "--current", "--truth", tmp / "c.json"),
                        delimiter=",", names=True)
    tau = np.genfromtxt(simulate(with_gains, tmp / "t.csv", "--seed", "4"), delimiter=",", names=True)
    for j, k in enumerate(GAINS):
        np.testing.assert_allclose(cur[f"tau{j + 1}"] * k, tau[f"tau{j + 1}"], rtol=1e-12, atol=1e-12)
        np.testing.assert_array_equal(cur[f"q{j + 1}"], tau[f"q{j + 1}"])
    assert json.loads((tmp / "c.json").read_text())["current"] == {"side": "joint", "drive_gains": GAINS}


def test_declared_gains_or_the_option_read_currents_as_the_torques(robots):
    """Currents through the YAML's drive_gains, or through --drive-gains on a robot without them, give
    the torque file's fit (an identity: same trajectory, same noise)."""
    tmp, with_gains, without = robots
    cur = simulate(with_gains, tmp / "c5.csv", "--seed", "5", "--current")
    tau = simulate(with_gains, tmp / "t5.csv", "--seed", "5")
    ref = identify(without, tau)
    declared = identify(with_gains, cur, "--current")
    option = identify(without, cur, "--current", "--drive-gains", ",".join(map(str, GAINS)))
    for r, source in ((declared, "drive_gains"), (option, "--drive-gains")):
        assert r["current"] == {"side": "joint", "drive_gains": GAINS, "gains_source": source, "torque_unit_arbitrary": False}
        assert not any("arbitrary" in f for f in r["flags"])
        for name, p in ref["parameters"].items():
            assert r["parameters"][name]["value"] == pytest.approx(p["value"], rel=1e-6, abs=1e-9), name


@pytest.mark.parametrize("seed", [1, 3, 5])
def test_gains_and_base_parameters_from_a_known_payload_mass(robots, seed):
    """simulate --current (declared gains) -> identify --current --payload-data --payload-mass on a robot
    without gains: each gain within 3σ of the declared one; the base parameters in N·m (the scale the
    mass fixed) match the simulated ones."""
    tmp, with_gains, without = robots
    a = simulate(with_gains, tmp / f"a{seed}.csv", "--seed", seed, "--current", "--truth", tmp / f"a{seed}.json")
    b = simulate(with_gains, tmp / f"b{seed}.csv", "--seed", seed + 1, "--current", "--payload-mass", MASS,
                 "--payload-com", ",".join(map(str, COM)))
    r = identify(without, a, "--current", "--payload-data", b, "--payload-mass", MASS)
    assert r["current"] == {"side": "joint", "drive_gains": None, "gains_source": "payload", "torque_unit_arbitrary": False}
    assert not any("arbitrary" in f for f in r["flags"])
    p = r["payload"]
    for k, g in enumerate(GAINS):
        e = p["drive_gains"][f"motor {k + 1}"]
        assert abs(e["value"] - g) < 3 * e["std"], (seed, k, e, g)
    truth = base_truth(json.loads((tmp / f"a{seed}.json").read_text())["phi"])
    est = p["base_parameters"]
    assert set(est) == set(truth)
    names = sorted(truth)
    x, t = np.array([est[k]["value"] for k in names]), np.array([truth[k] for k in names])
    assert float(x @ t / (t @ t)) == pytest.approx(1.0, abs=1e-3)  # the common scale: N·m, not the currents' unit
    z = [(est[k]["value"] - truth[k]) / est[k]["std"] for k in names]
    assert max(map(abs, z)) < 3, sorted(zip(z, names, strict=True), key=lambda v: -abs(v[0]))[:3]
    for name, value in zip(("MX", "MY", "MZ"), COM, strict=True):
        assert p["parameters"][name]["value"] == pytest.approx(MASS * value, rel=0.03, abs=1e-3)


def test_currents_without_gains_or_payload_run_and_flag_the_unit(robots):
    tmp, with_gains, without = robots
    cur = simulate(with_gains, tmp / "c6.csv", "--seed", "6", "--current")
    r = identify(without, cur, "--current")
    assert r["current"] == {"side": "joint", "drive_gains": None, "gains_source": None, "torque_unit_arbitrary": True}
    assert any("torque unit is arbitrary" in f for f in r["flags"])
    text = ok("identify", without, cur, "--no-diagnose", "-q", "--current").output
    assert "torque unit is arbitrary" in text
    # unit gains: the fit is in the currents' unit, not the torques' (ZZR1, on joint 1 only, near 1/k1 of
    # it; not exactly: the other joints' rows, in their own units, share the fit)
    x, ref = r["parameters"]["ZZR1"]["value"], identify(with_gains, cur, "--current")["parameters"]["ZZR1"]["value"]
    assert abs(x - ref / GAINS[0]) < 0.1 * abs(x - ref)


def test_the_api_takes_drive_gains_as_the_cli_does(robots):
    import minparam

    tmp, with_gains, without = robots
    cur = simulate(with_gains, tmp / "c7.csv", "--seed", "7", "--current")
    api = minparam.identify(without, cur, diagnose=False, current=True, drive_gains=GAINS).to_dict()
    cli = identify(without, cur, "--current", "--drive-gains", ",".join(map(str, GAINS)))
    assert api["current"] == cli["current"] and api["parameters"] == cli["parameters"]
    sim = minparam.simulate(without, current=True, drive_gains=GAINS, duration=2, seed=7)
    ref = minparam.simulate(without, duration=2, seed=7)
    np.testing.assert_allclose(sim.tau * np.asarray(GAINS), ref.tau, rtol=1e-12)


def bad_yaml(tmp, name, gains):
    doc = yaml.safe_load((ROBOTS / "puma560_mdh.yaml").read_text())
    doc["drive_gains"] = gains
    path = tmp / name
    path.write_text(yaml.safe_dump(doc))
    return path


@pytest.mark.parametrize("case,needle", [
    ("yaml_count", "expected 6 numbers (one per joint), got 3"),
    ("yaml_zero", "drive gain of joint 2 is 0"),
    ("yaml_negative", "drive gain of joint 1 is -1"),
    ("option_count", "--drive-gains: expected 6 gains"),
    ("option_zero", "expected positive gains"),
    ("option_text", "expected comma-separated numbers"),
    ("option_without_current", "--drive-gains needs --current"),
    ("option_motor_side", "--drive-gains are joint-side gains"),
    ("payload_without_mass", "--payload-mass is needed"),
    ("simulate_without_gains", "--current needs drive gains"),
    ("simulate_option_count", "--drive-gains: expected 6 gains"),
])
def test_bad_inputs_are_one_line_exit_2(robots, tmp_path, case, needle):
    tmp, with_gains, without = robots
    data = tmp / "bad_data.csv"
    if not data.exists():
        simulate(with_gains, data, "--seed", "8", "--current", "--duration", "2")
    out = tmp_path / "out.csv"
    args = {
        "yaml_count": ("identify", bad_yaml(tmp_path, "c.yaml", [1, 2, 3]), data, "--current"),
        "yaml_zero": ("identify", bad_yaml(tmp_path, "z.yaml", [1, 0, 3, 4, 5, 6]), data, "--current"),
        "yaml_negative": ("simulate", bad_yaml(tmp_path, "n.yaml", [-1, 2, 3, 4, 5, 6]), "--current", "-o", out),
        "option_count": ("identify", without, data, "--current", "--drive-gains", "1,2,3,4,5,6,7"),
        "option_zero": ("identify", without, data, "--current", "--drive-gains", "1,2,3,4,5,0"),
        "option_text": ("identify", without, data, "--current", "--drive-gains", "1,2,x"),
        "option_without_current": ("identify", without, data, "--drive-gains", "1,2,3,4,5,6"),
        "option_motor_side": ("identify", without, data, "--current", "--side", "motor", "--drive-gains", "1,2,3,4,5,6"),
        "payload_without_mass": ("identify", without, data, "--current", "--payload-data", data),
        "simulate_without_gains": ("simulate", without, "--current", "-o", out),
        "simulate_option_count": ("simulate", without, "--current", "--drive-gains", "1,2", "-o", out),
    }[case]
    r = run(*args, "-q") if args[0] == "simulate" else run(*args, "--no-diagnose", "-q")
    assert r.exit_code == 2, r.output
    lines = [ln for ln in r.output.strip().splitlines() if ln.strip()]
    assert len(lines) == 1 and needle in lines[0] and "Traceback" not in r.output, r.output
    assert not out.exists()


def test_saved_model_reads_joint_currents_through_the_gains(robots):
    """--save-model records the joint-side conversion (N = I, the gains): evaluate reads a current file
    of another seed through them, as the torque model reads that seed's torque file."""
    tmp, with_gains, without = robots
    model, model_t = tmp / "m9.json", tmp / "m9t.json"
    identify(without, simulate(with_gains, tmp / "c9.csv", "--seed", "9", "--current"), "--current",
             "--drive-gains", ",".join(map(str, GAINS)), "--save-model", model)
    identify(without, simulate(with_gains, tmp / "t9.csv", "--seed", "9"), "--save-model", model_t)
    assert json.loads(model.read_text())["data"]["motor_side"]["gains"] == GAINS
    cur = simulate(with_gains, tmp / "c10.csv", "--seed", "10", "--current")
    tau = simulate(with_gains, tmp / "t10.csv", "--seed", "10")
    a = json.loads(ok("evaluate", model, cur, "-f", "json").output)["pooled"]
    b = json.loads(ok("evaluate", model_t, tau, "-f", "json").output)["pooled"]
    assert a["relative_error"] < 0.01
    assert a["rms_per_joint"] == pytest.approx(b["rms_per_joint"], rel=1e-5)
