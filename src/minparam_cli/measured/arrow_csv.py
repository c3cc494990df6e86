"""The fast CSV path of ``identify``: pyarrow's C++ CSV parser (a core dependency since issue 34; numpy
reads where pyarrow cannot be imported).

numpy's loadtxt parses about 45 MB/s; pyarrow's streaming reader several times that.  It is only a
faster way to the same numbers: its rows fill tables of exactly ``rows`` lines (the chunks numpy's
reader makes), and a line pyarrow does not read as the header's width of numbers (a comment, a
blank line, quotes, an empty cell, a word where a number belongs, bytes that are not UTF-8) makes
``measured.reading`` read the table it falls in, and the rest of the file, with numpy, whose values
and one-line error messages are then the ones reported.  Both parsers round decimal text to the
nearest double, so the values agree bit for bit (tests/test_fast_reader.py).
"""

from __future__ import annotations

import os
from collections.abc import Iterator

import numpy as np

from minparam_cli.runtime import CSV_BLOCK_BYTES as BLOCK_BYTES  # pyarrow's streaming block

READ_BYTES = 2**20
ENV = "MINPARAM_CSV_READER"  # "numpy" forces the numpy reader (benchmarks, tests, a suspected difference)


def pyarrow_csv():
    """pyarrow.csv, or None when pyarrow cannot be imported (an install without its dependencies)."""
    try:
        import pyarrow.csv as pacsv
    except ImportError:
        return None
    return pacsv


def csv_module():
    """pyarrow.csv, or None when pyarrow is not installed or the numpy reader is asked for."""
    if os.environ.get(ENV, "").strip().lower() == "numpy":
        return None
    return pyarrow_csv()


def memory_pool():
    """The allocator pyarrow's reader draws on: jemalloc where the wheel has it, else the C library's.

    pyarrow's default on Linux, mimalloc, kept more of the freed parse buffers mapped: the 1 M-sample
    Panda run of ``benchmarks/bench_identify.py`` peaked at 266-307 MB with it and at 248-260 MB with
    jemalloc (4 runs each, interleaved, same speed; the C library's 261-297 MB).  Passed to the reader,
    not set as pyarrow's default: a library does not change its host process."""
    import pyarrow as pa

    try:
        return pa.jemalloc_memory_pool()
    except NotImplementedError:  # a build without jemalloc (pyarrow's Windows wheels)
        return pa.system_memory_pool()


def give_back(pool) -> None:
    """Return the pool's freed pages to the system once a file is read: jemalloc keeps them for
    reuse, and identify's diagnosis, which allocates after the pass, then stacked its 40 MB on top
    (the 1 M-sample Panda run peaked at 296-306 MB, against 267-272 MB with this)."""
    pool.release_unused()


def _options(pacsv, width: int):
    """pyarrow's options for a table of ``width`` numbers a line: no quotes, no nulls, no empty
    lines (each of those is an error here, so that numpy's reader decides)."""
    import pyarrow as pa

    names = [f"c{j}" for j in range(width)]
    return {
        "read_options": pacsv.ReadOptions(column_names=names, use_threads=False, block_size=BLOCK_BYTES),
        "parse_options": pacsv.ParseOptions(delimiter=",", quote_char=False, double_quote=False, escape_char=False,
                                            newlines_in_values=False, ignore_empty_lines=False),
        "convert_options": pacsv.ConvertOptions(column_types={c: pa.float64() for c in names}, null_values=[],
                                                strings_can_be_null=False, quoted_strings_can_be_null=False, check_utf8=True),
    }


def tables(pacsv, path, offset: int, rows: int, width: int) -> Iterator[tuple[int, np.ndarray | None]]:
    """(byte offset, table) for the file from ``offset`` on: tables of ``rows`` lines (the last one
    shorter), from pyarrow's streaming reader (its C++ tokenizer cuts the lines; a few MB of the
    file in memory at a time).  When pyarrow refuses a line, the table it falls in is None, at the
    byte offset where that table starts, and the sequence ends."""
    import pyarrow as pa

    f = pa.OSFile(str(path), "r")
    pool = memory_pool()
    done = 0  # lines in the tables yielded
    try:
        f.seek(offset)
        try:
            reader = pacsv.open_csv(f, **_options(pacsv, width), memory_pool=pool)
        except (pa.ArrowException, ValueError):
            yield offset, None
            return
        out, filled = np.empty((rows, width)), 0
        while True:
            try:
                batch = reader.read_next_batch()
            except StopIteration:
                break
            except (pa.ArrowException, ValueError):
                yield after_lines(path, offset, done), None
                return
            if batch.num_columns != width or any(batch.column(j).null_count for j in range(width)):
                yield after_lines(path, offset, done), None
                return
            k, n = 0, batch.num_rows
            cols = np.empty((width, n))  # the batch's columns side by side (contiguous copies), then
            for j in range(width):  # one transposing copy into the row-major table: fewer strided writes
                cols[j] = float_values(batch.column(j))
            while k < n:
                take = min(rows - filled, n - k)
                out[filled : filled + take] = cols[:, k : k + take].T
                filled, k = filled + take, k + take
                if filled == rows:
                    yield -1, out
                    done += rows
                    out, filled = np.empty((rows, width)), 0
        yield -1, out[:filled]
    finally:
        f.close()
        give_back(pool)


def float_values(column) -> np.ndarray:
    """The values of a float64 pyarrow Array as numpy floats, a null as NaN: a read-only view of its
    data buffer when it has no null (the CSV tables here, the Parquet columns of
    ``measured.parquet``).  Not ``Array.to_numpy``, nor pyarrow's fill_null with a NaN scalar: in
    pyarrow 26 both import pandas on first use (about 50 MB and 0.3 s)."""
    n = len(column)
    if not n:
        return np.empty(0)
    values = np.frombuffer(column.buffers()[1], dtype=np.float64, count=n, offset=8 * column.offset)
    if not column.null_count:
        return values
    bits = np.unpackbits(np.frombuffer(column.buffers()[0], dtype=np.uint8), bitorder="little")  # 1: valid
    return np.where(bits[column.offset : column.offset + n].astype(bool), values, np.nan)


def after_lines(path, offset: int, lines: int) -> int:
    """Byte offset after ``lines`` lines from ``offset``, a line ending at \\n, \\r\\n or a lone \\r (as
    numpy's text reader and pyarrow's count them).  Only where pyarrow hands over to numpy."""
    import re

    if lines == 0:
        return offset
    ends = re.compile(rb"\r\n|\r|\n")
    with open(path, "rb") as fb:
        fb.seek(offset)
        pos, carry = offset, b""
        while True:
            data = fb.read(READ_BYTES)
            if not data:
                return pos + len(carry)
            buf = carry + data
            scan = buf[:-1] if buf.endswith(b"\r") else buf  # a \r at the end may be half of \r\n
            for m in ends.finditer(scan):
                lines -= 1
                if lines == 0:
                    return pos + m.end()
            pos, carry = pos + len(scan), buf[len(scan):]
