"""Parquet recordings (``*.parquet``, read by pyarrow): columns named as in a CSV file (t, q1.., tau1..,
or as ``--columns`` says), read batch by batch, only the used columns; a null is NaN (the row is
dropped and counted as a CSV row with a NaN).  The same tables as ``measured.reading.raw_chunks``."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np

from minparam_cli.errors import DataError


def _open(path: Path):
    from minparam_cli.measured.tables import short_error, require_data_file
    from minparam_cli.optional import import_optional

    pq = import_optional("pyarrow.parquet", "arrow", "reading Parquet files")
    require_data_file(path)
    try:
        return pq.ParquetFile(path)
    except MemoryError:
        raise
    except Exception as e:  # noqa: BLE001 - pyarrow raises many kinds for a damaged file
        raise DataError(f"{path}: cannot read Parquet ({short_error(e)})") from None


def _floats(column, name: str, src: str) -> np.ndarray:
    import pyarrow as pa
    import pyarrow.compute as pc

    if not (pa.types.is_floating(column.type) or pa.types.is_integer(column.type) or pa.types.is_decimal(column.type)):
        kind = "text" if pa.types.is_string(column.type) or pa.types.is_large_string(column.type) else str(column.type)
        raise DataError(f"{src}: column '{name}' holds {kind}, not numbers")
    from minparam_cli.measured.arrow_csv import float_values

    if isinstance(column, pa.ChunkedArray):
        column = column.combine_chunks()
    return float_values(pc.cast(column, pa.float64()))  # a null becomes NaN


def parquet_chunks(path: Path, n: int, opts) -> Iterator[tuple[np.ndarray, dict]]:
    """Chunks of opts.chunk_rows rows: the used columns (t, q, [dq], [ddq], tau), time in the file's unit."""
    from minparam_cli.measured.records import KEYS
    from minparam_cli.measured.tables import column_layout
    from minparam_cli.measured.columns import column_indices

    src = str(path)
    f = _open(path)
    names = list(f.schema_arrow.names)
    idx = column_indices(names, n, opts.columns, src)
    layout = column_layout({k: ix is not None for k, ix in idx.items()}, n)
    used = [c for k in KEYS for c in (idx[k] or ())]
    wanted = sorted(set(used))
    where = {c: j for j, c in enumerate(wanted)}
    for batch in _batches(f, src, batch_size=opts.chunk_rows, columns=[names[c] for c in wanted]):
        cols = [_floats(batch.column(j), names[c], src) for j, c in enumerate(wanted)]
        yield np.column_stack([cols[where[c]] for c in used]), layout


def _batches(f, src: str, **kw) -> Iterator:
    """``f.iter_batches(**kw)``, a damaged page a one-line DataError (``_guarded``)."""
    batches = f.iter_batches(**kw)
    while (batch := _guarded(lambda: next(batches, None), src)) is not None:
        yield batch


def parquet_time_span(path: Path, name: str) -> tuple[float, float]:
    """First and last finite time stamps of column ``name`` (read alone), in the file's unit."""
    f = _open(path)
    if name not in f.schema_arrow.names:
        raise DataError(f"{path}: missing time column '{name}' (use --columns t=NAME)")
    t = _floats(_read_column(f, name, str(path)), name, str(path))
    t = t[np.isfinite(t)]
    if len(t) < 2:
        raise DataError(f"{path}: fewer than two time stamps")
    return float(t[0]), float(t.max())


def _read_column(f, name: str, src: str):
    """Column ``name`` of the whole file, a damaged page a one-line DataError (``_guarded``)."""
    return _guarded(lambda: f.read(columns=[name]).column(0), src)


def _guarded(read, src: str):
    """``read()``, pyarrow's error for a damaged page (bad compressed data, a truncated column chunk) as a
    one-line DataError."""
    from minparam_cli.measured.tables import short_error

    try:
        return read()
    except MemoryError:
        raise
    except Exception as e:  # noqa: BLE001 - pyarrow raises OSError, ArrowInvalid and others for a damaged page
        raise DataError(f"{src}: cannot read Parquet ({short_error(e)})") from None
