"""Tables of measured data, read chunk by chunk from a file or from arrays: the layout of the used
columns, CSV (pyarrow's streaming reader, or numpy's loadtxt where pyarrow cannot be imported; then a
file larger than BACKGROUND_BYTES is parsed by a second process one chunk ahead), .npz and arrays in
memory, the checks on a data file, and the one-line errors of a bad header or row.  Below every
reader (``measured/reading.py`` dispatches by format, ``measured/*`` reads the other formats): it
imports none of them.
"""

from __future__ import annotations

import contextlib
import itertools
import signal
import sys
import threading
from pathlib import Path
from typing import Any, Generator, Iterator

import numpy as np

from minparam_cli.errors import ComputationError, DataError
from minparam_cli.measured.records import KEYS, DataOptions
from minparam_cli.measured.sniff import refuse_binary
from minparam_cli.runtime import BACKGROUND_BYTES  # numpy's reader: a CSV above it is parsed by a second process


def column_layout(present: dict[str, bool], n: int) -> dict[str, slice | int | None]:
    """Where each key lives in a chunk's table (columns t, q, [dq], [ddq], tau): an index, a slice or None."""
    out: dict[str, slice | int | None] = {}
    c = 0
    for k in KEYS:
        if not present[k]:
            out[k] = None
        elif k == "t":
            out[k], c = 0, 1
        else:
            out[k], c = slice(c, c + n), c + n
    return out


def split(table: np.ndarray, layout: dict) -> dict:
    return {k: (None if where is None else table[:, where]) for k, where in layout.items()}


def csv_tables(path: Path, rows: int) -> Generator[Any, None, None]:
    """A CSV file read in chunks of ``rows`` rows, every column: yields its header (a list of names)
    first, then the chunks (a file of exactly k chunks ends after them, without an empty one).  The
    one-line errors of a bad header or a bad row (with its line) are raised from here."""
    src = str(path)
    require_data_file(path)
    refuse_binary(path)
    try:
        fh = open(path, encoding="utf-8-sig", errors="strict")  # a byte-order mark (Excel's "CSV UTF-8") is not the header's
    except OSError as e:
        raise DataError(f"{src}: cannot read file ({e.strerror})") from e
    with fh:
        try:
            header_line = fh.readline(MAX_LINE_CHARS)
            if len(header_line) == MAX_LINE_CHARS and not header_line.endswith("\n"):
                raise DataError(f"{src}: line 1 (the header) is longer than {MAX_LINE_CHARS} characters")
        except UnicodeDecodeError as e:  # the decoder reads ahead: the bad byte may be in a data row
            header_line = _header_bytes(path).decode("utf-8-sig", "replace")
            if "\ufffd" in header_line:
                raise DataError(f"{src}: line 1 (the header) is not UTF-8 text") from e
            raise _bad_row(path, 2, header_line.strip().split(","), e) from e
        if not header_line.strip():
            raise DataError(f"{src}: empty file, expected a header row")
        header = header_line.strip().split(",")
        yield header
        chunks = _csv_chunks(path, fh, header_line, len(header), rows)
        line_no = 1
        try:
            while True:
                try:
                    chunk = next(chunks)
                except ValueError as e:  # loadtxt's row numbers count from the chunk: find the file line
                    raise _bad_row(path, line_no + 1, header, e) from e
                if chunk.size == 0:
                    break
                if chunk.shape[1] != len(header):
                    raise DataError(f"{src}: rows have {chunk.shape[1]} values, the header has {len(header)}")
                line_no += len(chunk)
                last = len(chunk) < rows
                yield chunk
                del chunk
                if last:
                    break
        finally:
            chunks.close()


def array_chunks(arrays: dict, src: str, n: int, opts: DataOptions) -> Iterator[tuple[np.ndarray, dict]]:
    """Chunks of whole arrays t (N,), q, [dq], [ddq], tau (N, n) (None where absent): an .npz file's, or
    arrays held in memory (``measured.arrays``); the same checks and messages for both."""
    for k in ("t", "q", "tau"):
        if arrays[k] is None:
            raise DataError(f"{src}: missing array '{opts.columns.get(k, k)}'")
    t = arrays["t"]
    if t.ndim != 1 and t.size == max(t.shape, default=0):  # a column or a row of time stamps
        t = arrays["t"] = t.reshape(-1)
    if t.ndim != 1:
        raise DataError(f"{src}: array '{opts.columns.get('t', 't')}' has shape {t.shape}, expected one time stamp a sample")
    N = len(t)
    if N == 0:
        raise DataError(f"{src}: no usable samples (array '{opts.columns.get('t', 't')}' is empty)")
    for k in KEYS[1:]:
        a = arrays[k]
        if a is not None:
            name = opts.columns.get(k, k)
            if a.ndim == 0 or a.shape[0] != N:
                raise DataError(f"{src}: array '{name}' has shape {a.shape}, expected ({N}, {n}): a row per time stamp, a column per joint")
            shape, a = a.shape, a.reshape(N, -1)
            if a.shape[1] != n:
                m = a.shape[1]
                raise DataError(f"{src}: the data have {m} joint{'s' if m != 1 else ''} (array '{name}' has shape {shape}), the robot has {n}")
            arrays[k] = a
    layout = column_layout({k: a is not None for k, a in arrays.items()}, n)
    used = [a.reshape(N, -1) for a in arrays.values() if a is not None]
    for s in range(0, N, opts.chunk_rows):
        yield np.hstack([a[s : s + opts.chunk_rows] for a in used]), layout


MAX_LINE_CHARS = 2**20
# arrays of an .npz file: their total size once decompressed (a "zip bomb" is refused before it is inflated)
MAX_NPZ_BYTES = 16 * 2**30


def require_data_file(path: Path) -> None:
    """A data file must be a regular file: a FIFO would wait for a writer, a device (/dev/zero,
    /dev/urandom) never ends, a folder is not data.  Refused at once, without opening it."""
    from minparam_cli.safety import require_regular_file

    require_regular_file(Path(path), DataError)


def short_error(e: BaseException) -> str:
    text = " ".join(str(e).split()) or type(e).__name__
    return text if len(text) <= 160 else text[:157] + "..."


@contextlib.contextmanager
def open_npz(path: Path):
    """np.load of an .npz archive (no pickles), every failure to open it a one-line DataError; refuses a
    file that is not an .npz archive (a lone .npy array, random bytes) and members whose declared
    size exceeds MAX_NPZ_BYTES."""
    src = str(path)
    try:
        with open(path, "rb") as fh:
            magic = fh.read(4)
    except OSError as e:
        raise DataError(f"{src}: cannot read file ({e.strerror})") from None
    if magic != b"PK\x03\x04":
        what = "a single .npy array" if magic.startswith(b"\x93NUM") else "empty" if not magic else "no arrays" if magic == b"PK\x05\x06" else "no zip header"
        raise DataError(f"{src}: not an .npz archive ({what}); expected arrays t, q, tau, ... saved by numpy.savez")
    try:
        z = np.load(path, allow_pickle=False)
    except MemoryError:
        raise
    except Exception as e:  # noqa: BLE001 - numpy and zipfile raise many kinds for a damaged file
        raise DataError(f"{src}: cannot read .npz ({short_error(e)})") from None
    if not isinstance(z, np.lib.npyio.NpzFile):
        raise DataError(f"{src}: not an .npz archive; expected arrays t, q, tau, ... saved by numpy.savez")
    with z:
        declared = sum(info.file_size for info in z.zip.infolist())  # type: ignore[union-attr,misc]  # numpy stubs: NpzFile.zip is None only once closed
        if declared > MAX_NPZ_BYTES:
            raise DataError(f"{src}: its arrays hold {declared} bytes once decompressed, more than the {MAX_NPZ_BYTES}-byte limit")
        yield z


def _header_bytes(path: Path) -> bytes:
    with open(path, "rb") as fh:
        return fh.readline(MAX_LINE_CHARS)


def _bad_row(path: Path, start_line: int, header: list[str], err: ValueError) -> DataError:
    """The first line at or after ``start_line`` (1-based, in the file) that loadtxt refuses,
    described in one line: not UTF-8, only whitespace, a wrong number of values, or a value that
    is not a number.  numpy itself judges each line, so the verdict is loadtxt's; this only finds
    the line.  Only on the error path: it reads the file again up to that line."""
    src = str(path)
    try:
        found = _first_bad_line(path, start_line, len(header))
    except OSError:
        found = None
    if found is None:
        return DataError(f"{src}: unreadable row after line {start_line - 1} ({err})")
    no, problem = found
    if isinstance(problem, tuple):  # a value that is not a number: (column, value)
        c, v = problem
        shown = repr(v if len(v) <= 40 else v[:40] + "...")
        return DataError(f"{src}: non-numeric value {shown} on line {no}, column {c + 1} ({header[c].strip()})")
    return DataError(f"{src}: line {no} {problem}")


def _first_bad_line(path: Path, start_line: int, width: int):
    """(line number, problem text or (column, value)) of the first line loadtxt refuses, or None."""
    batch: list[tuple[int, str]] = []
    # universal newlines as the reader; undecodable bytes become lone surrogates instead of an error
    with open(path, encoding="utf-8", errors="surrogateescape") as fh:
        no = 0
        while True:
            line = fh.readline(MAX_LINE_CHARS)
            if not line:
                break
            no += 1
            if len(line) == MAX_LINE_CHARS and not line.endswith("\n"):  # a long line
                if no >= start_line and not line.lstrip().startswith("#"):
                    return no, f"is longer than {MAX_LINE_CHARS} characters"
                while len(line) == MAX_LINE_CHARS and not line.endswith("\n"):  # skip its rest
                    line = fh.readline(MAX_LINE_CHARS)
                continue
            if no < start_line:
                continue
            batch.append((no, line.rstrip("\n")))
            if len(batch) == 1000:
                bad = _judge(batch, width)
                if bad is not None:
                    return bad
                batch = []
    return _judge(batch, width) if batch else None


def _judge(batch: list[tuple[int, str]], width: int):
    """The first line of ``batch`` that loadtxt refuses (or reads at another width), or None."""
    if _loads([text for _, text in batch], width):
        return None
    for no, text in batch:
        if any("\udc80" <= ch <= "\udcff" for ch in text):
            return no, "is not UTF-8 text"
        if _loads([text], width):
            continue
        if not text.strip():
            return no, "holds only whitespace"
        values = text.split("#", 1)[0].split(",")
        if len(values) != width:
            return no, f"has {len(values)} values, the header has {width}"
        for c, v in enumerate(values):
            if not v or not _loads([v], 1):
                return no, (c, v)
        return no, "cannot be read"
    return None


def _loads(lines: list[str], width: int) -> bool:
    """Whether loadtxt reads these lines, as rows of ``width`` values (or as no rows at all)."""
    lines = [text for text in lines if _has_data(text)]  # loadtxt warns when it is given no data
    if not lines:
        return True
    try:
        table = np.loadtxt(lines, delimiter=",", ndmin=2)
    except ValueError:
        return False
    return table.size == 0 or table.shape[1] == width


def _has_data(line: str) -> bool:
    """Whether loadtxt (delimiter ",", comments "#") finds a row in this line: not when it is empty,
    a line end or a comment from its first character on (a line of blanks is a row, and an error)."""
    return line[:1] not in "#\r\n"  # "" is in every string


def _csv_chunks(path: Path, fh, header_line: str, width: int, rows: int) -> Generator[np.ndarray, None, None]:
    """The file's chunks of ``rows`` rows (every column), past the header: pyarrow's reader
    (``measured.arrow_csv``) while it reads every line as numbers, numpy from the start of the
    first chunk where it does not (the same chunks, values and errors; ValueError on a bad row)."""
    from minparam_cli.measured import arrow_csv

    pacsv = arrow_csv.csv_module()
    raw = _header_bytes(path) if pacsv is not None else b""
    try:
        same = raw.endswith(b"\n") and raw.decode("utf-8-sig").replace("\r\n", "\n") == header_line
    except UnicodeDecodeError:
        same = False
    if pacsv is None or not same:  # no pyarrow, or a header line that is not \n-terminated as the reader's
        background = path.stat().st_size > BACKGROUND_BYTES and sys.platform.startswith("linux")
        yield from _background(path, rows) if background else _sequential(fh, rows)
        return
    for offset, table in arrow_csv.tables(pacsv, path, len(raw), rows, width):
        if table is None:  # numpy from here: its chunks start where this table starts
            import io

            with io.TextIOWrapper(open(path, "rb"), encoding="utf-8", errors="strict") as rest:
                rest.buffer.seek(offset)
                yield from _sequential(rest, rows)
            return
        yield table
        del table


def _loadtxt(fh, rows: int) -> np.ndarray:
    """The next ``rows`` rows of the open file (fewer at its end; none, as loadtxt's empty table, past it).
    Lines with no data are skipped and not counted here, as loadtxt's ``max_rows`` would, because loadtxt
    warns about each of them, and about an empty read (a file of exactly k chunks ends on one)."""
    lines = _data_lines(fh, rows)
    first = next(lines, None)
    if first is None:
        return np.empty((0, 1))
    return np.loadtxt(itertools.chain((first,), lines), delimiter=",", ndmin=2)


def _data_lines(fh, rows: int) -> Iterator[str]:
    """The file's next ``rows`` lines that hold data (no line read past the last of them)."""
    taken = 0
    for line in fh:
        if _has_data(line):
            yield line
            taken += 1
            if taken == rows:
                return


def _sequential(fh, rows: int) -> Iterator[np.ndarray]:
    """Chunks of ``rows`` rows parsed here, from the open file (past its header); ValueError on bad values."""
    while True:
        chunk = _loadtxt(fh, rows)
        last = chunk.size == 0 or len(chunk) < rows
        yield chunk
        del chunk
        if last:
            return


def _parse_worker(path: str, rows: int, out, theirs) -> None:
    """The second process: parse the file's chunks in order into ``out`` (a pipe's sending end);
    an error ends it.  ``theirs`` is the reading process's end, inherited by the fork: closed here,
    so that when the reading process is gone the next send fails and this process ends too."""
    theirs.close()
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the reading process handles Ctrl-C and ends this one
    try:
        with open(path, encoding="utf-8", errors="strict") as fh:
            fh.readline()
            for chunk in _sequential(fh, rows):
                out.send(chunk)
        return
    except BrokenPipeError:  # the reading process has gone (ended early, killed): nothing to tell
        return
    except ValueError as e:
        message = ("ValueError", str(e))
    except OSError as e:
        message = ("OSError", str(e))
    with contextlib.suppress(BrokenPipeError):
        out.send(message)


def _background(path: Path, rows: int) -> Iterator[np.ndarray]:
    """The same chunks as ``_sequential``, parsed one ahead by a second process.

    A one-way pipe, of which each process keeps one end: if the second process dies (killed, out
    of memory) the read here ends at once with EOF instead of waiting for a message that never
    comes; if this process ends, the second one's next send fails and it ends too.
    """
    import multiprocessing as mp

    # fork, from identify's reading thread (identify.ahead) when it takes its first chunk: the other
    # thread is then waiting for that chunk, holding no lock, and the child runs only the file read
    # and numpy's parser (forkserver would also lose the tests' stand-in workers)
    ctx = mp.get_context("fork")
    recv, send = ctx.Pipe(duplex=False)  # the child's send waits until the last chunk is taken
    proc = ctx.Process(target=_parse_worker, args=(str(path), rows, send, recv), daemon=True)
    proc.start()
    send.close()
    try:
        while True:
            try:
                item = recv.recv()
            except (EOFError, OSError):
                proc.join()
                raise ComputationError(
                    f"{path}: the parsing process ended unexpectedly (exit code {proc.exitcode})"
                ) from None
            if isinstance(item, tuple):
                if item[0] == "ValueError":
                    raise ValueError(item[1])
                raise DataError(f"{path}: cannot read file ({item[1]})")
            last = item.size == 0 or len(item) < rows
            yield item
            del item
            if last:
                return
    finally:
        with _no_interrupt():  # a second Ctrl-C must not cut the cleanup short (and print a traceback)
            recv.close()
            if proc.is_alive():
                proc.terminate()
            proc.join()


@contextlib.contextmanager
def _no_interrupt():
    """Ctrl-C ignored for the duration (main thread only; elsewhere nothing changes)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)
