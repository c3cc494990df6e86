"""Writing joint data chunk by chunk: CSV text and NumPy ``.npz`` archives with flat memory.

Both writers take row blocks (k, m) of float64, one after another, and never hold more than one.

CSV: every number in the shortest form that reads back to the same double.  pyarrow's CSV writer
(double-conversion's shortest round trip) formats about three times faster than Python's
``repr``; it is used when pyarrow is installed, with ``repr`` as the fallback.  The two write
different text for some numbers (``1e-05`` against ``0.00001``, ``0.0`` against ``0``) but every
number reads back to the same double (tested).

npz: ``np.savez`` needs every array whole.  ``NpzWriter`` appends each block's rows to one
``.npy`` file per array in a scratch folder (the header names the final shape), then stores those
files uncompressed in the zip archive: the result is what ``np.savez`` writes, read by ``np.load``.
"""

from __future__ import annotations

import os
import shutil
import tempfile
import zipfile
from collections import deque
from typing import BinaryIO

import numpy as np

from minparam_cli.measured.arrow_csv import pyarrow_csv


def csv_block(block: np.ndarray, fast: bool = True) -> bytes:
    """Rows of ``block`` (k, m) as CSV lines, no header."""
    block = np.asarray(block, dtype=np.float64)
    pacsv = pyarrow_csv() if fast else None
    if pacsv is None:
        return "".join(",".join(map(repr, row)) + "\n" for row in block.tolist()).encode("ascii")
    import pyarrow as pa

    table = pa.Table.from_arrays([pa.array(np.ascontiguousarray(col)) for col in block.T],
                                 names=[f"c{i}" for i in range(block.shape[1])])
    sink = pa.BufferOutputStream()
    pacsv.write_csv(table, sink, pacsv.WriteOptions(include_header=False, quoting_style="none"))
    return sink.getvalue().to_pybytes()


class CsvWriter:
    """A header line, then row blocks, to an open binary file; use as a context manager.

    Rows are gathered into batches of ``ROWS``.  With ``background`` one worker thread formats and
    writes each batch while the caller computes the next rows (pyarrow formats without holding the
    GIL); one worker runs its tasks in order, so the rows stay in order; at most ``AHEAD`` batches
    wait.  ``close`` (or leaving the ``with`` block) writes the rest."""

    AHEAD = 1
    ROWS = 16384  # rows formatted at once: pyarrow's cost per call is large beside 2048-row blocks

    def __init__(self, fh: BinaryIO, header: tuple[str, ...], fast: bool = True, background: bool = True):
        self.fh, self.width, self.fast = fh, len(header), fast
        self._pool = None
        if background:
            from concurrent.futures import ThreadPoolExecutor

            self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="minparam-csv")
        self._pending: deque = deque()
        self._rows: list[np.ndarray] = []
        self._count = 0
        fh.write((",".join(header) + "\n").encode("ascii"))

    def write(self, block: np.ndarray) -> None:
        if block.shape[1] != self.width:
            raise ValueError(f"block of {block.shape[1]} columns for a header of {self.width}")
        self._rows.append(np.array(block, dtype=np.float64))
        self._count += block.shape[0]
        if self._count >= self.ROWS:
            self._flush_rows()

    def _flush_rows(self) -> None:
        if not self._rows:
            return
        rows = np.concatenate(self._rows) if len(self._rows) > 1 else self._rows[0]
        self._rows, self._count = [], 0
        if self._pool is None:
            self.fh.write(csv_block(rows, self.fast))
            return
        # one worker runs the tasks in the order given: it formats and writes, so the rows stay in order
        self._pending.append(self._pool.submit(self._format_and_write, rows))
        while len(self._pending) > self.AHEAD:
            self._pending.popleft().result()

    def _format_and_write(self, rows: np.ndarray) -> None:
        self.fh.write(csv_block(rows, self.fast))

    def close(self) -> None:
        try:
            self._flush_rows()
            while self._pending:
                self._pending.popleft().result()
        finally:
            self._shutdown()

    def _shutdown(self) -> None:
        if self._pool is not None:
            for f in self._pending:
                f.cancel()
            self._pending.clear()
            self._pool.shutdown(wait=True)
            self._pool = None
        self._rows, self._count = [], 0

    def __enter__(self) -> "CsvWriter":
        return self

    def __exit__(self, *exc) -> None:
        if exc[0] is None:
            self.close()
        else:
            self._shutdown()


class NpzWriter:
    """Arrays of known final shape filled in row order, then archived as an ``.npz`` file."""

    def __init__(self, shapes: dict[str, tuple[int, ...]]):
        self.shapes = dict(shapes)
        self.folder = tempfile.mkdtemp(prefix="minparam-npz-")
        self.files: dict[str, BinaryIO] = {}
        self.rows = {name: 0 for name in shapes}
        try:
            for name, shape in self.shapes.items():
                fh = open(os.path.join(self.folder, name + ".npy"), "wb")
                self.files[name] = fh
                np.lib.format.write_array_header_2_0(fh, {"descr": "<f8", "fortran_order": False, "shape": tuple(shape)})
        except BaseException:
            self.discard()
            raise

    def write(self, name: str, rows: np.ndarray) -> None:
        rows = np.ascontiguousarray(rows, dtype="<f8")
        if rows.shape[1:] != self.shapes[name][1:]:
            raise ValueError(f"{name}: rows of shape {rows.shape[1:]} for an array of shape {self.shapes[name]}")
        self.files[name].write(rows.tobytes())
        self.rows[name] += rows.shape[0]

    def save(self, path: str) -> None:
        """Archive the arrays at ``path`` (every array must be complete); the scratch folder goes."""
        try:
            for name, fh in self.files.items():
                fh.close()
                if self.rows[name] != self.shapes[name][0]:
                    raise ValueError(f"{name}: {self.rows[name]} rows written of {self.shapes[name][0]}")
            with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_STORED, allowZip64=True) as zf:
                for name in self.shapes:
                    with open(os.path.join(self.folder, name + ".npy"), "rb") as src, \
                            zf.open(name + ".npy", "w", force_zip64=True) as dst:
                        shutil.copyfileobj(src, dst, 1 << 20)
        finally:
            self.discard()

    def discard(self) -> None:
        for fh in self.files.values():
            fh.close()
        shutil.rmtree(self.folder, ignore_errors=True)
