"""The data reader on broken files and broken processes: a bad row is named by its file line, in
both readers; the second (parsing) process never hangs, outlives or out-talks the reading one."""

from __future__ import annotations

import os
import signal
import struct
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import ROOT


@pytest.fixture(autouse=True)
def _numpy_reader(monkeypatch):
    """These tests are about numpy's reader and its second process: pyarrow's reader
    (measured/arrow_csv.py, tested in test_fast_reader.py) is switched off unless a test asks."""
    monkeypatch.setenv("MINPARAM_CSV_READER", "numpy")


def _write_rows(path, t, tail=b""):
    """A two-joint CSV (t, q, dq, ddq, tau) with times ``t``, every other value 1, then ``tail``."""
    rows = np.hstack([t[:, None], np.ones((len(t), 8))])
    np.savetxt(path, rows, delimiter=",", header="t,q1,q2,dq1,dq2,ddq1,ddq2,tau1,tau2", comments="", fmt="%.9f")
    with open(path, "ab") as fh:
        fh.write(tail)
    return path


def _bad_copy(path, line_no, new_line):
    lines = path.read_bytes().split(b"\n")
    lines[line_no - 1] = new_line
    path.write_bytes(b"\n".join(lines))


@pytest.mark.parametrize(
    "line, expected",
    [
        (b"1,2,3", "line {no} has 3 values, the header has 9"),
        (b"1,2,3,4,5,6,7,8,9,10", "line {no} has 10 values, the header has 9"),
        (b"1,2,3,\xe9,5,6,7,8,9", "line {no} is not UTF-8 text"),
        (b"1,2,3,4,5,6,7,8,abc", "non-numeric value 'abc' on line {no}, column 9 (tau2)"),
        (b"1_000,2,3,4,5,6,7,8,9", "non-numeric value '1_000' on line {no}, column 1 (t)"),  # float() takes it
        (b"1,2,3,4,5,6,7,8,\xef\xbc\x99", "non-numeric value '\uff19' on line {no}, column 9 (tau2)"),  # full-width 9
        (b"   ", "line {no} holds only whitespace"),
    ],
    ids=["too few values", "too many values", "not utf-8", "not a number", "underscore", "full-width digit", "whitespace"],
)
@pytest.mark.parametrize("no", [2, 1500, 3001])  # first row, inside the third chunk, last row
def test_a_bad_row_is_named_by_its_file_line_in_both_readers(tmp_path, monkeypatch, line, expected, no):
    from minparam_cli.errors import DataError
    from minparam_cli.measured import tables
    from minparam_cli.measured.blocks import load_all
    from minparam_cli.measured.records import DataOptions

    N = 3000
    t = np.arange(N) / 100.0
    path = tmp_path / "d.csv"
    _write_rows(path, t)
    _bad_copy(path, no, line)
    for reader, limit in (("numpy", 1 << 40), ("numpy", 0), ("pyarrow", 1 << 40)):  # sequential, second process, pyarrow
        monkeypatch.setattr(tables, "BACKGROUND_BYTES", limit)
        monkeypatch.setenv("MINPARAM_CSV_READER", reader)
        with pytest.raises(DataError) as err:
            load_all(path, 2, DataOptions(chunk_rows=700))
        assert str(err.value) == f"{path}: " + expected.format(no=no)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the second process is Linux-only")
def test_a_parsing_process_that_dies_mid_message_is_an_error_not_a_hang(tmp_path, monkeypatch):
    """The child killed while it sends a chunk (out of memory, kill -9): the read ends with EOF."""
    from minparam_cli.errors import ComputationError
    from minparam_cli.measured import tables
    from minparam_cli.measured.blocks import load_all
    from minparam_cli.measured.records import DataOptions

    def dying_worker(path, rows, out, theirs):  # the real worker's signature: dies of the cut, not of a TypeError
        theirs.close()
        os.write(out.fileno(), struct.pack("!i", 50_000_000) + b"x" * 1000)  # a message cut short
        os.kill(os.getpid(), signal.SIGKILL)

    N = 2000
    path = tmp_path / "d.csv"
    _write_rows(path, np.arange(N) / 100.0)
    monkeypatch.setattr(tables, "BACKGROUND_BYTES", 0)
    monkeypatch.setattr(tables, "_parse_worker", dying_worker)
    signal.alarm(60)  # a hang fails the test instead of the suite
    try:
        with pytest.raises(ComputationError, match="the parsing process ended unexpectedly"):
            load_all(path, 2, DataOptions(chunk_rows=700))
    finally:
        signal.alarm(0)


ORPHAN_PROBE = """
import os, signal, sys, time
# Ctrl-C as in a terminal: a job started in the background by a non-interactive shell (`cmd &`, as CI
# may run the suite) inherits SIGINT ignored, and Python then leaves it so
signal.signal(signal.SIGINT, signal.default_int_handler)
import numpy as np
from minparam_cli.measured import tables
from minparam_cli.measured.records import DataOptions
from minparam_cli.measured.reading import raw_chunks

def slow(fh, rows):
    while True:
        time.sleep(0.05)
        yield np.ones((rows, 9))

tables.BACKGROUND_BYTES = 0
tables._sequential = slow  # the child parses forever, slowly
chunks = raw_chunks(__import__("pathlib").Path(sys.argv[1]), 2, DataOptions(chunk_rows=10))
import multiprocessing
try:
    next(chunks)
    print(multiprocessing.active_children()[0].pid, flush=True)  # inside try: Ctrl-C may follow at once
    for _ in chunks:
        time.sleep(0.2)  # the reading process's own work: Ctrl-C lands here, not in the reader
except KeyboardInterrupt:
    time.sleep(0.5)  # the child got the same Ctrl-C: time for it to speak, if it were to
    chunks.close()
    print("interrupted", flush=True)
"""


def _gone(pid: int, within: float = 10.0) -> bool:
    deadline = time.monotonic() + within
    while time.monotonic() < deadline:
        try:
            state = Path(f"/proc/{pid}/status").read_text()
        except FileNotFoundError:
            return True
        if "\nState:\tZ" in state:  # a zombie has ended; only its exit status waits
            return True
        time.sleep(0.05)
    return False


def _probe_csv(tmp_path):
    path = tmp_path / "d.csv"
    path.write_text("t,q1,q2,dq1,dq2,ddq1,ddq2,tau1,tau2\n" + "0,1,1,1,1,1,1,1,1\n" * 100)
    return path


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the second process is Linux-only")
@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM], ids=["SIGKILL", "SIGTERM"])
def test_the_parsing_process_dies_with_the_reading_process(tmp_path, sig):
    proc = subprocess.Popen([sys.executable, "-c", ORPHAN_PROBE, str(_probe_csv(tmp_path))], stdout=subprocess.PIPE, text=True, cwd=ROOT)
    child = int(proc.stdout.readline())
    proc.send_signal(sig)
    proc.wait(timeout=30)
    assert _gone(child), "the parsing process outlived the reading process"


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the second process is Linux-only")
def test_ctrl_c_ends_both_processes_quietly(tmp_path):
    """Ctrl-C reaches the whole process group: the child stays quiet, the reader cleans up."""
    proc = subprocess.Popen(
        [sys.executable, "-c", ORPHAN_PROBE, str(_probe_csv(tmp_path))],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT, start_new_session=True,
    )
    child = int(proc.stdout.readline())
    os.killpg(proc.pid, signal.SIGINT)
    out, err = proc.communicate(timeout=30)
    assert out.strip() == "interrupted" and err == ""
    assert _gone(child)


@pytest.mark.parametrize(
    "tail",
    [b"5.0,1,1,1,1,1,1,1,1\n", b"nan,nan,nan,nan,nan,nan,nan,nan,nan\n", b"0,1,1,1,1,1,1,1,1\n", b"\n\n", b"# the end\n"],
    ids=["time jumps back", "nan row", "time reset", "blank lines", "comment"],
)
def test_a_last_row_the_cleaning_drops_does_not_move_the_hold_out_split(tmp_path, tail):
    from minparam_cli.measured.blocks import time_span
    from minparam_cli.measured.records import DataOptions

    t = np.arange(3000) / 100.0
    clean = time_span(_write_rows(tmp_path / "clean.csv", t), DataOptions())
    assert clean == (0.0, 29.99)
    assert time_span(_write_rows(tmp_path / "bad.csv", t, tail=tail), DataOptions()) == clean


def test_the_tail_window_never_reads_a_cut_line_as_a_row(tmp_path):
    """The last 64 KiB start inside a line: '3.123456789,...' cut to '23456789,...' is not a time."""
    from minparam_cli.measured.blocks import time_span
    from minparam_cli.measured.records import DataOptions
    from minparam_cli.measured.spans import TAIL_BYTES

    t = 0.001 + np.arange(3000) / 100.0
    for k in range(200):  # trailing blank lines shift the window a byte at a time
        path = _write_rows(tmp_path / "d.csv", t, tail=b"\n" * k)
        data = path.read_bytes()
        start = len(data) - TAIL_BYTES
        line_start = data.rfind(b"\n", 0, start) + 1
        if data.index(b".", line_start) < start < data.index(b",", line_start):
            break
    else:
        pytest.fail("no file length puts the window inside a time stamp")
    assert time_span(path, DataOptions()) == (t[0], round(t[-1], 9))


def test_a_huge_value_is_a_one_line_error_naming_the_time(tmp_path):
    """A finite but absurd velocity overflows the regressor; the fit must not run on NaN."""
    from typer.testing import CliRunner

    from minparam_cli.cli.app import app

    N = 4000
    t = np.arange(N) / 500.0
    q = np.stack([0.5 * np.sin(2 * np.pi * 0.3 * t), 0.4 * np.sin(2 * np.pi * 0.7 * t)], axis=1)
    dq = np.gradient(q, t, axis=0)
    dq[2000, 1] = 1e200
    path = tmp_path / "d.csv"
    rows = np.hstack([t[:, None], q, dq, np.cos(q)])
    np.savetxt(path, rows, delimiter=",", header="t,q1,q2,dq1,dq2,tau1,tau2", comments="")
    r = CliRunner().invoke(app, ["identify", "robots/planar2r.yaml", str(path), "--no-diagnose"])
    assert r.exit_code == 2, r.output
    assert len(r.output.strip().splitlines()) == 1 and "Traceback" not in r.output and "Warning" not in r.output
    assert "gives a non-finite regressor row" in r.output and "t = " in r.output


def test_reading_goes_on_after_the_thread_that_started_it_ends(tmp_path, monkeypatch):
    """A library caller may start reading in one thread and go on in another: the second process
    must not be tied to the first thread's life."""
    import threading

    from minparam_cli.measured import reading

    from minparam_cli.measured import tables
    from minparam_cli.measured.records import DataOptions

    N = 3000
    path = tmp_path / "d.csv"
    _write_rows(path, np.arange(N) / 100.0)
    monkeypatch.setattr(tables, "BACKGROUND_BYTES", 0)
    chunks = reading.raw_chunks(path, 2, DataOptions(chunk_rows=700))
    first = []
    worker = threading.Thread(target=lambda: first.append(next(chunks)))
    worker.start()
    worker.join()
    rows = len(first[0][0]) + sum(len(table) for table, _ in chunks)
    assert rows == N


def test_the_time_span_of_a_file_with_carriage_returns_only(tmp_path):
    from minparam_cli.measured.blocks import time_span
    from minparam_cli.measured.records import DataOptions

    lines = ["t,q1,q2,dq1,dq2,ddq1,ddq2,tau1,tau2"] + [f"{i / 100},1,1,1,1,1,1,1,1" for i in range(3000)]
    for newline in ("\n", "\r\n", "\r"):
        path = tmp_path / "d.csv"
        path.write_bytes(newline.join(lines).encode() + newline.encode())
        assert time_span(path, DataOptions()) == (0.0, 29.99), repr(newline)


def test_a_long_comment_line_is_not_the_bad_row(tmp_path):
    """numpy skips a comment of any length; the line named is the one it refused."""
    from minparam_cli.errors import DataError
    from minparam_cli.measured.blocks import load_all
    from minparam_cli.measured.records import DataOptions
    from minparam_cli.measured.tables import MAX_LINE_CHARS

    N = 3000
    path = tmp_path / "d.csv"
    _write_rows(path, np.arange(N) / 100.0)
    _bad_copy(path, 50, b"# " + b"c" * (MAX_LINE_CHARS + 10))
    _bad_copy(path, 1500, b"1,2,3,4,x,6,7,8,9")
    with pytest.raises(DataError) as err:
        load_all(path, 2, DataOptions(chunk_rows=700))
    assert str(err.value).endswith("non-numeric value 'x' on line 1500, column 5 (dq2)")
