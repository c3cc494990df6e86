"""The first and last time stamps of a CSV file without reading it all: its head and tail, for the
hold-out split (``measured.readers.Csv.time_span``) and described recordings."""

from __future__ import annotations

import math
from pathlib import Path

from minparam_cli.errors import DataError
from minparam_cli.measured.records import DataOptions

TAIL_BYTES = 65536  # how much of the head and of the tail time_span reads


def csv_time_span(path: Path, opts: DataOptions) -> tuple[float, float]:
    """First and last finite time stamps of a CSV file (its head and tail; the time column as
    ``opts.columns`` names it), in the file's time unit."""
    from minparam_cli.measured.tables import MAX_LINE_CHARS, require_data_file
    from minparam_cli.measured.columns import time_index
    from minparam_cli.measured.sniff import refuse_binary

    require_data_file(path)
    refuse_binary(path)
    try:
        with open(path, "rb") as fh:
            line1 = _header_line(fh, MAX_LINE_CHARS)  # the header alone: it may be longer than TAIL_BYTES
            if line1 is None:
                raise DataError(f"{path}: line 1 (the header) is longer than {MAX_LINE_CHARS} characters")
            if "\ufffd" in line1:
                raise DataError(f"{path}: line 1 (the header) is not UTF-8 text")
            header = line1.strip().split(",")
            raw = fh.read(TAIL_BYTES)
            head = _lines(raw)
            if len(raw) == TAIL_BYTES:
                head = head[:-1]  # it may be cut
            fh.seek(0, 2)
            size = fh.tell()
            start = max(0, size - TAIL_BYTES)
            fh.seek(start)
            tail = _lines(fh.read())
    except OSError as e:
        raise DataError(f"{path}: cannot read file ({e.strerror})") from e
    if start > 0:
        tail = tail[1:]  # the window starts inside a line: its first fragment is not a row
    k = time_index(header, len(opts.joint_names), opts.columns, str(path))
    first = next((t for t in (_time_of(line, k) for line in head) if t is not None), None)
    last = max((t for t in (_time_of(line, k) for line in tail) if t is not None), default=None)
    if first is None or last is None:
        raise DataError(f"{path}: cannot read the first and last time stamps (no row with a finite time)")
    return first, last


def _header_line(fh, limit: int) -> str | None:
    """The file's first line (at \\n, \\r\\n or \\r, as the reader's universal newlines), without a
    byte-order mark, the file left at the start of the next line; None when it is ``limit``
    characters long or longer."""
    import codecs

    data = b""
    while True:
        piece = fh.read(TAIL_BYTES)
        end = min((i for i in (piece.find(b"\n"), piece.find(b"\r")) if i >= 0), default=-1)
        if end >= 0:
            stop = end + (2 if piece[end : end + 2] == b"\r\n" else 1)
            fh.seek(fh.tell() - len(piece) + stop)
            data += piece[:end]
            break
        data += piece
        if not piece or len(data) > 4 * limit:
            break
    if data.startswith(codecs.BOM_UTF8):
        data = data[len(codecs.BOM_UTF8):]
    text = data.decode("utf-8", "replace")
    return None if len(text) >= limit else text


def _lines(raw: bytes) -> list[str]:
    """Lines split at \\n, \\r\\n or \\r, as the reader's universal newlines (str.splitlines would also
    split at \\x1c, \\x85 or U+2028 inside a row)."""
    return [line.decode("utf-8", "replace") for line in raw.splitlines()]


def _time_of(line: str, k: int) -> float | None:
    """The finite time stamp of a data row, or None (blank, comment, too short, not a number); a row
    of the wrong width is the reader's to report, with its line."""
    values = line.split("#", 1)[0].split(",")
    if len(values) <= k:
        return None
    try:
        t = float(values[k])
    except ValueError:
        return None
    return t if math.isfinite(t) else None
