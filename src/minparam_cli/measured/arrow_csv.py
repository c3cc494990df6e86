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

READ_BYTES = 2**20
PIECE_ROWS = 16_384  # lines parsed at once: pyarrow's buffers stay a few MB
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


def _take_lines(fb, rest: bytes, want: int) -> tuple[bytes, int, bytes]:
    """(bytes of the next ``want`` lines, or of what remains at the end of the file; their number of
    lines; the bytes read past them), reading from ``fb`` after ``rest``."""
    pieces, count = [rest], rest.count(b"\n")
    while count < want:
        more = fb.read(READ_BYTES)
        if not more:
            tail = b"".join(pieces)
            return tail, count + (bool(tail) and not tail.endswith(b"\n")), b""
        pieces.append(more)
        count += more.count(b"\n")
    last = pieces[-1]
    k = want - (count - last.count(b"\n"))  # the cut is after the k-th newline of the last piece
    cut = int(np.flatnonzero(np.frombuffer(last, np.uint8) == 10)[k - 1]) + 1
    return b"".join(pieces[:-1] + [last[:cut]]), want, last[cut:]


def tables(pacsv, path, offset: int, rows: int, width: int) -> Iterator[tuple[int, np.ndarray | None]]:
    """(byte offset, table) for the file from ``offset`` on: tables of ``rows`` lines (the last one
    shorter), each parsed in pieces of PIECE_ROWS lines so that memory stays near one table's;
    a table pyarrow does not read exactly is None, and ends the sequence."""
    with open(path, "rb") as fb:
        fb.seek(offset)
        rest, pos = b"", offset
        while True:
            out, filled, start = np.empty((rows, width)), 0, pos
            while filled < rows:
                want = min(PIECE_ROWS, rows - filled)
                piece, lines, rest = _take_lines(fb, rest, want)
                if not piece:
                    break
                part = parse(pacsv, piece, width, lines)
                if part is None:
                    yield start, None
                    return
                out[filled : filled + lines] = part
                filled += lines
                pos += len(piece)
                if lines < want:
                    break
            yield start, out[:filled]
            if filled < rows:
                return


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
    cols = np.empty((width, lines))  # column by column, each a contiguous copy of the parser's blocks
    for j in range(width):
        col = table.column(j)
        if col.null_count:
            return None
        s = 0
        for piece in col.chunks:
            cols[j, s : s + len(piece)] = piece.to_numpy(zero_copy_only=True)
            s += len(piece)
    return cols.T  # (lines, width); the caller copies it into its row-major table
