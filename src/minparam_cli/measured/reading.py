"""Reading a data file chunk by chunk: the used columns (t, q, [dq], [ddq], tau) as one table.

Dispatch by format: a ROS bag (``measured.rosbag``), a described recording of several CSV files
(``measured.recording``), Parquet (``measured.parquet``), arrays held in memory (``measured.arrays``),
.npz and CSV (``measured.tables``: pyarrow's streaming reader or numpy's, the same values and errors
either way); then motor-side signals to the joint side through the transmission.
"""

from __future__ import annotations

from pathlib import Path
from typing import Iterator

import numpy as np

from minparam_cli.errors import DataError
from minparam_cli.measured.records import KEYS, DataOptions
from minparam_cli.measured.columns import TIME_UNITS, column_indices
from minparam_cli.measured.tables import (
    column_layout,
    short_error,
    array_chunks,
    csv_tables,
    open_npz,
    require_data_file,
)

def raw_chunks(path: Path, n: int, opts: DataOptions) -> Iterator[tuple[np.ndarray, dict]]:
    """Chunk by chunk: a table of the used columns (t, q, [dq], [ddq], tau) and its layout, time in
    seconds.  The format follows the name: a ROS bag (see ``measured.rosbag.is_bag``), .npz, or CSV."""
    from minparam_cli.measured.arrays import lookup
    from minparam_cli.measured.rosbag import is_bag

    record = lookup(path)  # data held in memory (the Python API), registered under a name
    path = Path(path)
    if record is None and is_bag(path):
        from minparam_cli.measured.rosbag import bag_chunks

        for table, layout in bag_chunks(path, n, opts):
            if opts.motor_side is not None:
                to_joint_side(table, layout, opts.motor_side)
            yield table, layout
        return
    divisor = TIME_UNITS[opts.time_unit]
    from minparam_cli.measured.recording import is_description, recording_chunks

    if record is None and is_description(path):  # several CSV files joined row by row, time in seconds
        source, divisor = recording_chunks(path, n, opts), 1.0
    elif record is not None:
        from minparam_cli.measured.arrays import chunks

        source = chunks(record, n, opts)
    else:
        source = _file_chunks(path, n, opts)
    for table, layout in source:
        if divisor != 1.0:
            table[:, 0] /= divisor  # a division: a stamp in ms, us or ns becomes the nearest double in s
        if opts.motor_side is not None:
            to_joint_side(table, layout, opts.motor_side)
        yield table, layout
        table = None  # not alive while the next chunk is read


def to_joint_side(table: np.ndarray, layout: dict, motor_side: tuple) -> None:
    """Motor angles, rates and torques (or current signals) of a chunk -> joint side, in place.

    Linear, so it commutes with the filter and the differentiation that follow (the zero offset
    only shifts q)."""
    from minparam_cli.dynamics.transmission import joint_from_motor, joint_torque

    rows, zero, gains = motor_side
    N = np.asarray(rows, dtype=float)
    for key in ("q", "dq", "ddq"):
        if layout.get(key) is not None:
            table[:, layout[key]] = joint_from_motor(table[:, layout[key]], N, zero if key == "q" else None)
    table[:, layout["tau"]] = joint_torque(table[:, layout["tau"]], N, gains)


def _file_chunks(path: Path, n: int, opts: DataOptions) -> Iterator[tuple[np.ndarray, dict]]:
    """raw_chunks of an .npz or CSV file, time in the file's unit."""
    src = str(path)
    if path.suffix.lower() == ".parquet":
        from minparam_cli.measured.parquet import parquet_chunks

        yield from parquet_chunks(path, n, opts)
        return
    require_data_file(path)
    if path.suffix.lower() == ".npz":
        with open_npz(path) as z:
            try:
                arrays = {k: (np.asarray(z[opts.columns.get(k, k)], dtype=float) if opts.columns.get(k, k) in z.files else None) for k in KEYS}
            except MemoryError:
                raise
            except Exception as e:  # noqa: BLE001 - a damaged member: zlib, zipfile, format or dtype errors
                raise DataError(f"{src}: cannot read .npz ({short_error(e)})") from None
        yield from array_chunks(arrays, src, n, opts)
        return
    tables = csv_tables(path, opts.chunk_rows)
    header = next(tables)
    idx = column_indices(header, n, opts.columns, src)
    layout = column_layout({k: ix is not None for k, ix in idx.items()}, n)
    used = [c for k in KEYS if idx[k] is not None for c in idx[k]]
    try:
        for chunk in tables:
            yield (chunk if used == list(range(chunk.shape[1])) else chunk[:, used]), layout
            del chunk  # not alive while the next chunk is parsed
    finally:
        tables.close()


