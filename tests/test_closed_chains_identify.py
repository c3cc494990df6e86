"""A closed chain through simulate → identify (issue 35 point 4): the actuated torques of the
parallelogram arm simulated with noise, identified with the usual data roles (fit | selection |
test), recover the base parameters K·φ of the truth; and excite keeps the passive joints inside
their limits."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from minparam_cli.api.derivation import derive_file
from minparam_cli.api.options.derive import DeriveOptions
from minparam_cli.cli.app import app

ROOT = Path(__file__).resolve().parents[1]
ARM = ROOT / "robots" / "parallelogram_arm.yaml"
NOISE = 0.5  # N·m, white


def _cli(*args):
    r = CliRunner().invoke(app, [str(a) for a in args])
    assert r.exit_code == 0, r.output
    return r


@pytest.fixture(scope="module")
def round_trips(tmp_path_factory):
    d = tmp_path_factory.mktemp("closed_rt")
    out = []
    for seed in (1, 2, 3):
        data, truth = d / f"s{seed}.csv", d / f"s{seed}.json"
        _cli("simulate", ARM, "-o", data, "--seed", seed, "--noise", NOISE, "--truth", truth, "-q")
        result = json.loads(_cli("identify", ARM, data, "--seed", seed, "--no-diagnose", "-f", "json").stdout)
        base = derive_file(ARM, DeriveOptions(seed=seed))
        true = dict(zip(base.base_names, base.K @ np.array(json.loads(truth.read_text())["phi"]), strict=True))
        out.append((result, true))
    return out


def test_identify_recovers_the_closed_chains_base_parameters(round_trips):
    """Every base parameter of 3 seeds (54 values) within 3σ of the truth K·φ with the textbook σ (the
    right one for the white noise simulated here); the normalised errors spread as σ says (mean z²
    between 0.3 and 3).  The default HAC σ rests on 12 one-second blocks (identify flags it as
    uncertain by about 20 %): at least 90 % within 3σ and none beyond 4σ."""
    z_text, z_hac = [], []
    for result, true in round_trips:
        assert set(result["parameters"]) == set(true)  # identify's base set is derive's
        for name, p in result["parameters"].items():
            err = p["value"] - true[name]
            z_text.append(err / (abs(p["value"]) * p["std_percent_textbook"] / 100))
            z_hac.append(err / (abs(p["value"]) * p["std_percent"] / 100))
    zt, zh = np.abs(np.array(z_text)), np.abs(np.array(z_hac))
    assert len(zt) == 54
    assert zt.max() <= 3, np.round(np.sort(zt)[-5:], 2)
    assert 0.3 < np.mean(zt**2) < 3
    assert np.mean(zh <= 3) >= 0.9 and zh.max() < 4, np.round(np.sort(zh)[-5:], 2)


def test_the_test_data_error_is_the_noise(round_trips):
    """The test part chose nothing: its RMS is the injected noise (the rigid model is complete)."""
    for result, _ in round_trips:
        assert result["test"]["final"]["rms_total"] == pytest.approx(NOISE, rel=0.1)


def test_excite_keeps_passive_joints_inside_their_limits(tmp_path):
    """With the elbow's passive limits at ±30° (the actuated ranges would let it reach ±64°), the designed
    motion closes the loops at every output sample with both passive joints inside ±30°, and it uses
    that room (the constraint is active, not idle)."""
    from minparam_cli.robot import DeriveOptions as Stage
    from minparam_cli.robot import load_chain
    from minparam_cli.loops.model import closed_model

    tight = tmp_path / "tight.yaml"
    tight.write_text(ARM.read_text().replace("limits: [-100, 100]", "limits: [-30, 30]"))
    out = tmp_path / "exc.csv"
    _cli("excite", tight, "-o", out, "--starts", 1, "--max-iterations", 30, "--harmonics", 3)
    table = np.genfromtxt(out, delimiter=",", names=True)
    q_a = np.stack([table[f"q{k}"] for k in (1, 2, 3)], axis=1)
    desc, chain = load_chain(tight, Stage(), loops=True)
    model = closed_model(desc, chain)
    q, err = model.close_from_reference(q_a)
    assert err.max() < 1e-9
    passive = np.degrees(q[:, list(model.passive)])
    assert np.abs(passive).max() <= 30.0 + 1e-6
    assert np.abs(passive).max() > 20.0


def _round_trip(robot: Path, noise: float, tmp_path: Path) -> tuple[dict, dict]:
    """simulate (white torque noise, seed 1) then identify with the default roles: identify's JSON report and
    the truth K·φ by base parameter name."""
    data, truth = tmp_path / "d.csv", tmp_path / "d.json"
    _cli("simulate", robot, "-o", data, "--seed", 1, "--noise", noise, "--truth", truth, "-q")
    result = json.loads(_cli("identify", robot, data, "--seed", 1, "--no-diagnose", "-f", "json").stdout)
    base = derive_file(robot, DeriveOptions(seed=1))
    true = dict(zip(base.base_names, base.K @ np.array(json.loads(truth.read_text())["phi"]), strict=True))
    return result, true


def _assert_within_3_sigma_and_test_rms_is_the_noise(result: dict, true: dict, noise: float) -> None:
    assert set(result["parameters"]) == set(true)  # identify's base set is derive's
    for name, p in result["parameters"].items():
        err = abs(p["value"] - true[name])
        assert err <= 3 * abs(p["value"]) * p["std_percent_textbook"] / 100, name
        assert err <= 3 * abs(p["value"]) * p["std_percent"] / 100, name
    assert result["test"]["final"]["rms_total"] == pytest.approx(noise, rel=0.1)


def test_delta_round_trip_on_one_seed(tmp_path):
    """robots/delta.yaml (3 motors, 34 base parameters) simulated with white torque noise 0.05 N·m on
    seed 1 and identified with the default roles: every estimate within 3σ of the truth K·φ (textbook
    σ and default HAC σ), and the test part's RMS is the noise."""
    noise = 0.05
    result, true = _round_trip(ROOT / "robots" / "delta.yaml", noise, tmp_path)
    assert len(true) == 34
    _assert_within_3_sigma_and_test_rms_is_the_noise(result, true, noise)


def test_fourbar_round_trip_on_one_seed(tmp_path):
    """The smallest closed chain, robots/fourbar_hybroblib.yaml (one motor, one loop, 8 base parameters),
    through the same round trip as the Delta: every estimate within 3σ of the truth K·φ (textbook σ and
    default HAC σ), and the test part's RMS is the noise."""
    noise = 0.05
    result, true = _round_trip(ROOT / "robots" / "fourbar_hybroblib.yaml", noise, tmp_path)
    assert len(true) == 8
    _assert_within_3_sigma_and_test_rms_is_the_noise(result, true, noise)
