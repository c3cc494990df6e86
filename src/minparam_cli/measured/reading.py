"""Reading a data file chunk by chunk: the used columns (t, q, [dq], [ddq], tau) as one table.

The format's reader (``measured.readers.reader_for``: a ROS bag, a recording description, Parquet,
.npz, CSV or arrays held in memory) gives the chunks, time in seconds; motor-side signals are turned
to the joint side here, through the transmission.
"""

from __future__ import annotations

from pathlib import Path
from typing import Iterator

import numpy as np

from minparam_cli.measured.readers import reader_for
from minparam_cli.measured.records import DataOptions


def raw_chunks(path: Path, n: int, opts: DataOptions) -> Iterator[tuple[np.ndarray, dict]]:
    """Chunk by chunk: a table of the used columns (t, q, [dq], [ddq], tau) and its layout, time in
    seconds.  The format follows the name (``measured.readers.READERS``)."""
    for table, layout in reader_for(path).chunks(Path(path), n, opts):
        if opts.motor_side is not None:
            to_joint_side(table, layout, opts.motor_side)
        yield table, layout
        del table  # not alive while the next chunk is read


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

