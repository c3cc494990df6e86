"""Drive gains and a known payload (issue 16, points 3, 4, 6 and 7): two simulated recordings of the
PUMA 560 (MDH, with the file's inertias) behind a coupled transmission, one with a payload."""

from __future__ import annotations

import json

import pytest
import yaml
from conftest import ROBOTS, cli as run, cli_ok as ok


GAINS = [0.8, 0.9, 1.1, 0.7, 1.3, 0.6]
MASS, COM, INERTIA = 2.8, (0.02, -0.01, 0.05), (0.01, 0.0, 0.0, 0.012, 0.0, 0.008)




@pytest.fixture(scope="module")
def recordings(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("payload")
    doc = yaml.safe_load((ROBOTS / "puma560_mdh.yaml").read_text())
    doc["transmission"] = {"ratios": [62.6, 107.8, 53.7, 76.0, 71.9, 76.7], "coupling": [[6, 5, 13.25]], "drive_gains": GAINS}
    with_gains = tmp / "puma_gains.yaml"
    with_gains.write_text(yaml.safe_dump(doc))
    doc["transmission"].pop("drive_gains")
    without = tmp / "puma.yaml"
    without.write_text(yaml.safe_dump(doc))
    common = ["--noise", "0.02", "--duration", "10", "-q"]
    payload = ["--payload-mass", MASS, "--payload-com", ",".join(map(str, COM)), "--payload-inertia", ",".join(map(str, INERTIA))]
    files = {}
    for name, extra in (("a_cur", ["--seed", "1", "--side", "motor", "--current"]),
                        ("b_cur", ["--seed", "2", "--side", "motor", "--current", *payload]),
                        ("a", ["--seed", "1"]), ("b", ["--seed", "2", *payload])):
        files[name] = tmp / f"{name}.csv"
        ok("simulate", with_gains, *common, *extra, "-o", files[name])
    return tmp, with_gains, without, files


def identify(robot, data, *extra) -> dict:
    return json.loads(ok("identify", robot, data, "--no-diagnose", "-q", "-f", "json", *extra).output)


def test_gains_from_currents_and_a_known_payload_mass(recordings):
    _, _, without, f = recordings
    r = identify(without, f["a_cur"], "--side", "motor", "--current", "--payload-data", f["b_cur"], "--payload-mass", MASS)
    p = r["payload"]
    for k, g in enumerate(GAINS):
        e = p["drive_gains"][f"motor {k + 1}"]
        assert e["value"] == pytest.approx(g, rel=0.02)
        assert 0 < e["std"] < 0.02 * g
        # the currents are fitted, not used as regressors: no errors-in-variables bias beyond σ
        assert abs(e["value"] - g) < 5 * e["std"], (k, e, g)
    assert p["method"].startswith("Gauss–Newton")
    for name, value in zip(("MX", "MY", "MZ"), COM, strict=True):
        assert p["parameters"][name]["value"] == pytest.approx(MASS * value, rel=0.03, abs=1e-3)
    assert not any("arbitrary" in f for f in r["flags"])  # the known mass fixed the scale
    assert "payload" not in json.dumps(r["steps"])  # never a missing effect


def test_payload_mass_and_com_from_joint_torques(recordings):
    _, robot, _, f = recordings
    r = identify(robot, f["a"], "--payload-data", f["b"])
    p = r["payload"]
    assert p["parameters"]["M"]["value"] == pytest.approx(MASS, rel=0.03)
    assert p["com"] == pytest.approx(list(COM), abs=2e-3)
    assert p["parameters"]["ZZ"]["value"] == pytest.approx(INERTIA[5] + MASS * (COM[0] ** 2 + COM[1] ** 2), rel=0.05)


def test_the_text_report_shows_the_json_reports_payload(recordings):
    """identify's text report (render/payload_text.py) ends with the payload block: the same figures as
    the JSON report of the same run, to the digits it prints."""
    _, robot, _, f = recordings
    p = identify(robot, f["a"], "--payload-data", f["b"])["payload"]
    text = ok("identify", robot, f["a"], "--payload-data", f["b"], "--no-diagnose", "-q").output
    block = text[text.index("\npayload (about the origin of"):].strip().splitlines()
    assert f"{p['samples'][0]} + {p['samples'][1]} samples" in block[0]
    for name, e in p["parameters"].items():
        assert f"  {name:<12} {e['value']:.6g}  (σ {e['std']:.3g}, {e['std_percent']:.3g} %)" in block
    assert "  centre of mass " + ", ".join(f"{c:.4g}" for c in p["com"]) + " m" in block


def test_currents_without_gains_or_mass_say_the_unit_is_arbitrary(recordings):
    _, _, without, f = recordings
    r = identify(without, f["a_cur"], "--side", "motor", "--current")
    assert any("torque unit is arbitrary" in x for x in r["flags"])


def test_bad_payload_inputs_are_one_line_exit_2(recordings, tmp_path):
    _, robot, without, f = recordings
    five = tmp_path / "five.csv"
    lines = f["b"].read_text().splitlines()
    header = lines[0].split(",")
    keep = [i for i, h in enumerate(header) if not h.endswith("6")]
    five.write_text("\n".join(",".join(row.split(",")[i] for i in keep) for row in lines[:200]) + "\n")
    cases = [
        ((robot, f["a"], "--payload-data", five), "the data have 5 joints"),
        ((robot, f["a"], "--payload-data", f["b"], "--payload-mass", "0"), "positive mass"),
        ((robot, f["a"], "--payload-data", f["b"], "--payload-mass", "-2"), "positive mass"),
        ((robot, f["a"], "--payload-mass", "2"), "need --payload-data"),
        ((without, f["a_cur"], "--side", "motor", "--current", "--payload-data", f["b_cur"]), "--payload-mass is needed"),
    ]
    for args, needle in cases:
        r = run("identify", *args, "--no-diagnose", "-q")
        assert r.exit_code == 2, (args, r.output)
        out = [ln for ln in r.output.strip().splitlines() if ln.strip()]
        assert len(out) == 1 and needle in out[0] and "Traceback" not in r.output, (args, r.output)


def test_the_api_gives_the_clis_report_for_motor_side_currents_and_a_payload(recordings):
    """minparam.identify(side=, current=, payload_data=, payload_mass=) is the CLI's run, to the JSON."""
    import minparam

    _, _, without, f = recordings
    cli = identify(without, f["a_cur"], "--side", "motor", "--current", "--payload-data", f["b_cur"], "--payload-mass", MASS)
    api = minparam.identify(without, f["a_cur"], diagnose=False, side="motor", current=True, payload_data=f["b_cur"],
                            payload_mass=MASS).to_dict()

    def untimed(x):
        if isinstance(x, dict):
            return {k: untimed(v) for k, v in x.items() if k != "elapsed_s"}
        return [untimed(v) for v in x] if isinstance(x, list) else x

    assert json.dumps(untimed(api), sort_keys=True) == json.dumps(untimed(cli), sort_keys=True)
    with pytest.raises(minparam.InputError, match="need --payload-data"):
        minparam.identify(without, f["a_cur"], payload_mass=MASS)
