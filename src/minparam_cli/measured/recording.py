"""A recording split over several CSV files: a small YAML description that joins them row by row.

Controllers often log each signal to its own file, without a time column (the Stäubli TX40
recording of FIGAROH: motor positions in one file, motor currents in another, both at 5 kHz).
A recording description names the files, which columns of each hold which signal, and either
the sample rate or the file holding the time column::

    # tx40.recording.yaml
    rate: 5000                # Hz: no time column; sample i is at t = i / rate
    files:
      - path: ../shared/data/staubli-tx40/pos_read_data.csv   # relative to this file
        columns: {q: Joint_}  # signal -> column spec, as --columns: prefix, pattern_{} or a|b|c list
      - path: ../shared/data/staubli-tx40/curr_data.csv
        columns: {tau: Joint_}

Signals are t, q, dq, ddq, tau (q and tau required, each named by exactly one file); with a time
column (``t: NAME`` in one file's columns) ``time_unit`` (s, ms, us, ns) gives its unit and
``rate`` is refused.  Row i of every file is sample i: the files must have the same number of
data rows, which is checked as they are read (streamed chunk by chunk, both CSV readers of
``measured.reading``).  The description is untrusted input: parsed by the safe YAML reader
(``describe.safety.read_yaml``), unknown keys, a missing file, a bad rate, a signal named twice,
a column name repeated in a file's header, or files of different lengths are one-line errors.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator, cast

import numpy as np

from minparam_cli.errors import DataError
from minparam_cli.measured.columns import KEYS, TIME_UNITS, looks_headerless, spec_problem

DESCRIPTION_SUFFIXES = (".yaml", ".yml")
MAX_FILES = 64
MAX_RATE_HZ = 1e9


@dataclass(frozen=True)
class Part:
    path: Path
    columns: dict[str, str]  # signal -> column spec


@dataclass(frozen=True)
class Recording:
    source: str
    parts: tuple[Part, ...]
    rate_hz: float | None
    time_unit: str


def is_description(path: Path) -> bool:
    """A recording description by its name: a .yaml or .yml file that is not a rosbag2 folder's."""
    path = Path(path)
    return path.suffix.lower() in DESCRIPTION_SUFFIXES and path.name != "metadata.yaml"


def read_description(path: Path) -> Recording:
    """The description's files, signals and rate, checked; DataError (one line) otherwise."""
    from minparam_cli.safety import read_yaml
    from minparam_cli.errors import DescriptionError

    src = str(path)
    try:
        doc = read_yaml(Path(path))
    except DescriptionError as e:
        raise DataError(str(e)) from None
    if not isinstance(doc, dict):
        raise DataError(f"{src}: a recording description is a mapping with 'files' and 'rate' (or a time column)")
    unknown = sorted(str(k) for k in doc if k not in ("files", "rate", "time_unit"))
    if unknown:
        raise DataError(f"{src}: unknown key {unknown[0]!r} (a recording description has files, rate, time_unit)")
    files = doc.get("files")
    if not isinstance(files, list) or not files:
        raise DataError(f"{src}: 'files' must be a list of {{path, columns}} entries")
    if len(files) > MAX_FILES:
        raise DataError(f"{src}: {len(files)} files, at most {MAX_FILES}")
    parts: list[Part] = []
    named: dict[str, int] = {}
    seen: set[Path] = set()
    for i, entry in enumerate(files):
        where = f"{src}: files[{i}]"
        if not isinstance(entry, dict) or set(entry) - {"path", "columns"} or "path" not in entry or "columns" not in entry:
            raise DataError(f"{where} must be a mapping with exactly 'path' and 'columns'")
        if not isinstance(entry["path"], str) or not entry["path"].strip():
            raise DataError(f"{where}.path must be a file name")
        cols = entry["columns"]
        if not isinstance(cols, dict) or not cols:
            raise DataError(f"{where}.columns must map signals (t, q, dq, ddq, tau) to column specs")
        spec: dict[str, str] = {}
        for key, value in cols.items():
            if not isinstance(value, str):
                raise DataError(f"{where}.columns.{key}: expected a column spec (text), got {type(value).__name__}")
            problem = spec_problem(str(key), value.strip())
            if problem:
                raise DataError(f"{where}.columns: {problem}")
            if key in named:
                raise DataError(f"{where}.columns: signal {key!r} is already named by files[{named[key]}]")
            named[key] = i
            spec[str(key)] = value.strip()
        p = Path(entry["path"])
        p = p if p.is_absolute() else Path(path).parent / p
        if p.suffix.lower() != ".csv":
            raise DataError(f"{where}.path: {entry['path']} is not a .csv file (a description joins CSV files)")
        if p.resolve() in seen:
            raise DataError(f"{where}.path: {entry['path']} is listed twice")
        seen.add(p.resolve())
        parts.append(Part(p, spec))
    for key in ("q", "tau"):
        if key not in named:
            raise DataError(f"{src}: no file names the signal {key!r} (columns: {{{key}: SPEC}})")
    rate = doc.get("rate")
    if ("t" in named) == (rate is not None):
        raise DataError(f"{src}: give either 'rate' (Hz, files without a time column) or one file's time column "
                        f"(columns: {{t: NAME}}), {'not both' if rate is not None else 'not neither'}")
    if rate is not None:
        if isinstance(rate, bool) or not isinstance(rate, (int, float)) or not (math.isfinite(rate) and 0 < rate <= MAX_RATE_HZ):
            raise DataError(f"{src}: rate must be a sample rate in Hz, > 0 and <= {MAX_RATE_HZ:g}; got {rate!r}")
        rate = float(rate)
    unit = doc.get("time_unit", "s")
    if unit not in TIME_UNITS:
        raise DataError(f"{src}: time_unit must be one of {', '.join(TIME_UNITS)}; got {unit!r}")
    if rate is not None and "time_unit" in doc:
        raise DataError(f"{src}: time_unit is for a time column; with 'rate' the times are in seconds")
    return Recording(src, tuple(parts), rate, unit)


def _indices(header: list[str], part: Part, n: int, src: str) -> dict[str, list[int]]:
    """Column indices of each signal this file names."""
    from minparam_cli.measured.columns import header_names, key_indices

    names = header_names(header)
    if looks_headerless(names):
        raise DataError(f"{src}: no header row (line 1 holds {len(names)} numbers); the description names columns")
    dup = next((h for i, h in enumerate(names) if h in names[:i]), None)
    if dup is not None:
        raise DataError(f"{src}: column {dup!r} appears twice in the header")
    out = {}
    for key, spec in part.columns.items():
        if key == "t":
            if spec not in names:
                raise DataError(f"{src}: missing time column {spec!r} (named by the recording description)")
            out[key] = [names.index(spec)]
            continue
        found = key_indices(names, key, spec, n, src, required=False)
        if found is None:
            raise DataError(f"{src}: no columns match {key}: {spec} (the recording description's spec)")
        out[key] = found
    return out


def recording_chunks(path: Path, n: int, opts) -> Iterator[tuple[np.ndarray, dict]]:
    """Chunks of ``opts.chunk_rows`` rows of the joined files: the used columns (t, q, [dq], [ddq],
    tau) and their layout, as ``measured.reading.raw_chunks`` yields them, time in seconds."""
    from minparam_cli.measured.tables import column_layout, csv_tables

    rec = read_description(path)
    if opts.columns:
        raise DataError(f"{rec.source}: --columns does not apply to a recording description (its files name their columns)")
    readers, where = [], {}
    try:
        for i, part in enumerate(rec.parts):
            tables = csv_tables(part.path, opts.chunk_rows)
            readers.append(tables)
            for key, cols in _indices(next(tables), part, n, str(part.path)).items():
                where[key] = (i, cols)
        layout = column_layout({k: (k in where) or (k == "t") for k in KEYS}, n)
        divisor = TIME_UNITS[rec.time_unit]
        rows = 0
        while True:
            chunks = [next(r, None) for r in readers]
            sizes = [0 if c is None else len(c) for c in chunks]
            if len(set(sizes)) > 1:
                short = min(range(len(sizes)), key=sizes.__getitem__)
                longer = max(range(len(sizes)), key=sizes.__getitem__)
                raise DataError(f"{rec.source}: the files have different numbers of rows: {rec.parts[short].path} "
                                f"ends after {rows + sizes[short]} data rows, {rec.parts[longer].path} has more")
            if sizes[0] == 0:
                break
            m = sizes[0]
            full = cast("list[np.ndarray]", chunks)  # equal sizes above zero: every file gave a chunk
            if rec.rate_hz is not None:
                t = (rows + np.arange(m, dtype=float)) / rec.rate_hz
            else:
                i, cols = where["t"]
                t = full[i][:, cols[0]] / divisor
            table = np.column_stack([t] + [full[where[k][0]][:, where[k][1]] for k in KEYS[1:] if k in where])
            rows += m
            yield table, layout
            del chunks, full, table
    finally:
        for r in readers:
            r.close()


def recording_time_span(path: Path, opts) -> tuple[float, float]:
    """First and last time stamp (s) of a described recording: from the row count and the rate, or
    from the time column's file (its head and tail)."""
    from minparam_cli.measured.tables import require_data_file

    rec = read_description(path)
    for part in rec.parts:
        if "t" in part.columns:
            from dataclasses import replace

            from minparam_cli.measured.spans import csv_time_span

            first, last = csv_time_span(part.path, replace(opts, columns={"t": part.columns["t"]}))
            return first / TIME_UNITS[rec.time_unit], last / TIME_UNITS[rec.time_unit]
    first_file = rec.parts[0].path
    require_data_file(first_file)
    rows = _data_rows(first_file)
    if rows < 2:
        raise DataError(f"{first_file}: fewer than two data rows")
    assert rec.rate_hz is not None  # read_description: a recording without a time column has a rate
    return 0.0, (rows - 1) / rec.rate_hz


def _data_rows(path: Path) -> int:
    """Lines after the header (blank lines at the end not counted), read in blocks: bounded memory
    for any line length.  Only the time span uses it; the reader counts the rows exactly."""
    lines, tail = 0, b"\n"
    try:
        with open(path, "rb") as fh:
            while block := fh.read(2**20):
                lines += block.count(b"\n")
                tail = block
    except OSError as e:
        raise DataError(f"{path}: cannot read file ({e.strerror})") from None
    if lines and not tail.endswith(b"\n"):
        lines += 1  # a last line without its newline
    return max(lines - 1, 0)
