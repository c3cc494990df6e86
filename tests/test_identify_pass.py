"""identify's pass on a thread of its own (identify.passes.stream.Pass): the caller goes on once the
fit and selection data are in, while the test data are still being read; the diagnosis never sees
them.  The marker that says so comes after every fit and selection row and before every test row,
whatever the roles' files; an error of the pass reaches the caller; a pass given up stops."""

from __future__ import annotations

import threading
from pathlib import Path

import numpy as np
import pytest
from test_identify_scale import _panda_sample

from minparam_cli.errors import DataError
from minparam_cli.identify import stage
from minparam_cli.identify.passes import stream as stream_module
from minparam_cli.identify.passes.design import Design
from minparam_cli.identify.passes.roles import FIT, SELECTION, plan
from minparam_cli.identify.passes.stream import EARLY, Pass, _rows
from minparam_cli.measured.blocks import time_span
from minparam_cli.robot import DeriveOptions, load_chain


@pytest.fixture(scope="module")
def panda(tmp_path_factory):
    from minparam_cli.base.qr import derive_qr

    folder = tmp_path_factory.mktemp("pass")
    path = _panda_sample(folder, samples=6000)
    _, chain = load_chain(Path("robots/panda.yaml"), DeriveOptions())
    base = derive_qr(chain, seed=0)
    return chain, Design(chain, base.kept, base.base_names), path


def _roles_in_order(design, sources, n, opts):
    """The rows generator's items reduced to their order: 'EARLY' or the piece's role, per rows item."""
    out = []
    for piece, _, rows in _rows({"design": design}, sources, n, opts.data, (), [], stream_module._Spare()):
        if piece is EARLY:
            out.append("EARLY")
        elif rows is not None:
            out.append(piece.role)
    return out


def _split_file(path: Path, folder: Path, shares: tuple[float, ...]) -> list[Path]:
    lines = path.read_text().splitlines()
    header, rows = lines[0], lines[1:]
    cuts = np.cumsum([0] + [int(s * len(rows)) for s in shares[:-1]] + [len(rows)])
    cuts[-1] = len(rows)
    out = []
    for i, (a, b) in enumerate(zip(cuts[:-1], cuts[1:], strict=True)):
        p = folder / f"part{i}.csv"
        p.write_text("\n".join([header] + rows[a:b]) + "\n")
        out.append(p)
    return out


@pytest.mark.parametrize("layout", ["one file", "--test file", "--validate file", "--validate and --test files"])
def test_the_marker_follows_every_fit_and_selection_row_and_precedes_every_test_row(panda, tmp_path, layout):
    chain, design, path = panda
    opts = stage.IdentifyOptions()
    monkey = pytest.MonkeyPatch()
    monkey.setattr(stream_module, "REGRESSOR_ROWS", 500)  # many rows items a piece
    try:
        if layout == "one file":
            sources = plan(path, None, (), opts.split, time_span(path, opts.data))
        elif layout == "--test file":
            data, test = _split_file(path, tmp_path, (0.8, 0.2))
            sources = plan(data, None, (test,), opts.split, time_span(data, opts.data))
        elif layout == "--validate file":  # the data file holds fit and test: its test rows come before the selection file
            data, validate = _split_file(path, tmp_path, (0.8, 0.2))
            sources = plan(data, validate, (), opts.split, time_span(data, opts.data))
        else:
            data, validate, test = _split_file(path, tmp_path, (0.6, 0.2, 0.2))
            sources = plan(data, validate, (test,), opts.split, None)
        order = _roles_in_order(design, sources, chain.dof, opts)
    finally:
        monkey.undo()
    assert order.count("EARLY") == 1
    at = order.index("EARLY")
    assert {FIT, SELECTION} <= set(order[:at])
    assert FIT not in order[at:] and SELECTION not in order[at:]
    assert "test" in order
    if layout != "--validate file":  # there the selection file is read last: the test rows come before it
        assert "test" not in order[:at]


def test_early_gives_complete_fit_and_selection_factors(panda):
    """What early() hands over is what the whole pass ends with (the test factors go on growing)."""
    chain, design, path = panda
    opts = stage.IdentifyOptions()
    sources = plan(path, None, (), opts.split, time_span(path, opts.data))
    running = Pass(design, sources, chain.dof, opts.data, opts.diagnosis_cap, True)
    try:
        acc, thin, _, _ = running.early()
        assert set(acc) == {FIT, SELECTION}
        early = {k: (a.R, a.rows.copy()) for k, a in acc.items()}
        samples = {k: len(t.block()) for k, t in thin.items()}
        whole, thin_end, _, reports, _ = running.result()
    finally:
        running.close()
    assert len(reports) == 1 and "test1" in whole
    for k, (R, rows) in early.items():
        assert np.array_equal(rows, whole[k].rows)
        for a, b in zip(R, whole[k].R, strict=True):
            assert np.array_equal(a, b)
    assert samples == {k: len(t.block()) for k, t in thin_end.items()}


def test_an_error_in_the_test_data_reaches_the_caller(panda, tmp_path):
    chain, design, path = panda
    data, test = _split_file(path, tmp_path, (0.8, 0.2))
    lines = test.read_text().splitlines()
    lines[len(lines) // 2] = lines[len(lines) // 2].replace(",", ",x", 1)  # a word where a number belongs
    test.write_text("\n".join(lines) + "\n")
    opts = stage.IdentifyOptions()
    sources = plan(data, None, (test,), opts.split, time_span(data, opts.data))
    running = Pass(design, sources, chain.dof, opts.data, opts.diagnosis_cap, True)
    try:
        acc, _, _, _ = running.early()  # the fit and selection data are fine
        assert acc[FIT].rows.sum() > 0
        with pytest.raises(DataError, match="part1.csv"):
            running.result()
    finally:
        running.close()


def test_a_pass_given_up_stops_its_threads(panda):
    chain, design, path = panda
    opts = stage.IdentifyOptions()
    sources = plan(path, None, (), opts.split, time_span(path, opts.data))
    before = {t.ident for t in threading.enumerate()}
    running = Pass(design, sources, chain.dof, opts.data, opts.diagnosis_cap, True)
    running.close()
    assert not running._thread.is_alive()
    left = [t for t in threading.enumerate() if t.ident not in before and t.name.startswith("minparam-")]
    for t in left:  # the reader and rows threads end with the pass (a daemon import thread may still finish)
        t.join(5.0)
    assert not [t for t in left if t.is_alive() and t.name != "minparam-import"]


def test_a_pass_that_fails_at_its_start_raises_instead_of_hanging(panda, monkeypatch):
    """(The review's case: a failure before the pass's own try, a thread that cannot start, left early()
    waiting for ever.)"""
    chain, design, path = panda
    opts = stage.IdentifyOptions()
    sources = plan(path, None, (), opts.split, time_span(path, opts.data))

    def refuse(*modules):
        raise RuntimeError("can't start new thread")

    monkeypatch.setattr(stream_module, "preload", refuse)
    got: list = []
    running = Pass(design, sources, chain.dof, opts.data, opts.diagnosis_cap, True)

    def wait():
        try:
            running.early()
        except RuntimeError as e:
            got.append(e)

    waiter = threading.Thread(target=wait, daemon=True)
    waiter.start()
    waiter.join(20.0)
    running.close()
    assert not waiter.is_alive() and len(got) == 1 and "new thread" in str(got[0])


def test_an_error_after_the_fit_and_selection_data_comes_from_result_whatever_the_timing(panda, tmp_path):
    """A test file with a bad header: the reader fails while (or before) the fold reaches the marker, but the
    marker comes first in the rows, so early() hands over the fit and selection data and result() raises."""
    chain, design, path = panda
    data, test = _split_file(path, tmp_path, (0.8, 0.2))
    lines = test.read_text().splitlines()
    test.write_text("\n".join(["t;q1"] + lines[1:]) + "\n")
    opts = stage.IdentifyOptions()
    sources = plan(data, None, (test,), opts.split, time_span(data, opts.data))
    for _ in range(3):
        running = Pass(design, sources, chain.dof, opts.data, opts.diagnosis_cap, True)
        try:
            running._done.wait(20.0)  # the reader has failed by now: early() must still not raise
            acc, _, _, _ = running.early()
            assert acc[FIT].rows.sum() > 0
            with pytest.raises(DataError, match="part1.csv"):
                running.result()
        finally:
            running.close()


def test_a_bad_test_row_is_reported_before_an_error_of_the_diagnosis(panda, tmp_path, monkeypatch):
    """The diagnosis runs while the test data are read. When both fail, the data error is the one reported
    (with the other as its cause), as when the pass ran before anything else."""
    chain, _, path = panda
    data, test = _split_file(path, tmp_path, (0.8, 0.2))
    lines = test.read_text().splitlines()
    lines[-3] = lines[-3].replace(",", ",x", 1)
    test.write_text("\n".join(lines) + "\n")

    def fails(*args, **kwargs):
        raise RuntimeError("the diagnosis failed")

    monkeypatch.setattr(stage, "diagnose", fails)
    opts = stage.IdentifyOptions(tests=(str(test),))
    with pytest.raises(DataError, match="part1.csv") as err:
        stage.identify(chain, data, opts)
    assert isinstance(err.value.__cause__, RuntimeError)
    test.write_text("\n".join(lines[:-3] + lines[-2:]) + "\n")  # the test file mended: the diagnosis's error
    with pytest.raises(RuntimeError, match="the diagnosis failed"):
        stage.identify(chain, data, opts)
