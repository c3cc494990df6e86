"""identify's σ: textbook, Newey–West over time blocks (hac) and block bootstrap, on synthetic recordings whose
truth and noise are known (tests/uncertainty_data.py), against the spread of estimates over many noise seeds."""

from __future__ import annotations

import json

import numpy as np
import pytest
import uncertainty_data as ud
from typer.testing import CliRunner

from minparam_cli.cli.app import app
from minparam_cli.identify.stage import IdentifyOptions, identify
from minparam_cli.identify.assess.uncertainty import UncertaintyOptions

SEEDS = 30
DURATION = 40.0  # s; the fit part (60 %) holds 24 blocks of 1 s


def _opts(kind="hac", **kw) -> IdentifyOptions:
    return IdentifyOptions(diagnose=False, uncertainty=UncertaintyOptions(kind=kind, **kw))


def _sigma(rep: dict, key: str) -> np.ndarray:
    """Absolute σ of every base parameter from the report's relative σ."""
    p = rep["parameters"]
    return np.array([abs(v["value"]) * v[key] / 100 for v in p.values()])


CUTOFF = {"white": None, "coloured": 2.0}  # Hz: the noise's low-pass (None: white)


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """``runs(kind)``: estimates, textbook σ and hac σ of every base parameter over SEEDS recordings of that
    noise kind, computed the first time a test asks for the kind (the fast tier's test needs only coloured)."""
    ch = ud.chain()
    done: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}

    def run(kind: str):
        if kind not in done:
            est, text, hac = [], [], []
            for s in range(SEEDS):
                path = ud.write(tmp_path_factory.mktemp(kind) / "d.csv", DURATION, s, CUTOFF[kind], ch=ch)
                rep, _ = identify(ch, path, _opts())
                rep = rep.to_dict()
                est.append([v["value"] for v in rep["parameters"].values()])
                text.append(_sigma(rep, "std_percent_textbook"))
                hac.append(_sigma(rep, "std_percent"))
            done[kind] = (np.array(est), np.array(text), np.array(hac))
        return done[kind]

    return run


def _ratios(run):
    est, text, hac = run
    spread = est.std(axis=0, ddof=1)
    return text.mean(axis=0) / spread, hac.mean(axis=0) / spread


def test_white_noise_hac_agrees_with_textbook(runs):
    _, text, hac = runs("white")
    r = hac.mean(axis=0) / text.mean(axis=0)
    assert np.all(np.abs(r - 1) < 0.2), r
    t_ratio, _ = _ratios(runs("white"))
    assert np.all((t_ratio > 1 / 1.5) & (t_ratio < 1.5)), t_ratio  # white noise: the textbook σ is right


def test_coloured_noise_textbook_too_small_hac_matches_spread(runs):
    t_ratio, h_ratio = _ratios(runs("coloured"))
    assert np.all(t_ratio < 1 / 1.5), t_ratio
    assert np.all((h_ratio > 1 / 1.5) & (h_ratio < 1.5)), h_ratio


def test_bootstrap_matches_hac_and_is_seeded(tmp_path):
    ch = ud.chain()
    path = ud.write(tmp_path / "c.csv", DURATION, 7, 2.0, ch=ch)
    hac, _ = identify(ch, path, _opts())
    hac = hac.to_dict()
    boot, _ = identify(ch, path, _opts("bootstrap", replicates=400, seed=3))
    boot = boot.to_dict()
    again, _ = identify(ch, path, _opts("bootstrap", replicates=400, seed=3))
    again = again.to_dict()
    # one recording of 24 blocks: each σ estimate is itself uncertain by ~15 %, and hac has a lag term the
    # bootstrap lacks; over 30 seeds both match the spread (docs/methods/uncertainty.md)
    r = _sigma(boot, "std_percent") / _sigma(hac, "std_percent")
    assert 0.75 < np.median(r) < 1.33 and np.all((r > 0.5) & (r < 2)), r
    assert boot["sigma"]["seed"] == 3 and boot["sigma"]["replicates"] == 400 and boot["sigma"]["kind"] == "bootstrap"
    assert _sigma(boot, "std_percent").tolist() == _sigma(again, "std_percent").tolist()


def test_block_statistics_reproduce_the_fit(tmp_path):
    """The weighted fit solved from the summed block Gram matrices is the streamed QR fit (identity)."""
    ch = ud.chain()
    path = ud.write(tmp_path / "c.csv", DURATION, 2, 2.0, ch=ch)
    rep, art = identify(ch, path, _opts())
    rep = rep.to_dict()
    theta = np.array([v["value"] for v in rep["parameters"].values()])
    assert np.allclose(art.uncertainty.theta, theta, rtol=1e-8, atol=1e-10 * np.abs(theta).max())
    # textbook σ from the blocks equals fit.py's σ²(WᵀW)⁻¹
    t_rep, _ = identify(ch, path, _opts("textbook"))
    t_rep = t_rep.to_dict()
    a = np.array([v["std_percent"] for v in t_rep["parameters"].values()])
    b = np.array([v["std_percent_textbook"] for v in rep["parameters"].values()])
    assert np.allclose(a, b, rtol=1e-6)


def _cli(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def test_cli_reports_which_sigma(tmp_path):
    path = ud.write(tmp_path / "c.csv", 20.0, 1, 2.0)
    r = _cli("identify", ud.ROBOT, path, "--friction", "viscous,coulomb", "--no-diagnose", "--quiet")
    assert r.exit_code == 0, r.output
    assert "σ % (hac)" in r.output and "Newey–West" in r.output
    r = _cli("identify", ud.ROBOT, path, "--friction", "viscous,coulomb", "--no-diagnose", "--quiet", "--sigma", "textbook", "-f", "json")
    assert r.exit_code == 0, r.output
    assert json.loads(r.output)["sigma"]["kind"] == "textbook"


@pytest.mark.parametrize("args, message", [
    (("--block-length", "100"), "longer than the fit data"),
    (("--block-length", "0"), "--block-length"),
    (("--sigma", "bootstrap", "--replicates", "0"), "at least 2 replicates"),
])
def test_bad_sigma_settings_exit_2(tmp_path, args, message):
    path = ud.write(tmp_path / "c.csv", 20.0, 1, 2.0)
    r = _cli("identify", ud.ROBOT, path, "--no-diagnose", "--quiet", *args)
    assert r.exit_code == 2, r.output
    assert message in r.output and len(r.output.strip().splitlines()) == 1 and "Traceback" not in r.output


def test_block_statistics_follow_the_diagnosis_columns(tmp_path):
    """Friction not declared: the diagnosis adds it through slot columns, and the final fit's block statistics
    come from the streamed ones by the same column map; the fit from them equals the final fit."""
    ch = ud.chain(friction=())
    path = ud.write(tmp_path / "c.csv", DURATION, 1, 2.0, ch=ch)
    rep, art = identify(ch, path, IdentifyOptions(uncertainty=UncertaintyOptions()))
    rep = rep.to_dict()
    assert any((s.get("label") or "").startswith("coulomb") for s in rep["steps"])
    theta = np.array([v["value"] for v in rep["parameters"].values()])
    assert len(art.uncertainty.theta) == len(theta) > 6
    assert np.allclose(art.uncertainty.theta, theta, rtol=1e-8, atol=1e-10 * np.abs(theta).max())


def test_short_data_with_the_default_block_falls_back_to_textbook_and_says_so(tmp_path):
    """A 1.5 s recording has 0.9 s of fit data: fewer than two default blocks. The run still succeeds, with
    the textbook σ, and both the σ kind and a flag say so (an explicit --block-length that long is refused)."""
    ch = ud.chain()
    path = ud.write(tmp_path / "s.csv", 1.5, 1, None, scale=0.05)
    rep, _ = identify(ch, path, _opts())
    rep = rep.to_dict()
    assert rep["sigma"]["kind"] == "textbook"
    assert any("shorter than two blocks" in f for f in rep["flags"])
    r = _cli("identify", ud.ROBOT, path, "--friction", "viscous,coulomb", "--no-diagnose", "--quiet", "--block-length", "1")
    assert r.exit_code == 2 and "longer than the fit data" in r.output
