"""Every data format behind one small interface, and the one place that picks a format.

A :class:`Reader` gives a source's chunks (tables of the used columns t, q, [dq], [ddq], tau and
their layout, ``tables.column_layout``; time in seconds) and its time span (the first and last usable
time stamps, s, read without reading it all).  ``reader_for`` picks the reader from the path, in the
order of ``READERS``: data held in memory under that name (``measured.arrays``), a ROS bag
(``measured.rosbag``), a recording description joining CSV files (``measured.recording``), then by
suffix Parquet (``measured.parquet``), .npz, and CSV for every other name (``measured.tables``:
pyarrow's streaming parser or numpy's, the same values and errors either way).

A new format is a class with these two methods and one entry in ``READERS``.  The format modules
import their heavy libraries (pyarrow, rosbags) where they read.
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable, Iterator, Protocol

import numpy as np

from minparam_cli.errors import DataError
from minparam_cli.measured import arrays, parquet, recording, rosbag, spans
from minparam_cli.measured.columns import TIME_UNITS, column_indices, require_named
from minparam_cli.measured.records import KEYS, DataOptions
from minparam_cli.measured.tables import array_chunks, column_layout, csv_tables, open_npz, require_data_file, short_error

Chunks = Iterator[tuple[np.ndarray, dict]]


class Reader(Protocol):
    def chunks(self, path: Path, n: int, opts: DataOptions) -> Chunks:
        """Chunk by chunk: a table of the used columns and its layout, time in seconds."""
        ...

    def time_span(self, path: Path, opts: DataOptions) -> tuple[float, float]:
        """The first and last usable time stamps, s."""
        ...


def _in_seconds(chunks: Chunks, opts: DataOptions) -> Chunks:
    """Chunks whose time column is in ``opts.time_unit``, in seconds."""
    divisor = TIME_UNITS[opts.time_unit]
    for table, layout in chunks:
        if divisor != 1.0:
            table[:, 0] /= divisor  # a division: a stamp in ms, us or ns becomes the nearest double in s
        yield table, layout
        del table  # not alive while the next chunk is read


def _span_in_seconds(span: tuple[float, float], opts: DataOptions) -> tuple[float, float]:
    divisor = TIME_UNITS[opts.time_unit]
    return span[0] / divisor, span[1] / divisor


def _time_name(opts: DataOptions) -> str:
    return opts.columns.get("t", "t")


class InMemory:
    """Arrays or a table registered under the name (the Python API), time in ``opts.time_unit``."""

    def chunks(self, path: Path, n: int, opts: DataOptions) -> Chunks:
        return _in_seconds(arrays.chunks(self._record(path), n, opts), opts)

    def time_span(self, path: Path, opts: DataOptions) -> tuple[float, float]:
        return _span_in_seconds(arrays.time_span(self._record(path), len(opts.joint_names), opts), opts)

    @staticmethod
    def _record(path: Path) -> arrays.Record:
        record = arrays.lookup(path)
        assert record is not None  # READERS chose this reader for a registered name
        return record


class Bag:
    """A ROS bag of JointState messages, time from the header stamps."""

    def chunks(self, path: Path, n: int, opts: DataOptions) -> Chunks:
        return rosbag.bag_chunks(path, n, opts)

    def time_span(self, path: Path, opts: DataOptions) -> tuple[float, float]:
        return rosbag.bag_time_span(path, len(opts.joint_names), opts)


class Recording:
    """CSV files joined row by row by a description, which gives the time's rate or unit."""

    def chunks(self, path: Path, n: int, opts: DataOptions) -> Chunks:
        return recording.recording_chunks(path, n, opts)

    def time_span(self, path: Path, opts: DataOptions) -> tuple[float, float]:
        return recording.recording_time_span(path, opts)


class Parquet:
    """A Parquet file, columns named as a CSV header's, time in ``opts.time_unit``."""

    def chunks(self, path: Path, n: int, opts: DataOptions) -> Chunks:
        return _in_seconds(parquet.parquet_chunks(path, n, opts), opts)

    def time_span(self, path: Path, opts: DataOptions) -> tuple[float, float]:
        return _span_in_seconds(parquet.parquet_time_span(path, _time_name(opts)), opts)


class Npz:
    """An .npz archive of arrays t, q, [dq], [ddq], tau, time in ``opts.time_unit``."""

    def chunks(self, path: Path, n: int, opts: DataOptions) -> Chunks:
        return _in_seconds(self._chunks(path, n, opts), opts)

    @staticmethod
    def _chunks(path: Path, n: int, opts: DataOptions) -> Chunks:
        require_data_file(path)
        with open_npz(path) as z:
            try:
                found = {k: (_real(z[opts.columns.get(k, k)], opts.columns.get(k, k), path) if opts.columns.get(k, k) in z.files else None) for k in KEYS}
            except (MemoryError, DataError):
                raise
            except Exception as e:  # noqa: BLE001 - a damaged member: zlib, zipfile, format or dtype errors
                raise DataError(f"{path}: cannot read .npz ({short_error(e)})") from None
        require_named(found, opts.columns, str(path))
        yield from array_chunks(found, str(path), n, opts)

    def time_span(self, path: Path, opts: DataOptions) -> tuple[float, float]:
        name = _time_name(opts)
        require_data_file(path)
        with open_npz(path) as z:
            try:
                t = _real(z[name], name, path)
            except (MemoryError, DataError):
                raise
            except Exception as e:  # noqa: BLE001 - a missing or damaged member
                raise DataError(f"{path}: cannot read time array '{name}' ({short_error(e)})") from None
        t = t[np.isfinite(t)]
        if len(t) < 2:
            raise DataError(f"{path}: fewer than two time stamps")
        return _span_in_seconds((float(t.min()), float(t.max())), opts)


def _real(a: np.ndarray, name: str, path: Path) -> np.ndarray:
    """An .npz member as floats; complex numbers, dates and durations refused (``arrays.require_real``)."""
    arrays.require_real(a.dtype.kind, f"array '{name}'", str(path))
    return np.asarray(a, dtype=float)


class Csv:
    """A CSV file with a header row, time in ``opts.time_unit``; its span from its head and tail."""

    def chunks(self, path: Path, n: int, opts: DataOptions) -> Chunks:
        return _in_seconds(self._chunks(path, n, opts), opts)

    @staticmethod
    def _chunks(path: Path, n: int, opts: DataOptions) -> Chunks:
        tables = csv_tables(path, opts.chunk_rows)
        header = next(tables)
        idx = column_indices(header, n, opts.columns, str(path))
        layout = column_layout({k: ix is not None for k, ix in idx.items()}, n)
        used = [c for k in KEYS for c in (idx[k] or ())]
        try:
            for chunk in tables:
                yield (chunk if used == list(range(chunk.shape[1])) else chunk[:, used]), layout
                del chunk  # not alive while the next chunk is parsed
        finally:
            tables.close()

    def time_span(self, path: Path, opts: DataOptions) -> tuple[float, float]:
        return _span_in_seconds(spans.csv_time_span(path, opts), opts)


def _suffix(suffix: str) -> Callable[[Path], bool]:
    return lambda path: path.suffix.lower() == suffix


# The dispatch over formats, first match wins: (does the path name this format, its reader).
READERS: tuple[tuple[Callable[[Path], bool], Reader], ...] = (
    (lambda path: arrays.lookup(path) is not None, InMemory()),
    (rosbag.is_bag, Bag()),
    (recording.is_description, Recording()),
    (_suffix(".parquet"), Parquet()),
    (_suffix(".npz"), Npz()),
    (lambda path: True, Csv()),
)


def reader_for(path: str | Path) -> Reader:
    """The reader of the data at ``path``: the first of ``READERS`` that claims it."""
    path = Path(path)
    return next(reader for claims, reader in READERS if claims(path))
