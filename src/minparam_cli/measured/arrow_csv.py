"""The fast CSV path of ``identify``: pyarrow's C++ CSV parser (optional extra ``minparam[arrow]``).

numpy's loadtxt parses about 45 MB/s; pyarrow's reader parses several hundred MB/s on one core and
uses the others.  It is only a faster way to the same numbers: the file is cut into blocks of
exactly ``rows`` lines (the chunks numpy's reader makes), and a block is accepted only when pyarrow
reads it as exactly that many rows of the header's width, every value a number (no quotes, no
empty or null cells).  Anything else, a comment, a blank line, a short row, a word where a number
belongs, makes ``identify.reading`` read that block and the rest of the file with numpy, whose
values and one-line error messages are then the ones reported.  Both parsers round decimal text to
the nearest double, so the values agree bit for bit (tests/test_fast_reader.py).
"""

from __future__ import annotations

import os
from typing import Iterator

import numpy as np

READ_BYTES = 8 * 2**20
ENV = "MINPARAM_CSV_READER"  # "numpy" forces the numpy reader (benchmarks, tests, a suspected difference)


def csv_module():
    """pyarrow.csv, or None when pyarrow is not installed or the numpy reader is asked for."""
    if os.environ.get(ENV, "").strip().lower() == "numpy":
        return None
    try:
        import pyarrow.csv as pacsv
    except ImportError:
        return None
    return pacsv


def blocks(path, offset: int, rows: int) -> Iterator[tuple[int, bytes, int]]:
    """(byte offset, bytes, lines) of the file from ``offset`` on, ``rows`` lines (cut after a
    newline byte) a block; the last block holds what remains.  Bytes only: nothing is decoded here."""
    with open(path, "rb") as fb:
        fb.seek(offset)
        rest = b""
        pos = offset
        while True:
            pieces, count = [rest], rest.count(b"\n")
            while count < rows:
                more = fb.read(READ_BYTES)
                if not more:
                    break
                pieces.append(more)
                count += more.count(b"\n")
            if count < rows:  # the end of the file
                tail = b"".join(pieces)
                if tail:
                    yield pos, tail, count + (not tail.endswith(b"\n"))
                return
            # the rows-th newline lies in the last piece: find it there
            last = pieces[-1]
            before = count - last.count(b"\n")
            k = rows - before  # that newline is the k-th of the last piece
            cut_in_last = int(np.flatnonzero(np.frombuffer(last, np.uint8) == 10)[k - 1]) + 1
            block = b"".join(pieces[:-1] + [last[:cut_in_last]])
            rest = last[cut_in_last:]
            del pieces, last
            yield pos, block, rows
            pos += len(block)
            del block


def parse(pacsv, block: bytes, width: int, lines: int) -> np.ndarray | None:
    """The block as a (lines, width) float table, or None when pyarrow does not read it as exactly
    that (the caller then reads it with numpy)."""
    import pyarrow as pa

    names = [f"c{j}" for j in range(width)]
    try:
        table = pacsv.read_csv(
            pa.BufferReader(block),
            read_options=pacsv.ReadOptions(column_names=names, use_threads=True),
            parse_options=pacsv.ParseOptions(delimiter=",", quote_char=False, double_quote=False, escape_char=False,
                                             newlines_in_values=False, ignore_empty_lines=True),
            convert_options=pacsv.ConvertOptions(column_types={c: pa.float64() for c in names}, null_values=[],
                                                 strings_can_be_null=False, quoted_strings_can_be_null=False,
                                                 check_utf8=True),
        )
    except (pa.ArrowException, ValueError):
        return None
    if table.num_rows != lines or table.num_columns != width:
        return None
    cols = np.empty((width, lines))  # column by column, each a contiguous copy of the parser's pieces
    for j in range(width):
        col = table.column(j)
        if col.null_count:
            return None
        s = 0
        for piece in col.chunks:
            cols[j, s : s + len(piece)] = piece.to_numpy(zero_copy_only=True)
            s += len(piece)
    del table
    return np.ascontiguousarray(cols.T)  # the row-major (lines, width) table numpy's reader makes
