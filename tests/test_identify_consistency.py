"""identify A B C --consistency: each recording alone and all together, and the parameters on which they disagree."""

from __future__ import annotations

import json

import numpy as np
import pytest
import uncertainty_data as ud
from typer.testing import CliRunner

from minparam_cli.cli.app import app

FLAGS = ("--friction", "viscous,coulomb", "--quiet")


def _cli(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def _consistency(paths, *extra) -> dict:
    r = _cli("identify", ud.ROBOT, *paths, *FLAGS, "--consistency", "-f", "json", *extra)
    assert r.exit_code == 0, r.output
    return json.loads(r.output)


@pytest.fixture(scope="module")
def recordings(tmp_path_factory):
    d = tmp_path_factory.mktemp("rec")
    same = [ud.write(d / f"r{k}.csv", 40.0, 10 + k, 2.0, motion_seed=k) for k in range(3)]
    # the third recording's joint viscous friction is 3x the others' (warmed-up gearbox): a model error
    other = ud.write(d / "warm.csv", 40.0, 12, 2.0, motion_seed=2, viscous=np.array([1.5, 0.5]))
    return same, other


def test_same_robot_recordings_agree_within_honest_sigma(recordings):
    same, _ = recordings
    c = _consistency(same)
    assert c["sigma"] == "hac" and len(c["recordings"]) == 3
    # the textbook σ understate the spread between recordings (coloured noise); the hac σ do not
    assert c["median_spread_over_sigma_textbook"] > 2.0
    assert c["median_spread_over_sigma"] < 1.5
    assert len(c["disagree"]) <= 1
    for p in c["parameters"]:
        # the joint fit has every recording's data: its σ is below each recording's
        assert p["joint"]["std"] < min(r["std"] for r in p["recordings"])
        assert min(r["value"] for r in p["recordings"]) - 1e-12 <= p["joint"]["value"] + 3 * p["joint"]["std"]


def test_a_changed_parameter_is_flagged_in_table_and_plot(recordings, tmp_path):
    """Through the stage and the renderers (the CLI path is the test above)."""
    from minparam_cli.cli.common import save_png
    from minparam_cli.identify.consistency import consistency
    from minparam_cli.identify.stage import IdentifyOptions
    from minparam_cli.render.consistency_plot import consistency_plot
    from minparam_cli.render.consistency_text import render_consistency

    same, other = recordings
    c, reports = consistency(ud.chain(), [same[0], same[1], other], IdentifyOptions())
    assert len(reports) == 3 and "Fv1" in c.disagree
    fv1 = next(p for p in c.parameters if p.parameter == "Fv1")
    assert fv1.disagree and fv1.spread_over_sigma > 3
    text = render_consistency(c)
    assert "σ: hac" in text and "DISAGREE" in text and "spread/σ textbook" in text
    save_png(consistency_plot(c, "test"), tmp_path / "consistency.png")
    assert (tmp_path / "consistency.png").stat().st_size > 1000


def test_recording_with_other_joint_count_exit_2(recordings, tmp_path):
    same, _ = recordings
    tab = np.loadtxt(same[0], delimiter=",", skiprows=1)
    three = tmp_path / "three.csv"
    cols = [tab[:, 0]] + [tab[:, 1 + 2 * k: 3 + 2 * k].repeat([1, 2], axis=1) for k in range(4)]
    hdr = ["t"] + [f"{k}{j}" for k in ("q", "dq", "ddq", "tau") for j in (1, 2, 3)]
    np.savetxt(three, np.column_stack(cols), delimiter=",", header=",".join(hdr), comments="")
    r = _cli("identify", ud.ROBOT, same[0], three, *FLAGS, "--consistency")
    assert r.exit_code == 2, r.output
    line = r.output.strip()
    assert len(line.splitlines()) == 1 and "3 joints" in line and "three.csv" in line


@pytest.mark.parametrize("extra, message", [
    ((), "--consistency"),  # two files, no --consistency
    (("--consistency", "--test", "TEST"), "does not combine with --test"),
])
def test_bad_combinations_exit_2(recordings, extra, message):
    same, _ = recordings
    extra = tuple(str(same[2]) if e == "TEST" else e for e in extra)
    r = _cli("identify", ud.ROBOT, same[0], same[1], *FLAGS, *extra)
    assert r.exit_code == 2, r.output
    assert message in r.output and len(r.output.strip().splitlines()) == 1


def test_one_recording_with_consistency_exit_2(recordings):
    same, _ = recordings
    r = _cli("identify", ud.ROBOT, same[0], *FLAGS, "--consistency")
    assert r.exit_code == 2 and "at least two recordings" in r.output
