"""Measured data held in memory — a mapping of numpy arrays or a pandas DataFrame — read like a data file.

``identify`` streams its data by name (``measured.blocks.iter_blocks``); an in-memory record is
registered under a name in angle brackets (``<arrays>``, ``<DataFrame>``) for the duration of one
call (:func:`registered`, a context variable: threads and async tasks do not see each other's), and
the readers look a name up here before they open a file.  No file is written.

Two shapes, the two shapes data files have:

* **arrays** (like an .npz file): keys ``t`` (N,), ``q``, ``dq`` (optional), ``ddq`` (optional),
  ``tau`` (N, n) — renamed with the ``columns`` option exactly as an .npz file's members;
* **a table** (like a CSV file): a pandas DataFrame, or a mapping of one-dimensional columns named as
  a CSV header (``t, q1..qn, dq1..dqn, ddq1..ddqn, tau1..taun``, or any ``columns`` spec).

pandas is never imported here: a DataFrame is recognised by its type's module and read through its
own ``columns`` and ``to_numpy``.
"""

from __future__ import annotations

import contextlib
from contextvars import ContextVar
from dataclasses import dataclass
from typing import Any, Iterator, Mapping

import numpy as np

from minparam_cli.errors import DataError

KEYS = ("t", "q", "dq", "ddq", "tau")


@dataclass(frozen=True)
class Record:
    """One in-memory data set: arrays by key (``kind == "arrays"``) or a table with a header."""

    name: str
    kind: str  # "arrays" | "table"
    arrays: Mapping[str, np.ndarray] | None = None
    header: tuple[str, ...] = ()
    table: np.ndarray | None = None


_SOURCES: ContextVar[dict[str, Record] | None] = ContextVar("minparam_in_memory_data", default=None)


def is_dataframe(data: object) -> bool:
    """A pandas DataFrame, recognised without importing pandas."""
    mod = type(data).__module__ or ""
    return (mod == "pandas" or mod.startswith("pandas.")) and type(data).__name__ == "DataFrame"


def is_in_memory(data: object) -> bool:
    """Whether ``data`` is a record held in memory (a mapping or a DataFrame) rather than a path."""
    return isinstance(data, Mapping) or is_dataframe(data)


def as_record(data: Any, name: str) -> Record:
    """A mapping of arrays or a DataFrame as a :class:`Record` named ``name`` (the name messages and
    the report show).  Values that are not numbers are refused in one line."""
    if is_dataframe(data):
        header = tuple(str(c) for c in data.columns)
        for c, dtype in zip(header, data.dtypes, strict=True):
            require_real(getattr(dtype, "kind", "O"), f"column '{c}'", name)
        try:
            table = np.asarray(data.to_numpy(dtype=float), dtype=float)
        except (TypeError, ValueError) as e:
            raise DataError(f"{name}: the DataFrame has columns that are not numbers ({e})") from None
        return Record(name, "table", header=header, table=table.reshape(len(data), len(header)))
    if not isinstance(data, Mapping):
        raise DataError(f"{name}: expected a file path, a mapping of arrays or a pandas DataFrame, got {type(data).__name__}")
    arrays: dict[str, np.ndarray] = {}
    for k, v in data.items():
        if isinstance(v, np.ma.MaskedArray):  # a masked entry is a missing value: NaN, its row dropped and counted
            v = np.ma.asarray(v, dtype=float).filled(np.nan)
        try:
            raw = np.asarray(v)
            require_real(raw.dtype.kind, f"array '{k}'", name)
            arrays[str(k)] = np.asarray(raw, dtype=float)
        except (TypeError, ValueError) as e:
            raise DataError(f"{name}: array '{k}' is not numeric ({e})") from None
    if "q" in arrays or "tau" in arrays or any(a.ndim >= 2 for a in arrays.values()):
        return Record(name, "arrays", arrays=arrays)  # renamed members too: {"time", "pos", "effort"} + columns
    # one-dimensional columns named like a CSV header
    lengths = {a.shape for a in arrays.values()}
    if any(a.ndim != 1 for a in arrays.values()) or len(lengths) > 1:
        raise DataError(f"{name}: expected arrays t, q, tau (N, n) or one-dimensional columns t, q1.., tau1.. "
                        "of one length")
    header = tuple(arrays)
    table = np.column_stack([arrays[h] for h in header]) if header else np.empty((0, 0))
    return Record(name, "table", header=header, table=table)


def require_real(kind: str, what_key: str, name: str) -> None:
    """Refuse values numpy would turn into floats by losing their meaning: complex numbers (the
    imaginary part dropped with a warning), dates and durations (nanoseconds read as seconds)."""
    what = {"c": "complex numbers", "M": "dates", "m": "durations"}.get(kind)
    if what is not None:
        unit = " (times as numbers, in seconds or the time unit given)" if kind in "Mm" else ""
        raise DataError(f"{name}: {what_key} holds {what}, expected real numbers{unit}")


@contextlib.contextmanager
def registered(records: list[Record]) -> Iterator[None]:
    """Make ``records`` readable by name for the duration of the block."""
    current = dict(_SOURCES.get() or {})
    current.update({r.name: r for r in records})
    token = _SOURCES.set(current)
    try:
        yield
    finally:
        _SOURCES.reset(token)


def lookup(path: object) -> Record | None:
    """The record registered under ``path``'s name, or None (a file)."""
    sources = _SOURCES.get()
    if not sources:
        return None
    return sources.get(str(path))


def chunks(record: Record, n: int, opts) -> Iterator[tuple[np.ndarray, dict]]:
    """``reading.raw_chunks`` of a record (time in the record's unit): the .npz route for arrays, the
    CSV column rules (``measured.columns.column_indices``) for a table."""
    from minparam_cli.measured.tables import column_layout, array_chunks
    from minparam_cli.measured.columns import column_indices, require_named

    if record.kind == "arrays":
        assert record.arrays is not None
        names = {k: opts.columns.get(k, k) for k in KEYS}
        arrays = {k: (np.array(record.arrays[names[k]], dtype=float) if names[k] in record.arrays else None) for k in KEYS}
        require_named(arrays, opts.columns, record.name)
        yield from array_chunks(arrays, record.name, n, opts)
        return
    assert record.table is not None
    idx = column_indices(list(record.header), n, opts.columns, record.name)
    layout = column_layout({k: ix is not None for k, ix in idx.items()}, n)
    used = [c for k in KEYS for c in (idx[k] or [])]
    table = record.table
    if not len(table):
        raise DataError(f"{record.name}: no usable samples (the table has no rows)")
    for s in range(0, len(table), opts.chunk_rows):
        yield np.array(table[s : s + opts.chunk_rows, used], dtype=float), layout


def time_span(record: Record, n: int, opts) -> tuple[float, float]:
    """First and last finite time stamp of a record, in its time unit."""
    from minparam_cli.measured.columns import time_index

    name = opts.columns.get("t", "t")
    if record.kind == "arrays":
        assert record.arrays is not None
        if name not in record.arrays:
            raise DataError(f"{record.name}: missing array '{name}'")
        t = np.asarray(record.arrays[name], dtype=float).reshape(-1)
    else:
        assert record.table is not None
        t = record.table[:, time_index(list(record.header), n, opts.columns, record.name)]
    t = t[np.isfinite(t)]
    if len(t) < 2:
        raise DataError(f"{record.name}: fewer than two time stamps")
    # a table's first row, as a CSV file's head; arrays: the earliest, as an .npz file's
    return (float(t[0]) if record.kind == "table" else float(t.min())), float(t.max())
