"""Output files and progress, shared by the CLI and the Python API (below both on the map).

Atomic writes that never leave a partial file and never replace what is not a regular file
(symlinks are followed, special files written through, ``-`` is stdout), and a minimal progress bar
on stderr.  No command-line parsing here: the commands import these from this module.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path
from typing import Callable, Iterator

from minparam_cli.errors import ComputationError, InputError

STDOUT = "-"  # `-o -`: the output goes to stdout


def is_stdout(path) -> bool:
    """True for the output name ``-`` (stdout)."""
    return path is not None and str(path) == STDOUT


def output_target(path: Path) -> tuple[Path, bool]:
    """Where an output name really writes, and whether that is a regular file to replace atomically.

    A symlink (or a chain of them) is followed to its target, so that the link stays a link and
    its target receives the new contents.  A character device, FIFO, socket or other special file
    is written through in place (``-o /dev/null``, a named pipe): it cannot be replaced by a rename.
    A folder, a link loop, or a missing output folder is refused before any work is done."""
    path = Path(path)
    target = Path(os.path.realpath(path)) if path.is_symlink() else path
    if path.is_symlink() and target.is_symlink():  # realpath gave up: a loop
        raise InputError(f"{path}: symbolic link loop; expected an output file name")
    if target.is_dir():
        raise InputError(f"{path}: is a folder; expected an output file name")
    if target.exists() and not target.is_file():
        return target, False
    directory = target.parent if str(target.parent) else Path(".")
    if not directory.is_dir():
        where = f"output folder {directory}" if target == path else f"the folder {directory} of its link target"
        raise InputError(f"{path}: {where} does not exist")
    return target, True


def check_output_path(path: Path) -> None:
    """An output file name must name a file in an existing folder (or ``-``, or a special file);
    refused before any work is done (a command that writes two files checks both first, so that a
    failure leaves neither)."""
    if not is_stdout(path):
        output_target(Path(path))


def output_folder(path: Path, flag: str) -> Path:
    """A folder for output files (``identify --plot figs/``), created with its parents when missing.

    An existing file of that name, or a folder that cannot be created, is refused in one line."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise InputError(f"{flag} {path}: exists and is not a folder")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise InputError(f"{flag} {path}: cannot create the folder ({e.strerror})") from None
    return path


@contextlib.contextmanager
def staged_folder(path: Path | None) -> Iterator[Path | None]:
    """Write the files meant for folder ``path`` into the yielded temporary folder, made beside it (in
    its parent: the same file system); they are moved into ``path`` only when the block ends without
    an error, so an interrupted command (Ctrl-C) or a failed one leaves none of them.  Each move is
    atomic (os.replace), the set is moved in one go after the command's work.  ``None``: nothing."""
    if path is None:
        yield None
        return
    path = Path(path)
    stage = Path(tempfile.mkdtemp(prefix=f".{path.resolve().name}.", suffix=".part", dir=path.resolve().parent))
    try:
        yield stage
        for f in sorted(stage.iterdir()):
            os.replace(f, path / f.name)
    finally:
        shutil.rmtree(stage, ignore_errors=True)


def atomic_write(path: Path, write: Callable[[str], object], suffix: str = ".tmp") -> None:
    """Write one output file, never leaving a partial one.

    ``write`` fills the file named by its argument.  For a regular file (new or existing, or the
    target of a symlink) that is a temporary file in the same folder, renamed over the target; the
    file keeps its permission bits if it existed, otherwise it gets 0666 less the umask.  A special
    file (a device, a FIFO) is written through directly.  ``-`` writes to stdout (through a
    temporary file, so that ``write`` may be any file writer)."""
    import tempfile  # only when writing a file: not on the start-up path of every command

    if is_stdout(path):
        _write_stdout(write, suffix)
        return
    path = Path(path)
    target, regular = output_target(path)
    if not regular:
        try:
            write(str(target))
        except OSError as e:
            raise ComputationError(f"{path}: cannot write ({e.strerror})") from None
        return
    directory = target.parent if str(target.parent) else Path(".")
    try:
        mode = target.stat().st_mode & 0o7777 if target.exists() else None
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=suffix, dir=directory)
    except OSError as e:
        raise ComputationError(f"{path}: cannot write ({e.strerror})") from None
    os.close(fd)
    try:
        write(tmp)
        if mode is None:
            umask = os.umask(0)
            os.umask(umask)
            mode = 0o666 & ~umask  # mkstemp makes 0600; give a new file the usual permissions
        os.chmod(tmp, mode)
        os.replace(tmp, target)
    except OSError as e:
        raise ComputationError(f"{path}: cannot write ({e.strerror})") from None
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def _write_stdout(write: Callable[[str], object], suffix: str) -> None:
    """Run ``write`` on a temporary file, then copy its bytes to stdout."""
    import shutil
    import tempfile

    fd, tmp = tempfile.mkstemp(prefix=".minparam-stdout.", suffix=suffix)
    os.close(fd)
    try:
        write(tmp)
        sys.stdout.flush()
        with open(tmp, "rb") as fh:
            shutil.copyfileobj(fh, sys.stdout.buffer)
        sys.stdout.buffer.flush()
    finally:
        os.unlink(tmp)


def write_output(text: str, output: Path | None) -> None:
    """Write to stdout (no output, or ``-``), or to ``output`` through ``atomic_write``."""
    text = text if text.endswith("\n") else text + "\n"
    if output is None or is_stdout(output):
        sys.stdout.write(text)
        sys.stdout.flush()
        return
    atomic_write(Path(output), lambda tmp: Path(tmp).write_text(text, encoding="utf-8"))


def write_outputs(files: dict[Path, str]) -> None:
    """Write several regular files together (an export and its side file): every one is written to a
    temporary file in its folder first, and only when all are written are they renamed into place,
    so that a failure leaves none of them changed."""
    import tempfile

    done: list[tuple[str, Path]] = []
    try:
        for path, text in files.items():
            target, regular = output_target(Path(path))
            if not regular:
                raise InputError(f"{path}: not a regular file; an export and its side file are replaced together")
            fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent if str(target.parent) else ".")
            done.append((tmp, target))
            with os.fdopen(fd, "w", encoding="utf-8") as fh:
                fh.write(text if text.endswith("\n") else text + "\n")
            mode = target.stat().st_mode & 0o7777 if target.exists() else 0o666 & ~_umask()
            os.chmod(tmp, mode)
        for tmp, target in done:
            os.replace(tmp, target)
    except OSError as e:
        raise ComputationError(f"cannot write {', '.join(str(p) for p in files)} ({e.strerror})") from None
    finally:
        for tmp, _ in done:
            if os.path.exists(tmp):
                os.unlink(tmp)


def _umask() -> int:
    umask = os.umask(0)
    os.umask(umask)
    return umask


class Progress:
    """A minimal progress bar on stderr.

    Silent when ``quiet``, when stderr is not a terminal, or until ``delay``
    seconds have passed (short runs print nothing).
    """

    def __init__(self, total: int, label: str, quiet: bool = False, delay: float = 1.0):
        self.total = max(int(total), 1)
        self.label = label
        self.enabled = not quiet and sys.stderr.isatty()
        self.start = time.perf_counter()
        self.delay = delay
        self.done = 0
        self.shown = False

    def __call__(self, done: int, total: int | None = None) -> None:
        if total is not None:
            self.total = max(int(total), 1)
        self.done = done
        if not self.enabled:
            return
        elapsed = time.perf_counter() - self.start
        if elapsed < self.delay and done < self.total:
            return
        frac = min(done / self.total, 1.0)
        width = 30
        bar = "#" * int(frac * width) + "-" * (width - int(frac * width))
        sys.stderr.write(f"\r{self.label} [{bar}] {done}/{self.total} {elapsed:5.1f}s")
        sys.stderr.flush()
        self.shown = True

    def close(self) -> None:
        if self.shown:
            sys.stderr.write("\n")
            sys.stderr.flush()


def write_code_files(files: dict[str, str], lang: str, output: Path | None) -> list[Path]:
    """Write generated code as ``codegen -o output`` does (C: FILE.h and FILE.c; otherwise one file,
    or stdout for None or "-"), each atomically; returns the paths written."""
    if lang == "c":
        assert output is not None
        h, c = output.with_suffix(".h"), output.with_suffix(".c") if output.suffix != ".c" else output
        write_output(files[".h"], h)
        write_output(files[".c"], c)
        return [c, h]
    write_output(files[".py"], output)
    return [] if output is None or is_stdout(output) else [output]


def columns(rows: list[tuple], headers: tuple[str, ...] | None = None, right: tuple[int, ...] = ()) -> str:
    """Rows of cells as left-aligned columns (right-aligned for indices in ``right``), with a dashed
    rule under the headers when given.

    tabulate renders every other table; this one is on the hot path of `minparam derive`, where
    importing tabulate (it pulls importlib.metadata and html) costs more than the whole base-set
    computation."""
    cells = [[str(c) for c in r] for r in rows]
    if headers:
        cells.insert(0, list(headers))
    if not cells:
        return ""
    widths = [max(len(r[i]) for r in cells) for i in range(len(cells[0]))]

    def line(r):
        parts = [c.rjust(w) if i in right else c.ljust(w) for i, (c, w) in enumerate(zip(r, widths, strict=True))]
        return "  ".join(parts).rstrip()

    out = [line(r) for r in cells]
    if headers:
        out.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(out)
