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
3. count, per joint, the samples in which the joint stands still (|q̇| below
   ``still_speed``) and, with ``trim_still_s``, drop every standstill of all
   joints that lasts longer than that (streamed: at most ``trim_still_s``
   seconds of samples are held back while a standstill's length is unknown);
4. yield blocks of (t, q, dq, ddq, tau).

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
# a time step that differs from the sampling step by more than this share (longer or shorter) is irregular
IRREGULAR_TOL = 0.1
STAMP_ULPS = 2  # two time stamps' steps that differ by at most this many units in the last place are the same step


@dataclass(frozen=True)
class DataOptions:
    columns: dict[str, str] = field(default_factory=dict)  # key -> column name (t) or spec (q, dq, ...: measured/columns.py)
    cutoff_hz: float = DEFAULT_CUTOFF_HZ
    force_filter: bool = False
    chunk_rows: int = CHUNK_ROWS
    decimate: int | None = None  # None: automatic (about 10x the cut-off)
    step_s: float | None = None  # sampling step; None: from the steps of the first chunk (see sampling_step)
    still_speed: float = 0.01  # rad/s or m/s: joint j is still at a sample when |dq_j| < still_speed
    trim_still_s: float | None = None  # drop every run of all-joints-still samples longer than this (s); None: keep all
    # a velocity derived by the filter (not read from the file) below still_speed is set to 0: the joint
    # is at rest as far as the data can tell, and sign(q̇) of the noise would put its Coulomb friction at ±Fc
    rest_below_still: bool = True
    time_unit: str = "s"  # unit of a CSV or .npz time column: s, ms, us or ns (measured.columns.TIME_UNITS)
    topic: str | None = None  # a ROS bag's JointState topic; None: the bag's only one
    joint_names: tuple[str, ...] = ()  # names of the independent coordinates, in order (ROS bags match by name)
    # motor-side data (identify --side motor): (N rows, zero, gains or None); q = N⁻¹θ + zero,
    # τ = Nᵀ diag(gains) τ_m, applied as the rows are read (dynamics/transmission.py); None: joint side
    motor_side: tuple | None = None


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
    samples: int = 0  # samples yielded (after decimation and standstill trimming)
    still_share: list = field(default_factory=list)  # per joint: share of the samples (before trimming) in which it is still
    still_all_share: float = 0.0  # share of the samples (before trimming) in which every joint is still
    trimmed_segments: int = 0  # standstills dropped by trim_still_s (their samples: dropped["standstill"])
    rest_below: float | None = None  # derived |q̇| below this speed was set to 0 (DataOptions.rest_below_still); None: not

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
            "still_share": [float(x) for x in self.still_share],
            "still_all_share": float(self.still_all_share),
            "trimmed_segments": self.trimmed_segments,
            "rest_below": self.rest_below,
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


def sampling_step(t: np.ndarray) -> float | None:
    """The sampling step of time stamps ``t`` (NaN and non-increasing steps ignored), or None.

    The median step, refined as the mean of the steps that equal it up to the rounding of the
    stamps (STAMP_ULPS units in the last place of the largest stamp).  The median alone carries
    that rounding: a double resolves raw controller stamps (t ≈ 1.7e9 s) to 0.24 µs, so a 2 ms step
    reads 1.99986 or 2.00010 ms and the median is one of them, which moves a long resampling grid
    by samples; the mean over those steps is the true step to the stamps' resolution divided by
    their count, so that a record and its re-zeroed copy are resampled alike.  Jitter larger than
    the rounding (logged stamps) is left out of the mean, which stays the median then.
    """
    t = t[np.isfinite(t)]
    d = np.diff(t)
    d = d[d > 0]
    if not len(d):
        return None
    med = float(np.median(d))
    same = d[np.abs(d - med) <= STAMP_ULPS * float(np.spacing(np.max(np.abs(t))))]
    return float(same.mean()) if len(same) else med


TAIL_BYTES = 65536  # how much of the head and of the tail time_span reads


def time_span(path: str | Path, opts: DataOptions) -> tuple[float, float]:
    """First and last usable time stamp of a data file without reading it all (CSV: its head and tail).

    The last is the largest finite time in the tail, so that a final row the cleaning drops (a NaN
    row, a time stamp that jumps back) does not move the hold-out split.
    """
    path = Path(path)
    name = opts.columns.get("t", "t")
    from minparam_cli.measured.columns import TIME_UNITS
    from minparam_cli.measured.rosbag import bag_time_span, is_bag

    from minparam_cli.measured.arrays import lookup

    record = lookup(path)  # data held in memory (the Python API)
    if record is None and is_bag(path):
        return bag_time_span(path, len(opts.joint_names), opts)
    from minparam_cli.measured.recording import is_description, recording_time_span

    if record is None and is_description(path):  # CSV files joined by a description (measured/recording.py)
        return recording_time_span(path, opts)
    if record is not None:
        from minparam_cli.measured.arrays import time_span as record_span

        first, last = record_span(record, len(opts.joint_names), opts)
    else:
        first, last = _file_time_span(path, name, opts)
    divisor = TIME_UNITS[opts.time_unit]
    return first / divisor, last / divisor


def _file_time_span(path: Path, name: str, opts: DataOptions) -> tuple[float, float]:
    """time_span of an .npz or CSV file, in the file's time unit."""
    from minparam_cli.identify.reading import _short, open_npz, require_data_file
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
                raise DataError(f"{path}: cannot read time array '{name}' ({_short(e)})") from None
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
            step = sampling_step(table[:, 0])
        table, last = _clean(table, last, report)
        if len(table) == 0:
            continue
        clean = split(table, layout)
        if processor is None:
            processor = Processor(clean, opts, report, step)
            still = Standstill(n, opts, report)
        for b in processor.push(clean):
            yield from still.push(b)
        # not alive while the next chunk is read: memory is one chunk, not two (an unfiltered block
        # is a view of the chunk's table, so b would keep that alive too)
        del table, clean
        b = None
    if processor is None:
        raise DataError(f"{path}: no usable samples (every row was dropped or the file has no data)")
    for b in processor.finish():
        yield from still.push(b)
    yield from still.finish()


class Standstill:
    """Counts the samples in which each joint (and every joint) is still, |dq_j| < still_speed, and
    with ``trim_still_s`` drops every run of consecutive all-joints-still samples that lasts longer
    than that: from its first to its last sample, t_last - t_first > trim_still_s.

    Streamed: a run's samples are held back (at most trim_still_s seconds of them) until the run
    ends, and emitted then; once the run is longer than trim_still_s they are dropped, and so is
    every further sample of the run, as it comes.  Blocks come out in order, so the result does not
    depend on how the samples are cut into blocks.
    """

    def __init__(self, n: int, opts: DataOptions, report: DataReport):
        self.speed = opts.still_speed
        self.trim = opts.trim_still_s
        self.rest = opts.rest_below_still and "dq" in report.derived
        report.rest_below = self.speed if self.rest else None
        self.report = report
        self.seen = 0
        self.still = np.zeros(n, dtype=np.int64)
        self.still_all = 0
        self.pending: list[Block] = []  # the open run's samples, not yet decided
        self.run_t0: float | None = None  # first time of the open run (a run is open when the last sample was still)
        self.dropping = False  # the open run is already longer than trim: drop as it comes
        report.still_share = [0.0] * n
        if self.trim is not None:
            report.dropped["standstill"] = 0

    def _stats(self, mask: np.ndarray, b: Block) -> np.ndarray:
        self.seen += len(b)
        self.still += mask.sum(axis=0)
        every = mask.all(axis=1)
        self.still_all += int(every.sum())
        self.report.still_share = [float(c / self.seen) for c in self.still]
        self.report.still_all_share = self.still_all / self.seen
        return every

    def _drop(self, count: int) -> None:
        self.report.dropped["standstill"] += count
        self.report.samples -= count

    def push(self, b: Block):
        if not len(b):
            return
        mask = np.abs(b.dq) < self.speed
        every = self._stats(mask, b)
        if self.rest and mask.any():
            b.dq[mask] = 0.0  # derived velocity below the noise floor: at rest (sign 0, no Coulomb torque)
        if self.trim is None:
            yield b
            return
        edges = np.diff(np.concatenate([[0], every.astype(np.int8), [0]]))
        starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)  # runs [start, end)
        was_open, was_dropping = self.run_t0 is not None, self.dropping
        continued = was_open and len(starts) > 0 and starts[0] == 0  # the open run goes on here
        open_end = len(ends) > 0 and ends[-1] == len(b)  # the last run goes on into the next block
        t0 = b.t[starts]
        if continued:
            t0[0] = self.run_t0
        long = (b.t[ends - 1] - t0) > self.trim
        if continued and was_dropping:
            long[0] = True
        self.report.trimmed_segments += int(long.sum()) - int(continued and was_dropping)
        carry: list[Block] = []
        if was_open:  # the samples held for the open run go with it: dropped, kept on holding, or out
            held, self.pending = self.pending, []
            if continued and long[0]:
                self._drop(sum(len(x) for x in held))
            elif continued and open_end and len(starts) == 1:
                carry = held
            else:
                yield from held
        cut = np.zeros(len(b) + 1, dtype=np.int64)
        np.add.at(cut, starts[long], 1)
        np.add.at(cut, ends[long], -1)
        keep = np.cumsum(cut[:-1]) == 0
        self._drop(int(len(b) - keep.sum()))
        self.run_t0, self.dropping = None, False
        if open_end:
            self.run_t0, self.dropping = float(t0[-1]), bool(long[-1])
            if not self.dropping:
                self.pending = carry + [b.take(slice(int(starts[-1]), None))]
                keep[starts[-1] :] = False
        if keep.all():
            yield b
        elif keep.any():
            yield b.take(keep)

    def finish(self):
        """The file ends: a run still held is shorter than trim_still_s, and kept."""
        held, self.pending, self.run_t0 = self.pending, [], None
        yield from held


def load_all(path: str | Path, n: int, opts: DataOptions, report: DataReport | None = None) -> Block:
    blocks = list(iter_blocks(path, n, opts, report))
    if not blocks:  # every sample dropped (standstill trimming)
        return Block(np.empty(0), *(np.empty((0, n)) for _ in KEYS[1:]))
    return Block.concat(blocks)
