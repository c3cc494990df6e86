"""identify preprocessing (issue 12): joint-count checks, tiny files without numpy/scipy warnings,
rate tolerances (raw controller time stamps), irregular steps, standstill shares and trimming."""

from __future__ import annotations

import subprocess
import sys
import warnings

import numpy as np
import pytest
from conftest import ROOT
from typer.testing import CliRunner

from minparam_cli.cli.app import app
from minparam_cli.errors import DataError
from minparam_cli.measured.blocks import Standstill, load_all
from minparam_cli.measured.records import Block, DataOptions, DataReport


def _csv(path, t, columns: dict, fmt="%.17g"):
    """A CSV with a time column and, for each prefix, one column per joint (its array's columns)."""
    header, parts = ["t"], [np.asarray(t, dtype=float)[:, None]]
    for prefix, a in columns.items():
        a = np.asarray(a, dtype=float).reshape(len(t), -1)
        header += [f"{prefix}{j}" for j in range(1, a.shape[1] + 1)]
        parts.append(a)
    np.savetxt(path, np.hstack(parts), delimiter=",", header=",".join(header), comments="", fmt=fmt)
    return path


def _motion(N, rate, n=2):
    t = np.arange(N) / rate
    w = 2 * np.pi * 0.4 * np.arange(1, n + 1)
    q = 0.5 * np.sin(t[:, None] * w)
    dq = 0.5 * w * np.cos(t[:, None] * w)
    ddq = -0.5 * w**2 * np.sin(t[:, None] * w)
    tau = 2.0 * q + 0.3 * dq + 0.01 * np.random.default_rng(0).standard_normal(q.shape)
    return t, q, dq, ddq, tau


def _one_line_error(r, name):
    assert r.exit_code == 2, r.output
    lines = r.output.strip().splitlines()
    assert len(lines) == 1 and name in lines[0] and "Traceback" not in r.output, r.output


# --- 1. joint count ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    "columns, message",
    [
        ({"q": 6, "tau": 6}, r"the data have 6 joints \(q1\.\.q6\), the robot has 2$"),
        ({"q": 2, "tau": 6}, r"the data have 6 joints \(tau1\.\.tau6\), the robot has 2$"),
        ({"q": 2, "dq": 3, "tau": 2}, r"the data have 3 joints \(dq1\.\.dq3\), the robot has 2$"),
        ({"q": 2, "dq": 2, "ddq": 4, "tau": 2}, r"the data have 4 joints \(ddq1\.\.ddq4\), the robot has 2$"),
        ({"q": 1, "tau": 1}, r"the data have 1 joint \(q1\), the robot has 2$"),
    ],
    ids=["q-and-tau-6", "tau-6", "dq-3", "ddq-4", "fewer"],
)
def test_joint_count_mismatch_is_one_data_error_in_joint_terms(tmp_path, columns, message):
    t, *_ = _motion(300, 100.0)
    p = _csv(tmp_path / "six.csv", t, {k: np.random.default_rng(1).random((300, m)) for k, m in columns.items()})
    with pytest.raises(DataError, match=message):
        load_all(p, 2, DataOptions())
    r = CliRunner().invoke(app, ["identify", "robots/planar2r.yaml", str(p), "--quiet"])
    _one_line_error(r, "six.csv")


def test_joint_count_mismatch_follows_the_column_mapping(tmp_path):
    t, *_ = _motion(300, 100.0)
    rng = np.random.default_rng(2)
    p = _csv(tmp_path / "mapped.csv", t, {"pos": rng.random((300, 6)), "effort": rng.random((300, 6)), "q": rng.random((300, 2))})
    opts = DataOptions(columns={"q": "pos", "tau": "effort"})
    with pytest.raises(DataError, match=r"mapped.csv: the data have 6 joints \(pos1\.\.pos6\), the robot has 2"):
        load_all(p, 2, opts)


def test_joint_count_mismatch_in_an_npz(tmp_path):
    t, q, dq, ddq, tau = _motion(300, 100.0, n=6)
    p = tmp_path / "six.npz"
    np.savez(p, t=t, q=q, dq=dq, ddq=ddq, tau=tau)
    with pytest.raises(DataError, match=r"six.npz: the data have 6 joints \(array 'q' has shape \(300, 6\)\), the robot has 2$"):
        load_all(p, 2, DataOptions())
    np.savez(p, t=t, q=q[:-1, :2], tau=tau[:, :2])
    with pytest.raises(DataError, match=r"array 'q' has shape \(299, 2\), expected \(300, 2\)"):
        load_all(p, 2, DataOptions())
    r = CliRunner().invoke(app, ["identify", "robots/planar2r.yaml", str(p), "--quiet"])
    _one_line_error(r, "six.npz")


# --- 2. tiny files -----------------------------------------------------------------------------


TINY = {
    "t-q-tau": ("q", "tau"),
    "t-q-dq-tau": ("q", "dq", "tau"),
    "t-q-dq-ddq-tau": ("q", "dq", "ddq", "tau"),
}


def _tiny(tmp_path, kind, rate=500.0, N=49):
    t, q, dq, ddq, tau = _motion(N, rate)
    arrays = {"q": q, "dq": dq, "ddq": ddq, "tau": tau}
    return _csv(tmp_path / f"tiny-{kind}.csv", t, {k: arrays[k] for k in TINY[kind]})


@pytest.mark.parametrize("kind", list(TINY))
def test_a_49_row_file_gives_no_numpy_warning(tmp_path, kind):
    p = _tiny(tmp_path, kind)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            load_all(p, 2, DataOptions())
        except DataError as e:
            assert str(e).startswith(str(p)) and "\n" not in str(e)
        r = CliRunner().invoke(app, ["identify", "robots/planar2r.yaml", str(p), "--quiet"])
    assert not [w for w in caught if issubclass(w.category, RuntimeWarning)], [str(w.message) for w in caught]
    assert "Warning" not in r.output and "Traceback" not in r.output, r.output
    if kind != "t-q-dq-ddq-tau":  # the filter needs 201 samples at 500 Hz: refused by the data pipeline
        _one_line_error(r, p.name)
    else:  # no filter: the 49 samples reach the fit, which may refuse them (exit 2) or find them too poor (exit 1)
        assert r.exit_code in (0, 1, 2), r.output
        if r.exit_code:
            assert len(r.output.strip().splitlines()) == 1, r.output


def test_a_49_row_file_too_short_for_the_filter_says_so(tmp_path):
    p = _tiny(tmp_path, "t-q-tau")
    with pytest.raises(DataError, match=r"tiny-t-q-tau.csv: too few samples to filter: 49 at 500 Hz.*100 samples.*at least 201"):
        load_all(p, 2, DataOptions())


@pytest.mark.parametrize("kind", ["t-q-tau", "t-q-dq-tau"])
def test_a_49_row_file_prints_no_warning_on_stderr(tmp_path, kind):
    p = _tiny(tmp_path, kind)
    r = subprocess.run(
        [sys.executable, "-m", "minparam_cli", "identify", "robots/planar2r.yaml", str(p), "--quiet"],
        cwd=ROOT, capture_output=True, text=True, timeout=120,
    )
    assert not [line for line in r.stderr.splitlines() if "Warning" in line], r.stderr
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1 and p.name in r.stderr, r.stderr


@pytest.mark.parametrize("N", [3, 10, 17, 30, 49])
@pytest.mark.parametrize("rate", [20.0, 100.0, 1000.0])
@pytest.mark.parametrize("kind", list(TINY))
def test_short_files_load_or_refuse_without_warnings(tmp_path, N, rate, kind):
    p = _tiny(tmp_path, kind, rate=rate, N=N)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        try:
            b = load_all(p, 2, DataOptions(chunk_rows=7))
        except DataError as e:
            assert str(e).startswith(str(p)) and "\n" not in str(e)
        else:
            assert len(b) > 0 and np.isfinite(b.ddq).all()


def test_values_too_large_to_filter_are_a_data_error_not_a_warning(tmp_path):
    t, q, dq, ddq, tau = _motion(1000, 500.0)
    q = q.copy()
    q[500:510] = 1e308
    p = _csv(tmp_path / "huge.csv", t, {"q": q, "tau": tau})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(DataError, match=r"huge.csv: filtering gives non-finite values at t = "):
            load_all(p, 2, DataOptions())


# --- 3. decimation with a tolerance: raw controller time stamps -----------------------------------


@pytest.mark.parametrize("columns", [("q", "tau"), ("q", "dq", "tau")])
def test_raw_large_time_stamps_give_the_same_samples_as_re_zeroed_ones(tmp_path, columns):
    t, q, dq, ddq, tau = _motion(4000, 500.0)
    arrays = {"q": q, "dq": dq, "tau": tau}
    offset = 1.7e9
    out = []
    for name, stamps in (("zeroed", t), ("raw", t + offset)):
        p = _csv(tmp_path / f"{name}.csv", stamps, {k: arrays[k] for k in columns})
        rep = DataReport(str(p))
        out.append((rep, load_all(p, 2, DataOptions(), rep)))
    (r0, b0), (r1, b1) = out
    assert r0.decimation == r1.decimation == 10  # 500 Hz / (10 x 5 Hz), whatever the rounding of the step
    assert r0.samples == r1.samples == len(b0) == len(b1)
    assert r0.dropped == r1.dropped and r0.irregular_steps == r1.irregular_steps == 0
    assert np.max(np.abs(b1.t - offset - b0.t)) < 1e-6
    assert np.max(np.abs(b1.q - b0.q)) < 1e-5
    assert np.max(np.abs(b1.dq - b0.dq)) < 1e-4
    assert np.max(np.abs(b1.tau - b0.tau)) < 1e-5


def test_the_automatic_decimation_tolerates_a_step_just_off_the_round_rate():
    from minparam_cli.measured.filtering import Processor

    for step in (0.002 * (1 - 1e-7), 0.002, 0.002 * (1 + 1e-7), 0.002 * (1 + 1e-4)):
        t = np.arange(50) * step
        clean = {"t": t, "q": np.zeros((50, 1)), "dq": None, "ddq": None, "tau": np.zeros((50, 1))}
        rep = DataReport("x")
        p = Processor(clean, DataOptions(), rep, step)
        assert rep.decimation == 10 and p.trim == 100


# --- 4. irregular steps ------------------------------------------------------------------------


@pytest.mark.parametrize("factor, counted", [(1.2, True), (0.8, True), (1.05, False), (0.95, False)])
def test_every_third_step_off_by_more_than_ten_percent_is_irregular(tmp_path, factor, counted):
    N = 601
    steps = np.full(N - 1, 0.005)
    steps[2::3] *= factor  # every third step
    t = np.concatenate([[0.0], np.cumsum(steps)])
    _, q, dq, ddq, tau = _motion(N, 200.0)
    p = _csv(tmp_path / "irregular.csv", t, {"q": q, "dq": dq, "ddq": ddq, "tau": tau})
    rep = DataReport(str(p))
    load_all(p, 2, DataOptions(chunk_rows=50), rep)
    assert rep.median_step_s == pytest.approx(0.005)
    assert rep.irregular_steps == (len(steps[2::3]) if counted else 0)


# --- 5. standstill -----------------------------------------------------------------------------

RATE = 200.0
N_STILL = 1600  # 8 s
STILL_LONG = slice(400, 701)  # 2.0 .. 3.5 s: 1.5 s, every joint still
STILL_SHORT = slice(1100, 1141)  # 5.5 .. 5.7 s: 0.2 s, every joint still
STILL_J2 = slice(1200, 1401)  # 6 .. 7 s: joint 2 still, joint 1 moving


def _standstill_file(tmp_path, filtered=False):
    t = np.arange(N_STILL) / RATE
    dq = np.full((N_STILL, 2), [0.5, -0.2])
    for s in (STILL_LONG, STILL_SHORT):
        dq[s] = 0.0
    dq[STILL_J2, 1] = 0.0
    q = np.vstack([[0.0, 0.0], np.cumsum(dq[:-1] / RATE, axis=0)])  # constant while still
    ddq = np.zeros_like(q)
    tau = 1.0 + 0.01 * np.random.default_rng(5).standard_normal(q.shape)  # noise: no repeated rows
    columns = {"q": q, "tau": tau} if filtered else {"q": q, "dq": dq, "ddq": ddq, "tau": tau}
    return t, _csv(tmp_path / "still.csv", t, columns)


def test_standstill_shares_are_reported_without_trimming(tmp_path):
    t, p = _standstill_file(tmp_path)
    rep = DataReport(str(p))
    b = load_all(p, 2, DataOptions(), rep)
    assert len(b) == N_STILL and rep.samples == N_STILL
    both = (701 - 400) + (1141 - 1100)
    assert rep.still_share == pytest.approx([both / N_STILL, (both + 201) / N_STILL])
    assert rep.still_all_share == pytest.approx(both / N_STILL)
    d = rep.as_dict()
    assert "standstill" not in d["dropped"] and d["trimmed_segments"] == 0
    assert d["still_share"] == rep.still_share and d["still_all_share"] == rep.still_all_share
    assert {"rows_read", "dropped", "irregular_steps", "median_step_s", "derived", "filter", "decimation", "samples"} <= set(d)


@pytest.mark.parametrize("chunk_rows", [7, 64, 333, 200_000])
def test_a_long_standstill_is_trimmed_a_short_one_kept_whatever_the_chunk_size(tmp_path, chunk_rows):
    t, p = _standstill_file(tmp_path)
    rep = DataReport(str(p))
    b = load_all(p, 2, DataOptions(trim_still_s=0.5, chunk_rows=chunk_rows), rep)
    long_run = t[STILL_LONG]
    assert rep.dropped["standstill"] == len(long_run) and rep.trimmed_segments == 1
    assert len(b) == rep.samples == N_STILL - len(long_run)
    assert not np.isin(b.t, long_run).any()  # the whole 1.5 s run, not just its part beyond 0.5 s
    assert np.isin(t[STILL_SHORT], b.t).all() and np.isin(t[STILL_J2], b.t).all()
    assert np.all(np.diff(b.t) > 0)
    both = (701 - 400) + (1141 - 1100)
    assert rep.still_all_share == pytest.approx(both / N_STILL)  # before trimming
    assert rep.as_dict()["dropped"]["standstill"] == len(long_run)


def test_trimming_a_filtered_record_does_not_depend_on_the_chunk_size(tmp_path):
    _, p = _standstill_file(tmp_path, filtered=True)
    out = []
    for chunk_rows in (97, 200_000):
        rep = DataReport(str(p))
        b = load_all(p, 2, DataOptions(trim_still_s=0.5, decimate=1, chunk_rows=chunk_rows), rep)
        out.append((rep, b))
    (r0, b0), (r1, b1) = out
    assert r0.trimmed_segments == r1.trimmed_segments == 1
    assert r0.dropped == r1.dropped and r0.dropped["standstill"] > 200
    assert len(b0) == len(b1) and np.allclose(b0.t, b1.t, rtol=0, atol=1e-9) and np.allclose(b0.q, b1.q, atol=1e-9)
    assert r0.still_share == pytest.approx(r1.still_share)


def _reference_trim(t, still, trim):
    """Keep-mask of the whole record: runs of still samples lasting longer than trim dropped."""
    keep = np.ones(len(t), dtype=bool)
    segments = 0
    i = 0
    while i < len(t):
        if still[i]:
            j = i
            while j + 1 < len(t) and still[j + 1]:
                j += 1
            if t[j] - t[i] > trim:
                keep[i : j + 1] = False
                segments += 1
            i = j + 1
        else:
            i += 1
    return keep, segments


@pytest.mark.parametrize("seed", range(6))
def test_streamed_trimming_equals_trimming_the_whole_record(seed):
    rng = np.random.default_rng(seed)
    N = 3000
    t = np.cumsum(rng.uniform(0.5, 1.5, N)) * 0.01
    # still runs of random lengths, at the start and the end too
    still = np.repeat(rng.random(200) < 0.5, rng.integers(1, 40, 200))[:N]
    if len(still) < N:
        still = np.concatenate([still, np.ones(N - len(still), dtype=bool)])
    dq = np.where(still[:, None], 0.001, 1.0) * rng.choice([-1, 1], (N, 2))
    dq[~still, 1] = 0.0  # joint 2 still while joint 1 moves: not a standstill of all joints
    z = np.zeros((N, 2))
    whole = Block(t, z, dq, z, z)
    keep, segments = _reference_trim(t, still, 0.15)
    for _ in range(3):
        cuts = np.sort(rng.choice(np.arange(1, N), rng.integers(1, 60), replace=False))
        rep = DataReport("x", samples=N)
        s = Standstill(2, DataOptions(trim_still_s=0.15), rep)
        out = []
        for piece in np.split(np.arange(N), cuts):
            out += list(s.push(whole.take(piece)))
            if s.pending:  # bounded memory: what is held back is one run, of at most trim seconds
                assert s.pending[-1].t[-1] - s.pending[0].t[0] <= 0.15
        out += list(s.finish())
        got = np.concatenate([b.t for b in out]) if out else np.empty(0)
        assert np.array_equal(got, t[keep])
        assert rep.dropped["standstill"] == int((~keep).sum()) and rep.trimmed_segments == segments
        assert rep.samples == int(keep.sum())
        assert rep.still_all_share == pytest.approx(still.mean())
        assert rep.still_share == pytest.approx([still.mean(), 1.0])
        assert not s.pending
