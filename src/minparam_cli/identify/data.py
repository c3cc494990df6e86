"""Measured joint data: reading (CSV or .npz, in chunks), cleaning, filtering, differentiation.

Pipeline per chunk, with a margin of neighbouring samples so that chunk edges
do not show:

1. drop rows with NaN in a used column, rows whose time does not increase,
   and repeated samples (sample-and-hold logging: q, q̇ and τ identical to the
   previous row);
2. when q̇ or q̈ must be computed: resample onto a uniform grid at the median
   step (linear interpolation; irregular steps are counted), low-pass q, q̇ and
   τ with the same zero-phase Butterworth filter (scipy.signal.sosfiltfilt),
   differentiate (central differences), and decimate so that the kept rate is
   about ten times the cut-off;
3. yield blocks of (t, q, dq, ddq, tau).

Everything dropped is counted and reported, with the reason.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterator

import numpy as np

from minparam_cli.errors import DataError

DEFAULT_CUTOFF_HZ = 5.0
FILTER_ORDER = 4
CHUNK_ROWS = 200_000
KEYS = ("t", "q", "dq", "ddq", "tau")


@dataclass(frozen=True)
class DataOptions:
    columns: dict[str, str] = field(default_factory=dict)  # key -> column name (t) or prefix (q, dq, ...)
    cutoff_hz: float = DEFAULT_CUTOFF_HZ
    force_filter: bool = False
    chunk_rows: int = CHUNK_ROWS
    decimate: int | None = None  # None: automatic (about 10x the cut-off)
    step_s: float | None = None  # sampling step; None: median step of the first chunk


@dataclass
class Block:
    t: np.ndarray
    q: np.ndarray
    dq: np.ndarray
    ddq: np.ndarray
    tau: np.ndarray

    def __len__(self) -> int:
        return len(self.t)

    def take(self, idx) -> "Block":
        return Block(self.t[idx], self.q[idx], self.dq[idx], self.ddq[idx], self.tau[idx])

    @staticmethod
    def concat(blocks: list["Block"]) -> "Block":
        return Block(*(np.concatenate([getattr(b, k) for b in blocks]) for k in KEYS))


@dataclass
class DataReport:
    """What happened to the file: counts and choices, for the report."""

    path: str
    rows_read: int = 0
    dropped: dict = field(default_factory=lambda: {"nan": 0, "time_not_increasing": 0, "repeated_sample": 0})
    irregular_steps: int = 0
    median_step_s: float | None = None
    derived: list = field(default_factory=list)
    filter: str | None = None
    decimation: int = 1
    samples: int = 0

    def as_dict(self) -> dict:
        return {
            "rows_read": self.rows_read,
            "dropped": dict(self.dropped),
            "irregular_steps": self.irregular_steps,
            "median_step_s": self.median_step_s,
            "derived": list(self.derived),
            "filter": self.filter,
            "decimation": self.decimation,
            "samples": self.samples,
        }


def _clean(table: np.ndarray, last: np.ndarray | None, report: DataReport) -> tuple[np.ndarray, np.ndarray | None]:
    """Drop NaN, non-increasing times and repeated samples; ``last`` is the previous kept row.

    ``table``: the used columns, time first.  Rows are copied only when some are dropped.
    """
    report.rows_read += len(table)
    ok = np.isfinite(table).all(axis=1)
    if not ok.all():
        report.dropped["nan"] += int((~ok).sum())
        table = table[ok]
    # compare every row with the row before it (the first with the previous chunk's last kept row)
    if len(table):
        repeated = np.empty(len(table), dtype=bool)
        repeated[0] = last is not None and bool(np.all(table[0, 1:] == last[1:]))
        np.all(table[1:, 1:] == table[:-1, 1:], axis=1, out=repeated[1:])
        if repeated.any():
            report.dropped["repeated_sample"] += int(repeated.sum())
            table = table[~repeated]
    # time must increase: keep the running maximum rule
    t_prev = last[0] if last is not None else -np.inf
    tt = table[:, 0]
    if len(tt) and not (tt[0] > t_prev and np.all(tt[1:] > tt[:-1])):
        running = np.maximum.accumulate(np.concatenate([[t_prev], tt]))[:-1]
        increasing = tt > running
        report.dropped["time_not_increasing"] += int((~increasing).sum())
        table = table[increasing]
    new_last = table[-1].copy() if len(table) else last
    return table, new_last


TAIL_BYTES = 65536  # how much of the head and of the tail time_span reads


def time_span(path: str | Path, opts: DataOptions) -> tuple[float, float]:
    """First and last usable time stamp of a data file without reading it all (CSV: its head and tail).

    The last is the largest finite time in the tail, so that a final row the cleaning drops (a NaN
    row, a time stamp that jumps back) does not move the hold-out split.
    """
    path = Path(path)
    name = opts.columns.get("t", "t")
    if path.suffix.lower() == ".npz":
        try:
            with np.load(path, allow_pickle=False) as z:
                t = np.asarray(z[name], dtype=float)
        except (OSError, ValueError, KeyError) as e:
            raise DataError(f"{path}: cannot read time array '{name}' ({e})") from e
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
    names = [h.strip() for h in header]
    if name not in names:
        raise DataError(f"{path}: missing time column '{name}' (use --columns t=NAME)")
    k = names.index(name)
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


def iter_blocks(path: str | Path, n: int, opts: DataOptions, report: DataReport | None = None) -> Iterator[Block]:
    """Clean, filter and differentiate the file chunk by chunk; memory bounded by the chunk size."""
    from minparam_cli.identify.filtering import Processor
    from minparam_cli.identify.reading import raw_chunks, split

    path = Path(path)
    report = report if report is not None else DataReport(str(path))
    last = None
    processor = None
    step = None
    for table, layout in raw_chunks(path, n, opts):
        if step is None and opts.step_s:
            step = float(opts.step_s)
        if step is None:
            # the sampling step from the raw time stamps (sample-and-hold rows have proper stamps)
            t = table[:, 0]
            d = np.diff(t[np.isfinite(t)])
            d = d[d > 0]
            step = float(np.median(d)) if len(d) else None
        table, last = _clean(table, last, report)
        if len(table) == 0:
            continue
        clean = split(table, layout)
        if processor is None:
            processor = Processor(clean, opts, report, step)
        yield from processor.push(clean)
        del table, clean  # not alive while the next chunk is read: memory is one chunk, not two
    if processor is None:
        raise DataError(f"{path}: no usable samples (every row was dropped or the file has no data)")
    yield from processor.finish()


def load_all(path: str | Path, n: int, opts: DataOptions, report: DataReport | None = None) -> Block:
    blocks = list(iter_blocks(path, n, opts, report))
    return Block.concat(blocks)
