"""identify: a pause in the logging (a gap in the time stamps) splits the record into segments that
are filtered and differentiated apart; nothing is interpolated across it (measured/filtering.py)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import ROBOTS
from typer.testing import CliRunner

from minparam_cli.cli.app import app
from minparam_cli.errors import DataError
from minparam_cli.measured.blocks import load_all
from minparam_cli.measured.records import GAP_STEPS, DataOptions, DataReport


def _run(*args):
    r = CliRunner().invoke(app, [str(a) for a in args])
    assert r.exit_code == 0, r.output
    return r


@pytest.fixture(scope="module")
def puma(tmp_path_factory):
    """A simulated PUMA (20 s at 200 Hz, seed 3) with q only (q̇ and q̈ derived), whole and with
    the 3 s from 8.5 to 11.5 s cut out."""
    d = tmp_path_factory.mktemp("gap")
    _run("simulate", ROBOTS / "puma560.yaml", "-o", d / "sim.csv", "--seed", 3, "--no-ddq", "-q")
    header = (d / "sim.csv").read_text().splitlines()[0].split(",")
    data = np.loadtxt(d / "sim.csv", delimiter=",", skiprows=1)
    keep = [i for i, h in enumerate(header) if not h.startswith("dq")]
    header, data = [header[i] for i in keep], data[:, keep]
    cut = (data[:, 0] > 8.5) & (data[:, 0] < 11.5)
    for name, rows in (("whole", data), ("gap", data[~cut])):
        np.savetxt(d / f"{name}.csv", rows, delimiter=",", header=",".join(header), comments="", fmt="%.17g")
    return d


def _identify(path, out):
    _run("identify", ROBOTS / "puma560.yaml", path, "-f", "json", "-q", "-o", out)
    return json.loads(out.read_text())


def test_a_three_second_pause_leaves_the_test_error_near_the_no_gap_value(puma):
    whole = _identify(puma / "whole.csv", puma / "whole.json")
    gap = _identify(puma / "gap.csv", puma / "gap.json")
    e_whole, e_gap = whole["test"]["final"]["relative_error"], gap["test"]["final"]["relative_error"]
    # measured: 0.061 % whole, 0.077 % with the gap; resampled across it (before): 10.1 %
    assert e_whole < 1e-3 and e_gap < 1e-3 and e_gap < 1.5 * e_whole
    pre = gap["preprocessing"]
    assert whole["preprocessing"]["segments"] == 1 and pre["segments"] == 2
    assert pre["gap_s"] == pytest.approx(3.0, abs=0.01) and pre["trim_s"] == pytest.approx(0.2)
    # one cut-off period (40 samples at 200 Hz, 5 Hz) at both ends of both segments
    assert pre["dropped"]["filter_edges"] == 4 * 40 == 2 * whole["preprocessing"]["dropped"]["filter_edges"]
    text = _run("identify", ROBOTS / "puma560.yaml", puma / "gap.csv", "-q", "--no-diagnose").output
    assert "segments         2 (1 gap(s) longer than 25 steps, 3 s in all, filtered apart)" in text


def _motion(t):
    q = np.stack([np.sin(1.3 * t), np.cos(0.7 * t)], axis=1)
    return q, np.stack([1.3 * np.cos(1.3 * t), -0.7 * np.sin(0.7 * t)], axis=1)


def _csv(path, t, q, tau):
    header = "t,q1,q2,tau1,tau2"
    np.savetxt(path, np.column_stack([t, q, tau]), delimiter=",", header=header, comments="")
    return path


@pytest.mark.parametrize("chunk", [25_000, 333, 400])  # 400: the gap falls between two chunks
def test_no_derived_sample_lies_in_the_gap_and_each_segment_is_differentiated_alone(tmp_path, chunk):
    t = np.concatenate([np.arange(0, 4, 0.005), np.arange(7, 11, 0.005)])
    q, dq = _motion(t)
    p = _csv(tmp_path / "d.csv", t, q, q.copy())
    rep = DataReport(str(p))
    b = load_all(p, 2, DataOptions(decimate=1, chunk_rows=chunk), rep)
    assert rep.segments == 2 and not np.any((b.t > 4 - 0.2 + 1e-6) & (b.t < 7 + 0.2 - 1e-6))
    exact = _motion(b.t)[1]
    assert np.max(np.abs(b.dq - exact)) < 0.02  # 1.5 % of the 1.3 rad/s peak at the segments' ends (0.0093 measured)
    assert rep.dropped["filter_edges"] == 4 * 40
    whole = load_all(p, 2, DataOptions(decimate=1))
    assert len(whole) == len(b) and np.max(np.abs(whole.t - b.t)) < 1e-9 and np.max(np.abs(whole.ddq - b.ddq)) < 1e-9 * np.max(np.abs(whole.ddq))


def test_a_step_of_gap_steps_is_not_a_gap_and_one_step_more_is(tmp_path):
    for extra, segments in ((GAP_STEPS * 0.005 * 0.99, 1), (GAP_STEPS * 0.005 * 1.01, 2)):
        t = np.arange(0, 8, 0.005)
        t[800:] += extra - 0.005
        q, _ = _motion(t)
        rep = DataReport("d")
        load_all(_csv(tmp_path / "d.csv", t, q, q.copy()), 2, DataOptions(), rep)
        assert rep.segments == segments


def test_segments_too_short_to_filter_are_dropped_and_all_short_is_refused(tmp_path):
    t = np.concatenate([np.arange(0, 4, 0.005), np.arange(6, 6.3, 0.005)])  # 60 samples < 2 x 40 + 1
    q, _ = _motion(t)
    rep = DataReport("d")
    load_all(_csv(tmp_path / "d.csv", t, q, q.copy()), 2, DataOptions(), rep)
    assert rep.segments == 2 and rep.dropped["short_segment"] == 60
    t = np.concatenate([np.arange(0, 0.3, 0.005), np.arange(6, 6.3, 0.005)])
    q, _ = _motion(t)
    with pytest.raises(DataError, match="every one of the 2 segments .* is too short to filter"):
        load_all(_csv(tmp_path / "e.csv", t, q, q.copy()), 2, DataOptions())
