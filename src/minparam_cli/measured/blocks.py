"""Measured joint data: reading (CSV or .npz, in chunks), cleaning, filtering, differentiation.

Pipeline per chunk, with a margin of neighbouring samples so that chunk edges
do not show:

1. drop rows with NaN in a used column and repeated samples (sample-and-hold
   logging: q, q̇ and τ identical to the previous row, with a new time stamp);
   refuse a time stamp that does not increase (naming its row);
2. when q̇ or q̈ must be computed: split the record at gaps (steps longer than
   records.GAP_STEPS median steps) into segments and, per segment, resample
   onto a uniform grid at the median step (linear interpolation; irregular
   steps are counted), low-pass q, q̇ and
   τ with the same zero-phase Butterworth filter (scipy.signal.sosfiltfilt),
   differentiate (central differences), and decimate so that the kept rate is
   about ten times the cut-off;
3. count, per joint, the samples in which the joint stands still (|q̇| below
   ``still_speed``) and, with ``trim_still_s``, drop every standstill of all
   joints that lasts longer than that (streamed: at most ``trim_still_s``
   seconds of samples are held back while a standstill's length is unknown);
4. yield blocks of (t, q, dq, ddq, tau).

Where the file gives both q and q̇, q̇ must be q's time derivative (measured/consistency.py): a
q̇ in deg/s, a flipped sign or a mapped column of another joint is refused, naming the joint.

Everything dropped is counted and reported, with the reason.
"""

from __future__ import annotations

from pathlib import Path
from typing import Iterator

import numpy as np

from minparam_cli.errors import DataError
from minparam_cli.measured.records import KEYS, Block, DataOptions, DataReport, sampling_step


def _clean(table: np.ndarray, last: np.ndarray | None, report: DataReport) -> tuple[np.ndarray, np.ndarray | None]:
    """Drop NaN and repeated samples; refuse time stamps that do not increase.  ``last`` is the
    previous kept row.

    ``table``: the used columns, time first.  Rows are copied only when some are dropped.  A time
    stamp equal to or before the previous row's (rows with NaN left out) is an error naming the row
    (counted from 1 after a CSV's header; a sample of another source, counted from 1): the order of the samples is unknown then, and dropping rows
    would hide it.  Sample-and-hold rows (q, q̇ and τ identical to the previous row, with a new and
    later stamp) are logging artefacts, dropped and counted.
    """
    first_row = report.rows_read + 1
    report.rows_read += len(table)
    ok = np.isfinite(table).all(axis=1)
    rows = None
    if not ok.all():
        report.dropped["nan"] += int((~ok).sum())
        rows = np.flatnonzero(ok)
        table = table[ok]
    t_prev = last[0] if last is not None else -np.inf
    tt = table[:, 0]
    if len(tt) and not (tt[0] > t_prev and np.all(tt[1:] > tt[:-1])):
        bad = int(np.argmax(tt <= np.concatenate([[t_prev], tt[:-1]])))
        before = float(tt[bad - 1]) if bad else float(t_prev)
        row = first_row + (int(rows[bad]) if rows is not None else bad)
        kind = "repeats" if tt[bad] == before else "goes back from"
        where = f"data row {row} (after the header)" if report.path.lower().endswith(".csv") else f"sample {row}"
        raise DataError(f"{report.path}: time stamps must increase: {where} has t = {float(tt[bad])!r}, "
                        f"which {kind} the row before's {before!r}")
    # compare every row with the row before it (the first with the previous chunk's last kept row)
    if len(table):
        repeated = np.empty(len(table), dtype=bool)
        repeated[0] = last is not None and bool(np.all(table[0, 1:] == last[1:]))
        np.all(table[1:, 1:] == table[:-1, 1:], axis=1, out=repeated[1:])
        if repeated.any():
            report.dropped["repeated_sample"] += int(repeated.sum())
            table = table[~repeated]
    new_last = table[-1].copy() if len(table) else last
    return table, new_last


def time_span(path: str | Path, opts: DataOptions) -> tuple[float, float]:
    """First and last usable time stamp of a data file without reading it all (CSV: its head and tail).

    The last is the largest finite time in the tail, so that a final row the cleaning drops (a NaN
    row, a time stamp that jumps back) does not move the hold-out split.
    """
    from minparam_cli.measured.readers import reader_for

    return reader_for(path).time_span(Path(path), opts)


def iter_blocks(path: str | Path, n: int, opts: DataOptions, report: DataReport | None = None) -> Iterator[Block]:
    """Clean, filter and differentiate the file chunk by chunk; memory bounded by the chunk size."""
    from minparam_cli.measured.consistency import VelocityCheck
    from minparam_cli.measured.filtering import Processor
    from minparam_cli.measured.reading import raw_chunks
    from minparam_cli.measured.tables import split

    path = Path(path)
    report = report if report is not None else DataReport(str(path))
    last = None
    processor = None
    velocity: VelocityCheck | None = None
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
            velocity = VelocityCheck(n, processor.gap, opts.still_speed, str(path)) if clean["dq"] is not None else None
        if velocity is not None:
            velocity.push(clean["t"], clean["q"], clean["dq"])
        for b in processor.push(clean):
            yield from still.push(b)
        # not alive while the next chunk is read: memory is one chunk, not two (an unfiltered block
        # is a view of the chunk's table, so b would keep that alive too)
        del table, clean
        b = None
    if processor is None:
        raise DataError(f"{path}: no usable samples (every row was dropped or the file has no data)")
    if velocity is not None:
        velocity.finish()
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
        return every  # type: ignore[return-value]  # numpy stubs: all(axis=1) of a 2-D array may be a scalar

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
