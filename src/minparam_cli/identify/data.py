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


def _column_indices(header: list[str], n: int, opts: DataOptions, src: str) -> dict[str, list[int] | None]:
    names = [h.strip() for h in header]
    idx: dict[str, list[int] | None] = {}
    for key in KEYS:
        name = opts.columns.get(key, key)
        if key == "t":
            if name not in names:
                raise DataError(f"{src}: missing time column '{name}' (use --columns t=NAME)")
            idx[key] = [names.index(name)]
            continue
        wanted = [f"{name}{j}" for j in range(1, n + 1)]
        found = [c for c in wanted if c in names]
        if not found:
            if key in ("q", "tau"):
                raise DataError(f"{src}: missing columns {wanted[0]}..{wanted[-1]} (use --columns {key}=PREFIX)")
            idx[key] = None
            continue
        if len(found) != n:
            missing = [c for c in wanted if c not in names]
            raise DataError(f"{src}: column(s) {missing} missing: the robot has {n} joints")
        idx[key] = [names.index(c) for c in wanted]
    return idx


def _raw_chunks(path: Path, n: int, opts: DataOptions) -> Iterator[tuple[dict, dict]]:
    """(arrays by key, column indices) chunk by chunk; arrays hold None for absent keys."""
    src = str(path)
    if not path.exists():
        raise DataError(f"{src}: no such file")
    if path.suffix.lower() == ".npz":
        try:
            with np.load(path, allow_pickle=False) as z:
                arrays = {k: (np.asarray(z[opts.columns.get(k, k)], dtype=float) if opts.columns.get(k, k) in z.files else None) for k in KEYS}
        except (OSError, ValueError) as e:
            raise DataError(f"{src}: cannot read .npz ({e})") from e
        for k in ("t", "q", "tau"):
            if arrays[k] is None:
                raise DataError(f"{src}: missing array '{opts.columns.get(k, k)}'")
        N = len(arrays["t"])
        for k in KEYS[1:]:
            a = arrays[k]
            if a is not None:
                a = a.reshape(N, -1) if a.ndim != 2 else a
                if a.shape != (N, n):
                    raise DataError(f"{src}: array '{k}' has shape {a.shape}, expected ({N}, {n})")
                arrays[k] = a
        for s in range(0, N, opts.chunk_rows):
            yield {k: (None if a is None else a[s : s + opts.chunk_rows]) for k, a in arrays.items()}
        return
    try:
        fh = open(path, encoding="utf-8", errors="strict")
    except OSError as e:
        raise DataError(f"{src}: cannot read file ({e.strerror})") from e
    with fh:
        header_line = fh.readline()
        if not header_line.strip():
            raise DataError(f"{src}: empty file, expected a header row")
        header = header_line.strip().split(",")
        idx = _column_indices(header, n, opts, src)
        line_no = 1
        while True:
            try:
                chunk = np.loadtxt(fh, delimiter=",", max_rows=opts.chunk_rows, ndmin=2)
            except ValueError as e:
                raise DataError(f"{src}: non-numeric value after line {line_no} ({e})") from e
            if chunk.size == 0:
                break
            if chunk.shape[1] != len(header):
                raise DataError(f"{src}: rows have {chunk.shape[1]} values, the header has {len(header)}")
            line_no += len(chunk)
            yield {k: (None if ix is None else (chunk[:, ix[0]] if k == "t" else chunk[:, ix])) for k, ix in idx.items()}
            if len(chunk) < opts.chunk_rows:
                break


def _clean(raw: dict, last: np.ndarray | None, report: DataReport) -> tuple[dict, np.ndarray | None]:
    """Drop NaN, non-increasing times and repeated samples; ``last`` is the previous kept row."""
    keys = [k for k in KEYS if raw[k] is not None]
    t = raw["t"]
    report.rows_read += len(t)
    stacked = np.column_stack([raw[k] if raw[k].ndim == 2 else raw[k][:, None] for k in keys])
    ok = np.all(np.isfinite(stacked), axis=1)
    report.dropped["nan"] += int((~ok).sum())
    stacked = stacked[ok]
    # compare every row with the row before it (the first with the previous chunk's last kept row)
    first = last[None] if last is not None else np.full((1, stacked.shape[1]), np.nan)
    prev_rows = np.vstack([first, stacked[:-1]]) if len(stacked) else stacked
    repeated = np.all(stacked[:, 1:] == prev_rows[:, 1:], axis=1)
    report.dropped["repeated_sample"] += int(repeated.sum())
    stacked = stacked[~repeated]
    # time must increase: keep the running maximum rule
    t_prev = last[0] if last is not None else -np.inf
    tt = stacked[:, 0]
    running = np.maximum.accumulate(np.concatenate([[t_prev], tt]))[:-1]
    increasing = tt > running
    report.dropped["time_not_increasing"] += int((~increasing).sum())
    stacked = stacked[increasing]
    new_last = stacked[-1] if len(stacked) else last
    out, c = {}, 0
    for k in KEYS:
        if raw[k] is None:
            out[k] = None
            continue
        w = 1 if k == "t" else raw[k].shape[1]
        out[k] = stacked[:, c] if k == "t" else stacked[:, c : c + w]
        c += w
    return out, new_last


def time_span(path: str | Path, opts: DataOptions) -> tuple[float, float]:
    """First and last time stamp of a data file without reading it all (CSV: first and last line)."""
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
            header = fh.readline().decode("utf-8", "replace").strip().split(",")
            first = fh.readline().decode("utf-8", "replace")
            fh.seek(0, 2)
            size = fh.tell()
            fh.seek(max(0, size - 65536))
            tail = [ln for ln in fh.read().decode("utf-8", "replace").splitlines() if ln.strip()]
    except OSError as e:
        raise DataError(f"{path}: cannot read file ({e.strerror})") from e
    names = [h.strip() for h in header]
    if name not in names:
        raise DataError(f"{path}: missing time column '{name}' (use --columns t=NAME)")
    k = names.index(name)
    try:
        t0, t1 = float(first.split(",")[k]), float(tail[-1].split(",")[k])
    except (ValueError, IndexError) as e:
        raise DataError(f"{path}: cannot read the first and last time stamps ({e})") from e
    return t0, t1


def iter_blocks(path: str | Path, n: int, opts: DataOptions, report: DataReport | None = None) -> Iterator[Block]:
    """Clean, filter and differentiate the file chunk by chunk; memory bounded by the chunk size."""
    from minparam_cli.identify.filtering import Processor

    path = Path(path)
    report = report if report is not None else DataReport(str(path))
    last = None
    processor = None
    step = None
    for raw in _raw_chunks(path, n, opts):
        if step is None and opts.step_s:
            step = float(opts.step_s)
        if step is None:
            # the sampling step from the raw time stamps (sample-and-hold rows have proper stamps)
            d = np.diff(raw["t"][np.isfinite(raw["t"])])
            d = d[d > 0]
            step = float(np.median(d)) if len(d) else None
        clean, last = _clean(raw, last, report)
        if len(clean["t"]) == 0:
            continue
        if processor is None:
            processor = Processor(clean, opts, report, step)
        yield from processor.push(clean)
    if processor is None:
        raise DataError(f"{path}: no usable samples (every row was dropped or the file has no data)")
    yield from processor.finish()


def load_all(path: str | Path, n: int, opts: DataOptions, report: DataReport | None = None) -> Block:
    blocks = list(iter_blocks(path, n, opts, report))
    return Block.concat(blocks)
