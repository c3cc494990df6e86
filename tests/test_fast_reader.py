"""pyarrow's CSV reader (measured/arrow_csv.py) against numpy's on the same files: the same chunks,
the same values bit for bit, the same one-line errors; and it is really the one that reads a clean
file.  (The bad-row messages of both readers, row by row, are in test_identify_reading.py.)"""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
from typer.testing import CliRunner

from minparam_cli.cli.app import app
from minparam_cli.errors import DataError
from minparam_cli.measured.records import DataOptions
from minparam_cli.measured.reading import raw_chunks

pytest.importorskip("pyarrow.csv")

HEADER = "t,q1,q2,dq1,dq2,ddq1,ddq2,tau1,tau2"


@pytest.fixture(autouse=True)
def _small_blocks(monkeypatch):
    """pyarrow's streaming reader returns a batch per block; 8 kB blocks (about 60 lines here) put
    batch edges inside every 700-row table, as 1 MB blocks do in 200000-row chunks."""
    from minparam_cli.measured import arrow_csv

    monkeypatch.setattr(arrow_csv, "BLOCK_BYTES", 8192)


def chunks(path, monkeypatch, reader: str, rows: int = 700):
    monkeypatch.setenv("MINPARAM_CSV_READER", reader)
    return [table.copy() for table, _ in raw_chunks(path, 2, DataOptions(chunk_rows=rows))]


def outcome(path, monkeypatch, reader: str, rows: int = 700):
    """The chunks, or the error's text."""
    try:
        return chunks(path, monkeypatch, reader, rows)
    except DataError as e:
        return str(e)


def same(a, b) -> bool:
    if isinstance(a, str) or isinstance(b, str):
        return a == b
    return len(a) == len(b) and all(x.shape == y.shape and np.array_equal(x.view(np.uint64), y.view(np.uint64)) for x, y in zip(a, b, strict=True))


def number_texts(rng, n: int) -> list[str]:
    """Decimal texts of many kinds: shortest round-trip, 17 and 9 digits, exponents, integers, signs,
    subnormals, beyond the double range, far more digits than a double holds."""
    x = rng.standard_normal(n) * 10.0 ** rng.integers(-12, 12, n)
    kinds = [lambda v: repr(float(v)), lambda v: f"{v:.17g}", lambda v: f"{v:.9g}", lambda v: f"{v:e}",
             lambda v: str(int(v * 1000)), lambda v: f"+{abs(v):.6f}", lambda v: f" {v:.4f} ",
             lambda v: f"{v:.40f}", lambda v: f"{v:.3e}".replace("e", "E")]
    out = [kinds[int(k)](v) for k, v in zip(rng.integers(0, len(kinds), n), x, strict=True)]
    for i, special in zip(rng.choice(n, 8, replace=False), ["4.9e-324", "2.2250738585072011e-308", "1e-400", "1.7976931348623157e308",
                                                           "0.1000000000000000055511151231257827021181583404541015625", "-0", ".5", "5."], strict=True):
        out[i] = special
    return out


def write(path, rows: list[list[str]], newline="\n", header=HEADER, end=True):
    text = newline.join([header] + [",".join(r) for r in rows]) + (newline if end else "")
    path.write_bytes(text.encode())
    return path


@pytest.mark.parametrize("n", [3000, 2800])  # 2800: a whole number of 700-row chunks
def test_the_same_values_bit_for_bit_and_the_same_chunks(tmp_path, monkeypatch, n):
    rng = np.random.default_rng(11)
    cells = number_texts(rng, n * 8)
    rows = [[f"{i / 100:.2f}"] + cells[8 * i : 8 * i + 8] for i in range(n)]
    path = write(tmp_path / "d.csv", rows)
    fast, slow = chunks(path, monkeypatch, "pyarrow"), chunks(path, monkeypatch, "numpy")
    assert [len(c) for c in fast] == [len(c) for c in slow] == [700] * (n // 700) + ([n % 700] if n % 700 else [])
    assert same(fast, slow)
    every = np.concatenate(slow)
    assert (every == 5e-324).any() and (every == np.finfo(float).max).any()  # the specials were read


def test_a_clean_file_is_read_by_pyarrow_alone(tmp_path, monkeypatch):
    from minparam_cli.measured import tables

    rows = [[f"{i / 100:.2f}"] + ["1.5"] * 8 for i in range(2000)]
    path = write(tmp_path / "d.csv", rows, newline="\r\n")
    calls = []
    monkeypatch.setattr(tables, "_sequential", lambda fh, rows: calls.append(1) or iter(()))
    got = chunks(path, monkeypatch, "pyarrow")
    assert not calls and sum(len(c) for c in got) == 2000


def test_the_reader_draws_on_the_chosen_memory_pool(tmp_path, monkeypatch):
    """The parse buffers come from ``arrow_csv.memory_pool()`` (jemalloc where the wheel has it: a lower
    peak than pyarrow's default, docs/methods/streaming.md), not from the default pool."""
    from minparam_cli.measured.arrow_csv import memory_pool

    rows = [[f"{i / 100:.2f}"] + ["1.5"] * 8 for i in range(2000)]
    path = write(tmp_path / "d.csv", rows)
    pool = memory_pool()
    assert pool.backend_name in ("jemalloc", "system")
    before = pool.total_bytes_allocated()
    got = chunks(path, monkeypatch, "pyarrow")
    assert sum(len(c) for c in got) == 2000
    assert pool.total_bytes_allocated() - before > 2000 * 9 * 8  # at least the floats themselves went through it


@pytest.mark.parametrize("stop", [None, 1])
def test_the_pool_gives_its_pages_back_when_the_file_ends_or_is_left(tmp_path, monkeypatch, stop):
    from minparam_cli.measured import arrow_csv

    given = []
    monkeypatch.setattr(arrow_csv, "give_back", lambda pool: given.append(pool.backend_name))
    rows = [[f"{i / 100:.2f}"] + ["1.5"] * 8 for i in range(2000)]
    path = write(tmp_path / "d.csv", rows)
    reader = arrow_csv.tables(__import__("pyarrow.csv").csv, path, len(HEADER) + 1, 500, 9)
    for i, _ in enumerate(reader):
        assert not given
        if i == stop:
            reader.close()
            break
    assert given == [arrow_csv.memory_pool().backend_name]


@pytest.mark.parametrize("case", ["comment lines", "blank lines", "quoted values", "carriage returns only", "no final newline",
                                  "every row too wide", "an empty cell", "nan and inf", "a null word", "header only",
                                  "a late bad row", "not utf-8"])
def test_files_pyarrow_does_not_read_exactly_give_numpy_s_values_or_errors(tmp_path, monkeypatch, case):
    base = [[f"{i / 100:.2f}"] + [f"{(i * 7 + j) % 13 / 3:.6f}" for j in range(8)] for i in range(2000)]
    path = tmp_path / "d.csv"
    if case == "comment lines":
        text = HEADER + "\n" + "\n".join(",".join(r) + (" # note" if i % 500 == 3 else "") for i, r in enumerate(base)) + "\n# end\n"
        path.write_text(text)
    elif case == "blank lines":
        text = HEADER + "\n" + "\n".join(",".join(r) + ("\n" if i in (10, 1500) else "") for i, r in enumerate(base)) + "\n"
        path.write_text(text)
    elif case == "quoted values":
        base[900][3] = '"0.5"'
        write(path, base)
    elif case == "carriage returns only":
        write(path, base, newline="\r")
    elif case == "no final newline":
        write(path, base, end=False)
    elif case == "every row too wide":
        write(path, [r + ["0"] for r in base])
    elif case == "an empty cell":
        base[1234][5] = ""
        write(path, base)
    elif case == "nan and inf":
        base[5][2], base[1600][7], base[1700][1] = "nan", "-inf", "NaN"
        write(path, base)
    elif case == "a null word":
        base[800][4] = "NA"
        write(path, base)
    elif case == "header only":
        write(path, [])
    elif case == "a late bad row":
        base[1999][8] = "1.2.3"
        write(path, base)
    else:
        write(path, base)
        data = path.read_bytes()
        k = data.index(b"\n", len(data) // 2) + 3
        path.write_bytes(data[:k] + b"\xff" + data[k + 1 :])
    fast, slow = outcome(path, monkeypatch, "pyarrow"), outcome(path, monkeypatch, "numpy")
    assert same(fast, slow), (fast if isinstance(fast, str) else "chunks", slow if isinstance(slow, str) else "chunks")
    if case in ("every row too wide", "an empty cell", "a null word", "a late bad row", "not utf-8"):
        assert isinstance(slow, str) and slow.startswith(f"{path}: ")  # an error, the same one line


def test_identify_reports_are_the_same_with_either_reader(tmp_path, monkeypatch):
    data = tmp_path / "sim.csv"
    r = CliRunner().invoke(app, ["simulate", "robots/planar2r.yaml", "--effects", "coulomb", "--noise", "0.01", "--duration", "10",
                                 "-o", str(data), "--quiet"])
    assert r.exit_code == 0, r.output
    reports = []
    for reader in ("numpy", "pyarrow"):
        monkeypatch.setenv("MINPARAM_CSV_READER", reader)
        r = CliRunner().invoke(app, ["identify", "robots/planar2r.yaml", str(data), "-f", "json", "--quiet", "--effects", "coulomb,viscous"])
        assert r.exit_code == 0, r.output
        reports.append(re.sub(r'"elapsed_s": [-+0-9.eE]+', "", r.stdout))
    assert reports[0] == reports[1]
    assert json.loads(r.stdout)["effects"][0]["effect"] == "coulomb"


def test_a_parquet_recording_gives_the_report_of_its_csv(tmp_path):
    pd = pytest.importorskip("pandas")
    data = tmp_path / "sim.csv"
    r = CliRunner().invoke(app, ["simulate", "robots/planar2r.yaml", "--effects", "viscous", "--noise", "0.01", "--duration", "10",
                                 "-o", str(data), "--quiet"])
    assert r.exit_code == 0, r.output
    pd.read_csv(data).to_parquet(tmp_path / "sim.parquet")
    texts = []
    for path in (data, tmp_path / "sim.parquet"):
        r = CliRunner().invoke(app, ["identify", "robots/planar2r.yaml", str(path), "-f", "json", "--quiet", "--effects", "coulomb,viscous"])
        assert r.exit_code == 0, r.output
        texts.append(re.sub(r'"elapsed_s": [-+0-9.eE]+', "", r.stdout).replace(str(path), "DATA"))
    assert texts[0] == texts[1]


@pytest.mark.parametrize("case, message", [
    ("text column", "column 'tau2' holds text, not numbers"),
    ("no time column", "missing time column 't' (use --columns t=NAME)"),
    ("not parquet", "cannot read Parquet"),
])
def test_a_broken_parquet_file_is_one_line(tmp_path, case, message):
    pd = pytest.importorskip("pandas")
    path = tmp_path / "d.parquet"
    frame = pd.DataFrame({c: np.arange(50) / 10.0 for c in HEADER.split(",")})
    if case == "text column":
        frame["tau2"] = "x"
    elif case == "no time column":
        frame = frame.rename(columns={"t": "time"})
    if case == "not parquet":
        path.write_bytes(b"PAR1 but not really")
    else:
        frame.to_parquet(path)
    r = CliRunner().invoke(app, ["identify", "robots/planar2r.yaml", str(path)])
    assert r.exit_code == 2 and r.stderr.startswith(f"minparam: error: {path}: {message}"), r.stderr
    assert len(r.stderr.strip().splitlines()) == 1


@pytest.mark.parametrize("kind", ["csv", "parquet"])
def test_the_fast_readers_do_not_import_pandas(tmp_path, kind):
    """pyarrow's Array.to_numpy imports pandas on first use (about 50 MB of identify's peak memory):
    the CSV and Parquet readers take the column buffers themselves, a Parquet null still becoming
    NaN. In a fresh process, since pandas may be loaded here."""
    import subprocess
    import sys

    rows = np.random.default_rng(0).standard_normal((3000, 5))
    names = ["t", "q1", "dq1", "ddq1", "tau1"]
    if kind == "csv":
        path = tmp_path / "d.csv"
        path.write_text(",".join(names) + "\n" + "\n".join(",".join(f"{v:.9g}" for v in r) for r in rows) + "\n")
        nulls = 0
    else:
        pa = pytest.importorskip("pyarrow")
        pq = pytest.importorskip("pyarrow.parquet")
        path = tmp_path / "d.parquet"
        tau = pa.array(rows[:, 4], mask=np.arange(3000) == 1234)  # one null
        pq.write_table(pa.table([pa.array(rows[:, j]) for j in range(4)] + [tau], names=names), path)
        nulls = 1
    code = (
        "import sys, numpy as np; from minparam_cli.measured.reading import raw_chunks;"
        "from minparam_cli.measured.records import DataOptions;"
        f"cs = [c[0] for c in raw_chunks({str(path)!r}, 1, DataOptions())];"
        "print(sum(len(c) for c in cs), int(sum(np.isnan(c).sum() for c in cs)), 'pandas' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out == ["3000", str(nulls), "False"]


def test_float_values_read_nulls_as_nan_at_any_offset():
    """The buffers of a sliced pyarrow array start at an offset, its validity bitmap at a bit offset."""
    pa = pytest.importorskip("pyarrow")
    from minparam_cli.measured.arrow_csv import float_values

    data = [1.0, None, 2.0, 3.0, None, 5.0, 6.0, 7.0, 8.0, None, 10.0]
    whole = pa.array(data, type=pa.float64())
    for start in range(len(data)):
        part = whole.slice(start, len(data) - start - (start % 3))
        expected = np.array([np.nan if v is None else v for v in part.to_pylist()])
        assert np.array_equal(float_values(part), expected, equal_nan=True)
    assert float_values(pa.array([], type=pa.float64())).shape == (0,)
