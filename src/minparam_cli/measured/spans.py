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
    from minparam_cli.measured.tables import require_data_file
    from minparam_cli.measured.columns import time_index

    require_data_file(path)
    try:
        with open(path, "rb") as fh:
            raw = fh.read(TAIL_BYTES)
            head = _lines(raw)
            if len(raw) == TAIL_BYTES:
                head = head[:-1]  # it may be cut
            header = (head[0] if head else "").strip().split(",")
            head = head[1:]
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
