"""`-o PATH` and every other output file: one function (output.atomic_write) for every command.

Regular files are replaced atomically (temporary file + rename in the same folder) and keep their
permission bits; a symlink is followed and its target replaced; a FIFO (or another special file)
is written through; `-o -` is stdout; a folder, a missing folder or a link loop is refused with one
line and exit 2; a failed write leaves no file.  Only files made in a temporary folder are used.
"""

from __future__ import annotations

import json
import os
import stat
import threading
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from minparam_cli.output import atomic_write, write_output
from minparam_cli.errors import ComputationError, InputError

runner = CliRunner()
PLANAR = "robots/planar2r.yaml"


@pytest.fixture(scope="module")
def app():
    from minparam_cli.cli.app import app as real_app

    return real_app


def leftovers(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


class FifoReader:
    """Read a FIFO to its end in a thread (the writer's open blocks until a reader opens)."""

    def __init__(self, path: Path):
        self.data = b""
        self.thread = threading.Thread(target=self._read, args=(path,), daemon=True)
        self.thread.start()

    def _read(self, path):
        with open(path, "rb") as fh:
            self.data = fh.read()

    def result(self) -> bytes:
        self.thread.join(timeout=60)
        assert not self.thread.is_alive()
        return self.data


# --- the function ----------------------------------------------------------------------------------


def test_a_new_regular_file_gets_0666_less_the_umask(tmp_path):
    out = tmp_path / "new.txt"
    write_output("hello", out)
    assert out.read_text() == "hello\n"
    umask = os.umask(0)
    os.umask(umask)
    assert stat.S_IMODE(out.stat().st_mode) == 0o666 & ~umask
    assert leftovers(tmp_path) == []


def test_an_existing_file_is_replaced_by_rename_and_keeps_its_permissions(tmp_path):
    out = tmp_path / "old.txt"
    out.write_text("old contents, longer than the new ones\n")
    os.chmod(out, 0o640)
    inode = out.stat().st_ino
    write_output("new", out)
    assert out.read_text() == "new\n"
    assert stat.S_IMODE(out.stat().st_mode) == 0o640
    assert out.stat().st_ino != inode  # a new file renamed over the old one, not rewritten in place
    assert leftovers(tmp_path) == []


def test_a_symlink_is_followed_and_its_target_replaced(tmp_path):
    (tmp_path / "real").mkdir()
    target = tmp_path / "real" / "report.txt"
    target.write_text("old\n")
    link = tmp_path / "link.txt"
    link.symlink_to(target)
    write_output("new", link)
    assert link.is_symlink() and os.readlink(link) == str(target)
    assert target.read_text() == "new\n"
    assert leftovers(tmp_path) == [] and leftovers(tmp_path / "real") == []


def test_a_chain_of_symlinks_and_a_dangling_one(tmp_path):
    target = tmp_path / "t.txt"
    (tmp_path / "a").symlink_to(tmp_path / "b")
    (tmp_path / "b").symlink_to(target)  # dangling: the target is created
    write_output("x", tmp_path / "a")
    assert target.read_text() == "x\n"
    assert (tmp_path / "a").is_symlink() and (tmp_path / "b").is_symlink()


def test_a_symlink_into_a_missing_folder_or_a_loop_is_refused(tmp_path):
    (tmp_path / "l").symlink_to(tmp_path / "nowhere" / "x.txt")
    with pytest.raises(InputError, match="folder .*nowhere of its link target does not exist"):
        write_output("x", tmp_path / "l")
    (tmp_path / "loop").symlink_to(tmp_path / "loop")
    with pytest.raises(InputError, match="symbolic link loop"):
        write_output("x", tmp_path / "loop")


def test_a_fifo_is_written_through(tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    reader = FifoReader(fifo)
    write_output("through the pipe", fifo)
    assert reader.result() == b"through the pipe\n"
    assert stat.S_ISFIFO(fifo.stat().st_mode)  # still the FIFO, not replaced by a file
    assert leftovers(tmp_path) == []


def test_dash_is_stdout(capsys):
    write_output("to stdout", Path("-"))
    assert capsys.readouterr().out == "to stdout\n"


def test_a_binary_writer_to_dash_goes_to_stdout(capsysbinary):
    atomic_write(Path("-"), lambda tmp: Path(tmp).write_bytes(b"\x00\x01binary"))
    assert capsysbinary.readouterr().out == b"\x00\x01binary"


def test_a_folder_or_a_missing_folder_is_refused(tmp_path):
    with pytest.raises(InputError, match="is a folder"):
        write_output("x", tmp_path)
    with pytest.raises(InputError, match="output folder .* does not exist"):
        write_output("x", tmp_path / "no" / "x.txt")


def test_a_failed_write_leaves_neither_a_file_nor_a_temporary(tmp_path):
    out = tmp_path / "x.bin"

    def fail(tmp):
        Path(tmp).write_bytes(b"half")
        raise OSError(28, "No space left on device")

    with pytest.raises(ComputationError, match="cannot write"):
        atomic_write(out, fail)
    assert list(tmp_path.iterdir()) == []
    out.write_text("kept\n")
    with pytest.raises(ComputationError):
        atomic_write(out, fail)
    assert out.read_text() == "kept\n"  # the old file is untouched
    assert leftovers(tmp_path) == []


# --- through the commands --------------------------------------------------------------------------


def test_derive_writes_through_a_symlink_and_to_dash(app, tmp_path):
    target = tmp_path / "rep.json"
    link = tmp_path / "link.json"
    link.symlink_to(target)
    r = runner.invoke(app, ["derive", PLANAR, "--format", "json", "-o", str(link)])
    assert r.exit_code == 0, r.output
    assert link.is_symlink() and json.loads(target.read_text())["n_base"] > 0
    r = runner.invoke(app, ["derive", PLANAR, "--format", "json", "-o", "-"])
    assert r.exit_code == 0 and json.loads(r.stdout)["n_base"] > 0


def test_simulate_csv_to_dash_and_truth_through_a_symlink(app, tmp_path):
    truth = tmp_path / "truth.json"
    link = tmp_path / "t.json"
    link.symlink_to(truth)
    r = runner.invoke(app, ["simulate", PLANAR, "--duration", "1", "-o", "-", "--truth", str(link), "-q"])
    assert r.exit_code == 0, r.output
    assert r.stdout.startswith("t,q1,q2,")
    assert link.is_symlink() and json.loads(truth.read_text())["seed"] == 0


def test_simulate_npz_through_a_symlink_and_into_a_fifo(app, tmp_path):
    target = tmp_path / "data.npz"
    link = tmp_path / "link.npz"
    link.symlink_to(target)
    r = runner.invoke(app, ["simulate", PLANAR, "--duration", "1", "-o", str(link), "-q"])
    assert r.exit_code == 0, r.output
    assert link.is_symlink() and np.load(target)["q"].shape[1] == 2
    fifo = tmp_path / "pipe.csv"
    os.mkfifo(fifo)
    reader = FifoReader(fifo)
    r = runner.invoke(app, ["simulate", PLANAR, "--duration", "1", "-o", str(fifo), "-q"])
    assert r.exit_code == 0, r.output
    assert reader.result().startswith(b"t,q1,q2,")
    assert leftovers(tmp_path) == []


def test_simulate_refuses_truth_on_stdout_beside_the_data(app):
    r = runner.invoke(app, ["simulate", PLANAR, "--truth", "-"])
    assert r.exit_code == 2
    assert r.stderr.strip().splitlines() == ["minparam: error: --truth -: the data already go to stdout; give --truth or -o a file name"]


@pytest.mark.parametrize("where", ["folder", "missing", "loop"])
def test_every_command_refuses_a_bad_output_before_any_work(app, tmp_path, where):
    bad = {"folder": tmp_path, "missing": tmp_path / "no" / "x.txt", "loop": tmp_path / "loop.csv"}[where]
    if where == "loop":
        bad.symlink_to(bad)
    lines = [
        ["derive", PLANAR, "-o", str(bad)],
        ["simulate", PLANAR, "--duration", "1", "-o", str(bad) if where != "missing" else str(bad.with_suffix(".csv"))],
        ["simulate", PLANAR, "--duration", "1", "-o", str(tmp_path / "ok.csv"), "--truth", str(bad)],
        ["singular", PLANAR, "--q", "10,20", "-o", str(bad)],
        ["platform", "ik", "robots/dodekapod_dang2013.yaml", "--pose", "0,0,200,5,-3,10", "-o", str(bad)],
    ]
    for argv in lines:
        r = runner.invoke(app, argv)
        assert r.exit_code == 2, (argv, r.output)
        assert len(r.stderr.strip().splitlines()) == 1 and "Traceback" not in r.output, r.output
    assert not (tmp_path / "ok.csv").exists()
