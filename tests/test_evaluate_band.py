"""evaluate --band: the parameter covariance saved by identify, propagated to τ, and the share of samples inside."""

from __future__ import annotations

import json

import numpy as np
import pytest
import uncertainty_data as ud
from typer.testing import CliRunner

from minparam_cli.cli.app import app
from minparam_cli.model.file import dumps
from minparam_cli.model.parse import parse_model


def _cli(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    d = tmp_path_factory.mktemp("band")
    fit = ud.write(d / "fit.csv", 40.0, 21, None, scale=0.2, motion_seed=0)
    other = ud.write(d / "other.csv", 40.0, 22, None, scale=0.2, motion_seed=1)
    path = d / "m.json"
    r = _cli("identify", ud.ROBOT, fit, "--friction", "viscous,coulomb", "--no-diagnose", "--quiet", "--save-model", path)
    assert r.exit_code == 0, r.output
    return path, other


def _evaluate(path, data, *extra) -> dict:
    r = _cli("evaluate", path, data, "--band", "-f", "json", *extra)
    assert r.exit_code == 0, r.output
    return json.loads(r.output)


def test_model_file_keeps_the_covariance(model):
    path, _ = model
    m = parse_model(path.read_text(), str(path))
    u = m.uncertainty
    assert u["sigma"] == "hac" and len(u["columns"]) == len(u["covariance"]) == 10
    cov = np.array(u["covariance"])
    # the stored covariance gives the σ the saved model reports (std_percent), an identity between two fields
    theta = m.theta[u["columns"]]
    std = np.array([m.std_percent[c] for c in u["columns"]])
    assert np.allclose(100 * np.sqrt(np.diag(cov)) / np.abs(theta), std, rtol=1e-9)
    assert parse_model(dumps(m), "again").uncertainty == u  # round trip


@pytest.mark.parametrize("level", [0.5, 0.95])
def test_share_inside_matches_the_level_on_another_recording(model, level):
    """White noise of the same size as in the fit data: the share inside is the band's probability."""
    path, other = model
    r = _evaluate(path, other, "--band-level", level)
    inside = np.array(r["files"][0]["band"]["inside_per_joint"])
    assert np.all(np.abs(inside - level) < 0.03), inside
    assert r["band"]["level"] == level and r["band"]["sigma"] == "hac"
    half = np.array(r["files"][0]["band"]["half_width_per_joint"])
    part = np.array(r["files"][0]["band"]["parameter_half_width_per_joint"])
    assert np.all(part < half) and np.all(part > 0)


def test_table_shows_the_band(model):
    path, other = model
    r = _cli("evaluate", path, other, "--band")
    assert r.exit_code == 0, r.output
    assert "Prediction band 95 %" in r.output and "inside 1" in r.output


def _broken(path, tmp_path, change) -> str:
    doc = json.loads(path.read_text())
    change(doc)
    out = tmp_path / "broken.json"
    out.write_text(json.dumps(doc))
    return out


@pytest.mark.parametrize("change, message", [
    (lambda d: d.pop("uncertainty"), "no parameter covariance"),
    (lambda d: d["uncertainty"]["covariance"][0].__setitem__(1, 1e3), "symmetric"),
    (lambda d: d["uncertainty"]["residual_sigma_per_joint"].append(1.0), "the robot has 2 joints"),
])
def test_bad_model_covariance_exit_2(model, tmp_path, change, message):
    path, other = model
    r = _cli("evaluate", _broken(path, tmp_path, change), other, "--band")
    assert r.exit_code == 2, r.output
    assert message in r.output and len(r.output.strip().splitlines()) == 1


def test_bad_band_level_exit_2(model):
    path, other = model
    r = _cli("evaluate", path, other, "--band", "--band-level", "1.5")
    assert r.exit_code == 2 and "--band-level" in r.output and len(r.output.strip().splitlines()) == 1
