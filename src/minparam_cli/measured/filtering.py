"""Streaming resampling, zero-phase low-pass filtering, differentiation and decimation.

The Butterworth filter runs forwards and backwards (scipy.signal.sosfiltfilt),
so it adds no phase lag.  Chunks are processed with ``margin`` samples of
context on each side, so the result does not depend on the chunk size beyond
rounding (the filter's transient decays within the margin).

Tolerances, so that rounding of the time stamps does not change the result (a record with raw
controller stamps, t ≈ 1.7e9 s, and the same record re-zeroed give the same samples):

- RATE_TOL: sample counts derived from the rate are rounded with a relative tolerance: the
  automatic decimation is k = floor(fs / (10·fc) · (1 + RATE_TOL)), the samples dropped at each
  end (one cut-off period) ceil(fs / fc · (1 - RATE_TOL)), so that 500 Hz read as 500.0001 or
  499.9999 Hz keeps one sample in 10 and drops 100 at each end either way;
- GRID_TOL: the uniform grid gets one more point at the end of the record when that point lies
  at most this share of a step after the last raw sample (the stamps' rounding), instead of
  ending one step early;
- a time step is irregular when it differs from the sampling step by more than IRREGULAR_TOL
  (records.IRREGULAR_TOL, 10 %), longer or shorter.

Gaps: a step longer than GAP_STEPS (records.GAP_STEPS, 25) sampling steps is a gap in the
recording (a logging pause), not a late sample.  It splits the record into segments, and nothing
is invented across it: each segment is resampled, filtered and differentiated on its own, and one
cut-off period is dropped at both ends of every segment (the filter's settling).  A segment too
short to keep anything after that is dropped whole (DataReport.dropped["short_segment"]).  Without
filtering (q̇ and q̈ read from the file) no sample is invented anyway; the gaps are still counted.
"""

from __future__ import annotations

import math

import numpy as np

from minparam_cli.errors import DataError
from minparam_cli.runtime import await_preload
from minparam_cli.measured.records import FILTER_ORDER, GAP_STEPS, IRREGULAR_TOL, KEYS, Block, DataOptions, DataReport, sampling_step

RATE_TOL = 1e-3
GRID_TOL = 1e-3
MAX_RATE_RATIO = 1e5  # sampling rate / cut-off: the filter holds 30 cut-off periods of samples (3e6 at most)


def _floor(x: float) -> int:
    """floor(x), up to the relative tolerance RATE_TOL (9.9999 -> 10)."""
    return int(math.floor(x * (1 + RATE_TOL)))


def _ceil(x: float) -> int:
    """ceil(x), up to the relative tolerance RATE_TOL (100.0001 -> 100)."""
    return int(math.ceil(x * (1 - RATE_TOL)))


class Processor:
    def __init__(self, first: dict, opts: DataOptions, report: DataReport, step: float | None = None):
        self.opts = opts
        self.report = report
        t = first["t"]
        if step is None and len(t) < 3:
            raise DataError(f"{report.path}: too few samples in the first chunk to find the sampling step")
        dt = step if step else sampling_step(t)
        if not (dt is not None and dt > 0):
            raise DataError(f"{report.path}: time stamps do not increase")
        self.dt: float = dt
        report.median_step_s = self.dt
        self.gap = GAP_STEPS * dt  # a longer step starts a new segment
        self.filter = opts.force_filter or first["dq"] is None or first["ddq"] is None
        self.has_dq = first["dq"] is not None
        self.has_ddq = first["ddq"] is not None
        self.last_t: float | None = None
        self.count = 0  # samples seen on the output grid (before decimation)
        fs = 1.0 / self.dt
        if self.filter:
            if not 0 < opts.cutoff_hz < fs / 2:
                raise DataError(f"{report.path}: cut-off {opts.cutoff_hz} Hz must be below half the sampling rate ({fs / 2:.4g} Hz)")
            if fs / opts.cutoff_hz > MAX_RATE_RATIO:
                raise DataError(
                    f"{report.path}: the sampling rate ({fs:.4g} Hz) is more than {MAX_RATE_RATIO:.0e} times the "
                    f"{opts.cutoff_hz:g} Hz cut-off: are the time stamps in seconds? (else --rate or --cutoff)"
                )
            await_preload()  # scipy imported on one thread at a time (runtime.preload)
            from scipy.signal import butter

            try:
                with np.errstate(all="ignore"):
                    self.sos = butter(FILTER_ORDER, opts.cutoff_hz, fs=fs, output="sos")
            except (ValueError, np.linalg.LinAlgError) as e:
                raise DataError(f"{report.path}: cannot design a {opts.cutoff_hz:g} Hz filter at {fs:.6g} Hz ({e})") from e
            if not np.isfinite(self.sos).all():
                raise DataError(f"{report.path}: cannot design a {opts.cutoff_hz:g} Hz filter at {fs:.6g} Hz")
            self.margin = _ceil(10 * fs / opts.cutoff_hz)
            # the forward-backward filter is only as good as its padding at the two ends of the
            # record: one period of the cut-off is dropped there (Panda data: 2.9 % -> 1.05 %
            # held-out error with the edges kept vs dropped)
            self.trim = _ceil(fs / opts.cutoff_hz)
            self.offset = 0  # global grid index of the buffer's first row
            report.dropped["filter_edges"] = 0
            report.trim_s = self.trim * self.dt
            self.k = opts.decimate or max(1, _floor(fs / (10 * opts.cutoff_hz)))
            report.filter = f"Butterworth order {FILTER_ORDER}, zero-phase (forward-backward), cut-off {opts.cutoff_hz:g} Hz, at {fs:.6g} Hz"
            report.derived = [name for name, present in (("dq", self.has_dq), ("ddq", self.has_ddq)) if not present or opts.force_filter]
            self.buffer: list[np.ndarray] = []  # uniform samples: columns t, q, [dq], tau
            self.buffered = 0
            self.total = 0  # samples on the grid so far
            self.emitted = 0  # samples of the buffer already emitted
            self.prev_raw: np.ndarray | None = None
            self.grid_next = float(t[0])
        else:
            self.k = opts.decimate or 1
        report.decimation = self.k

    # --- helpers -------------------------------------------------------------

    def _count_irregular(self, t: np.ndarray) -> None:
        """Count the steps (of the cleaned time stamps) that differ from the sampling step by more
        than IRREGULAR_TOL of it, longer or shorter (a dropped row leaves a long step)."""
        if self.last_t is not None:
            t = np.concatenate([[self.last_t], t])
        if len(t) > 1:
            d = np.diff(t)
            self.report.irregular_steps += int(np.sum(np.abs(d - self.dt) > IRREGULAR_TOL * self.dt))
            gaps = d[d > self.gap]
            self.report.segments += len(gaps)
            self.report.gap_s += float(gaps.sum())
            self.last_t = float(t[-1])

    def _decimate(self, b: Block) -> Block:
        if self.k == 1:
            self.count += len(b)
            self.report.samples += len(b)
            return b
        idx = np.flatnonzero((self.count + np.arange(len(b))) % self.k == 0)
        self.count += len(b)
        out = b.take(idx)
        self.report.samples += len(out)
        return out

    # --- unfiltered path -----------------------------------------------------

    def push(self, clean: dict):
        self._count_irregular(clean["t"])
        if not self.filter:
            yield self._decimate(Block(*(clean[k] for k in KEYS)))
            return
        yield from self._push_filtered(clean)

    def finish(self):
        if self.filter:
            yield from self._end_segment(last=True)

    def _end_segment(self, last: bool):
        """Filter out what the segment still holds; then start afresh (a gap, or the end of the file)."""
        end = self.prev_raw
        if end is not None and self.grid_next <= end[0] + GRID_TOL * self.dt:
            # the next grid point is the last sample, up to the stamps' rounding: it ends the grid
            self._append(np.concatenate([[self.grid_next], end[1:]])[None])
        yield from self._flush(final=True, last=last)
        self.buffer, self.buffered, self.total, self.emitted, self.offset = [], 0, 0, 0, 0
        self.prev_raw = None

    # --- filtered path -------------------------------------------------------

    def _columns(self, clean: dict) -> np.ndarray:
        parts = [clean["t"][:, None], clean["q"]]
        if self.has_dq:
            parts.append(clean["dq"])
        parts.append(clean["tau"])
        return np.hstack(parts)

    def _push_filtered(self, clean: dict):
        raw = self._columns(clean)
        t = raw[:, 0]
        steps = np.diff(np.concatenate([[self.prev_raw[0]], t])) if self.prev_raw is not None else np.diff(t)
        first = 0 if self.prev_raw is not None else 1  # steps[k] ends at row k - 1 + first
        starts = np.flatnonzero(steps > self.gap) + first  # rows that begin a new segment
        bounds = [0, *starts.tolist(), len(raw)]
        for k in range(len(bounds) - 1):
            lo, hi = bounds[k], bounds[k + 1]
            if k > 0:  # a gap before row lo: the segment before it ends, a new one starts at lo
                yield from self._end_segment(last=False)
                self.grid_next = float(raw[lo, 0])
            if hi > lo:
                yield from self._push_part(raw[lo:hi])

    def _push_part(self, raw: np.ndarray):
        if self.prev_raw is not None:
            raw = np.vstack([self.prev_raw[None], raw])
        self.prev_raw = raw[-1]
        t = raw[:, 0]
        n_grid = int(math.floor((t[-1] - self.grid_next) / self.dt + 1e-9)) + 1
        if n_grid <= 0:
            return
        grid = self.grid_next + self.dt * np.arange(n_grid)
        self.grid_next = float(grid[-1] + self.dt)
        self._append(np.column_stack([grid] + [np.interp(grid, t, raw[:, c]) for c in range(1, raw.shape[1])]))
        if self.buffered >= 3 * self.margin + self.opts.chunk_rows // 2:
            yield from self._flush(final=False)

    def _append(self, uni: np.ndarray) -> None:
        self.buffer.append(uni)
        self.buffered += len(uni)
        self.total += len(uni)

    def _flush(self, final: bool, last: bool = True):
        if final and self.total <= 2 * self.trim:
            if self.report.segments > 1:  # one segment of several: dropped; refused when none is left
                self.report.dropped["short_segment"] = self.report.dropped.get("short_segment", 0) + self.total
                if not (last and self.report.samples == 0):
                    return
            fs = 1.0 / self.dt
            if self.report.segments > 1:
                raise DataError(
                    f"{self.report.path}: every one of the {self.report.segments} segments (split at gaps longer than "
                    f"{GAP_STEPS} sampling steps) is too short to filter: at {fs:.6g} Hz one period of the "
                    f"{self.opts.cutoff_hz:g} Hz cut-off ({self.trim} samples) is dropped at each end of each"
                )
            raise DataError(
                f"{self.report.path}: too few samples to filter: {self.total} at {fs:.6g} Hz, and one period of the "
                f"{self.opts.cutoff_hz:g} Hz cut-off ({self.trim} samples) is dropped at each end; at least "
                f"{2 * self.trim + 1} are needed"
            )
        if not self.buffer:
            return
        data = np.vstack(self.buffer)
        if len(data) < 16:
            raise DataError(f"{self.report.path}: too few samples to filter ({len(data)})")
        await_preload()  # scipy imported on one thread at a time (runtime.preload)
        from scipy.signal import sosfiltfilt

        n = (data.shape[1] - 1) // (3 if self.has_dq else 2)
        padlen = min(2 * self.trim, len(data) - 1)  # odd extension over two cut-off periods
        with np.errstate(all="ignore"):  # values too large overflow: refused below, with their time
            f = sosfiltfilt(self.sos, data[:, 1:], axis=0, padlen=padlen)
            q = f[:, :n]
            if self.has_dq:
                dq = f[:, n : 2 * n]
                tau = f[:, 2 * n :]
            else:
                dq = np.gradient(q, self.dt, axis=0)
                tau = f[:, n:]
            ddq = np.gradient(dq, self.dt, axis=0)
        end = len(data) - (self.trim if final else self.margin)
        start = max(self.emitted, self.trim - self.offset)
        if final or start > self.emitted:
            dropped_head = max(0, min(start, len(data)) - self.emitted)
            self.report.dropped["filter_edges"] += dropped_head + (max(0, len(data) - max(end, start)) if final else 0)
        if end > start:
            b = Block(data[start:end, 0], q[start:end], dq[start:end], ddq[start:end], tau[start:end])
            bad = ~(np.isfinite(b.q).all(axis=1) & np.isfinite(b.dq).all(axis=1) & np.isfinite(b.ddq).all(axis=1)
                    & np.isfinite(b.tau).all(axis=1))
            if bad.any():
                raise DataError(
                    f"{self.report.path}: filtering gives non-finite values at t = {b.t[int(np.argmax(bad))]:.6g} s "
                    "(a value of q, dq or tau near there is too large to filter)"
                )
            yield self._decimate(b)
        if final:
            self.buffer, self.buffered = [], 0
            return
        keep_from = max(0, len(data) - 2 * self.margin)
        self.buffer = [data[keep_from:]]
        self.buffered = len(data) - keep_from
        self.emitted = max(end, start) - keep_from
        self.offset += keep_from
