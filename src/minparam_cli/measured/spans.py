"""The first and last time stamps of an .npz, Parquet or CSV file without reading it all (CSV: its
head and tail), for the hold-out split (``identify.data.time_span``) and described recordings."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from minparam_cli.errors import DataError
from minparam_cli.measured.records import DataOptions

TAIL_BYTES = 65536  # how much of the head and of the tail time_span reads



def file_time_span(path: Path, name: str, opts: DataOptions) -> tuple[float, float]:
    """time_span of an .npz or CSV file, in the file's time unit."""
    from minparam_cli.measured.tables import short_error, open_npz, require_data_file
    from minparam_cli.measured.columns import time_index

    if path.suffix.lower() == ".parquet":
        from minparam_cli.measured.parquet import parquet_time_span

        return parquet_time_span(path, name)
    require_data_file(path)
    if path.suffix.lower() == ".npz":
        with open_npz(path) as z:
            try:
                t = np.asarray(z[name], dtype=float)
            except MemoryError:
                raise
            except Exception as e:  # noqa: BLE001 - a missing or damaged member
                raise DataError(f"{path}: cannot read time array '{name}' ({short_error(e)})") from None
        t = t[np.isfinite(t)]
        if len(t) < 2:
            raise DataError(f"{path}: fewer than two time stamps")
        return float(t.min()), float(t.max())
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
