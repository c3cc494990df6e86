"""Reading a data file chunk by chunk: the used columns (t, q, [dq], [ddq], tau) as one table.

CSV is parsed by numpy's loadtxt (about 45 MB/s).  A file larger than
BACKGROUND_BYTES is parsed by a second process, up to two chunks ahead of the
chunk being processed, so that parsing runs on the other core beside the
regressor and the factor updates.  The chunks, their values and the error
messages are the same either way.
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path
from typing import Iterator

import numpy as np

from minparam_cli.errors import DataError
from minparam_cli.identify.data import KEYS, DataOptions

BACKGROUND_BYTES = 64 * 2**20


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


def _layout(present: dict[str, bool], n: int) -> dict[str, slice | int | None]:
    """Where each key lives in a chunk's table (columns t, q, [dq], [ddq], tau): an index, a slice or None."""
    out, c = {}, 0
    for k in KEYS:
        if not present[k]:
            out[k] = None
        elif k == "t":
            out[k], c = 0, 1
        else:
            out[k], c = slice(c, c + n), c + n
    return out


def split(table: np.ndarray, layout: dict) -> dict:
    return {k: (None if where is None else table[:, where]) for k, where in layout.items()}


def raw_chunks(path: Path, n: int, opts: DataOptions) -> Iterator[tuple[np.ndarray, dict]]:
    """Chunk by chunk: a table of the used columns (t, q, [dq], [ddq], tau) and its layout."""
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
        layout = _layout({k: a is not None for k, a in arrays.items()}, n)
        used = [a.reshape(N, -1) for a in arrays.values() if a is not None]
        for s in range(0, N, opts.chunk_rows):
            yield np.hstack([a[s : s + opts.chunk_rows] for a in used]), layout
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
        layout = _layout({k: ix is not None for k, ix in idx.items()}, n)
        used = [c for k in KEYS if idx[k] is not None for c in idx[k]]
        background = path.stat().st_size > BACKGROUND_BYTES and sys.platform.startswith("linux")
        chunks = _background(path, opts.chunk_rows) if background else _sequential(fh, opts.chunk_rows)
        line_no = 1
        try:
            while True:
                try:
                    chunk = next(chunks)
                except ValueError as e:
                    raise DataError(f"{src}: non-numeric value after line {line_no} ({e})") from e
                if chunk.size == 0:
                    break
                if chunk.shape[1] != len(header):
                    raise DataError(f"{src}: rows have {chunk.shape[1]} values, the header has {len(header)}")
                line_no += len(chunk)
                last = len(chunk) < opts.chunk_rows
                yield (chunk if used == list(range(chunk.shape[1])) else chunk[:, used]), layout
                del chunk  # not alive while the next chunk is parsed
                if last:
                    break
        finally:
            chunks.close()


def _loadtxt(fh, rows: int) -> np.ndarray:
    with warnings.catch_warnings():  # a file of exactly k chunks ends on an empty read
        warnings.filterwarnings("ignore", "loadtxt: input contained no data")
        return np.loadtxt(fh, delimiter=",", max_rows=rows, ndmin=2)


def _sequential(fh, rows: int) -> Iterator[np.ndarray]:
    """Chunks of ``rows`` rows parsed here, from the open file (past its header); ValueError on bad values."""
    while True:
        chunk = _loadtxt(fh, rows)
        last = chunk.size == 0 or len(chunk) < rows
        yield chunk
        del chunk
        if last:
            return


def _parse_worker(path: str, rows: int, out) -> None:
    """The second process: parse the file's chunks in order into ``out`` (a queue); an error ends it."""
    try:
        with open(path, encoding="utf-8", errors="strict") as fh:
            fh.readline()
            for chunk in _sequential(fh, rows):
                out.put(chunk)
    except ValueError as e:
        out.put(("ValueError", str(e)))
    except Exception as e:  # noqa: BLE001 - reported by the reading process
        out.put(("OSError", str(e)))


def _background(path: Path, rows: int) -> Iterator[np.ndarray]:
    """The same chunks as ``_sequential``, parsed one or two ahead by a second process."""
    import multiprocessing as mp
    import queue

    ctx = mp.get_context("fork")
    out = ctx.Queue(maxsize=1)  # one parsed chunk waits while the next is parsed: memory stays bounded
    proc = ctx.Process(target=_parse_worker, args=(str(path), rows, out), daemon=True)
    proc.start()
    try:
        while True:
            try:
                item = out.get(timeout=1.0)
            except queue.Empty:
                if not proc.is_alive():
                    raise DataError(f"{path}: the parsing process ended unexpectedly (exit code {proc.exitcode})") from None
                continue
            if isinstance(item, tuple):
                if item[0] == "ValueError":
                    raise ValueError(item[1])
                raise DataError(f"{path}: cannot read file ({item[1]})")
            last = item.size == 0 or len(item) < rows
            yield item
            del item
            if last:
                return
    finally:
        if proc.is_alive():
            proc.terminate()
        proc.join()
        out.close()
