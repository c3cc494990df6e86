"""Measured recordings as a batch run on untrusted files meets them (a fuzz sweep of the data readers).

A good but unusual recording (a byte-order mark, quoted column names, a header wider than the head
that the time span reads) gives the same identification as the plain file, with either CSV parser; a
broken one (a column named twice, a compressed file under a .csv name, a damaged Parquet page, a
torque too large to square, a FIFO given to evaluate) is refused with one line and exit code 2.
"""

from __future__ import annotations

import gzip
import json
import os
import warnings
from pathlib import Path

import numpy as np
import pytest
from conftest import cli, refused

ROBOT = Path(__file__).resolve().parents[1] / "robots" / "planar2r.yaml"


@pytest.fixture(scope="module")
def rec(tmp_path_factory) -> Path:
    """A 6 s simulated recording (t, q, dq, ddq, tau of the planar 2R) and a model identified from it."""
    d = tmp_path_factory.mktemp("rec")
    r = cli("simulate", ROBOT, "--duration", "6", "--effects", "coulomb,viscous", "--noise", "0.01", "-q", "-o", d / "sim.csv")
    assert r.exit_code == 0, r.output
    r = cli("identify", ROBOT, d / "sim.csv", "--no-diagnose", "-q", "--save-model", d / "model.json", "-o", d / "report.txt")
    assert r.exit_code == 0, r.output
    return d


def parameters(*args) -> list:
    """identify's fitted parameters (JSON) on the data, with the declared model only."""
    r = cli("identify", ROBOT, *args, "--no-diagnose", "-q", "-f", "json")
    assert r.exit_code == 0, r.output
    return json.loads(r.stdout)["parameters"]


@pytest.mark.parametrize("reader", ["arrow", "numpy"])
def test_byte_order_mark_is_not_part_of_the_header(rec, tmp_path, monkeypatch, reader):
    """Excel's "CSV UTF-8" starts the file with a byte-order mark (and ends lines with CRLF): the first
    column is still 't' (it read as '\\ufefft', and the file was refused as missing its time column)."""
    monkeypatch.setenv("MINPARAM_CSV_READER", reader)
    text = (rec / "sim.csv").read_text()
    bom = tmp_path / "excel.csv"
    bom.write_bytes(b"\xef\xbb\xbf" + text.replace("\n", "\r\n").encode())
    assert parameters(bom) == parameters(rec / "sim.csv")


@pytest.mark.parametrize("reader", ["arrow", "numpy"])
def test_quoted_column_names(rec, tmp_path, monkeypatch, reader):
    """Python's csv module (QUOTE_NONNUMERIC) and R's write.csv quote the names, not the numbers."""
    monkeypatch.setenv("MINPARAM_CSV_READER", reader)
    lines = (rec / "sim.csv").read_text().splitlines(keepends=True)
    quoted = tmp_path / "quoted.csv"
    quoted.write_text(",".join(f'"{h}"' for h in lines[0].strip().split(",")) + "\n" + "".join(lines[1:]))
    assert parameters(quoted) == parameters(rec / "sim.csv")


def test_header_wider_than_the_time_span_head(rec, tmp_path):
    """A logger's many extra signals make a header longer than the 64 KiB head the time span reads: it
    was refused as an 'empty file'."""
    lines = (rec / "sim.csv").read_text().splitlines()
    extra = [f"aux_signal_{k:03d}_{'x' * 100}" for k in range(600)]  # 69 KiB of names
    zeros = "," + ",".join("0" * len(extra))
    wide = tmp_path / "wide.csv"
    wide.write_text(",".join([lines[0], *extra]) + "\n" + "".join(line + zeros + "\n" for line in lines[1:]))
    assert len(lines[0]) + sum(len(e) + 1 for e in extra) > 65536
    assert parameters(wide) == parameters(rec / "sim.csv")


def test_header_longer_than_the_line_limit(rec, tmp_path):
    """A header past the reader's line limit is named as such (it was an 'empty file')."""
    lines = (rec / "sim.csv").read_text().splitlines()
    long = tmp_path / "long.csv"
    long.write_text("x" * (2**20 + 10) + "," + lines[0] + "\n" + "\n".join(lines[1:]) + "\n")
    refused("identify", ROBOT, long, "--no-diagnose", needle="line 1 (the header) is longer than")


@pytest.mark.parametrize("fmt", ["csv", "parquet"])
def test_used_column_named_twice(rec, tmp_path, fmt):
    """Two columns named q1 with different values: which one is the joint's cannot be told (the CSV
    reader took the last, the time column the first; both read silently)."""
    lines = (rec / "sim.csv").read_text().splitlines()
    header = lines[0].split(",")
    table = np.loadtxt(rec / "sim.csv", delimiter=",", skiprows=1)
    table = np.column_stack([table, table[:, header.index("q1")] + 1.0])
    header.append("q1")
    if fmt == "csv":
        path = tmp_path / "twice.csv"
        np.savetxt(path, table, delimiter=",", header=",".join(header), comments="", fmt="%.17g")
    else:
        pa = pytest.importorskip("pyarrow")
        import pyarrow.parquet as pq

        path = tmp_path / "twice.parquet"
        pq.write_table(pa.Table.from_arrays([pa.array(c) for c in table.T], names=header), path)
    refused("identify", ROBOT, path, "--no-diagnose", needle="column 'q1' appears 2 times")


def test_compressed_file_named_csv(rec, tmp_path):
    """A gzip-compressed recording under a .csv name is told as such (identify showed its bytes as a
    one-column header, evaluate called line 1 not UTF-8)."""
    packed = tmp_path / "run.csv"
    packed.write_bytes(gzip.compress((rec / "sim.csv").read_bytes()))
    refused("identify", ROBOT, packed, "--no-diagnose", needle="not CSV text but a gzip-compressed file")
    refused("evaluate", rec / "model.json", packed, needle="not CSV text but a gzip-compressed file")


def test_parquet_under_a_csv_name_is_told_by_both_ends(tmp_path):
    """Parquet starts and ends with PAR1; a CSV whose first column is named PAR1... is still CSV text."""
    from minparam_cli.errors import DataError
    from minparam_cli.measured.sniff import refuse_binary

    pa = pytest.importorskip("pyarrow")
    import pyarrow.parquet as pq

    real = tmp_path / "run.csv"
    pq.write_table(pa.table({"t": [0.0, 0.001], "q1": [0.0, 0.1]}), real)
    with pytest.raises(DataError, match="not CSV text but a Parquet file"):
        refuse_binary(real)
    text = tmp_path / "par.csv"
    text.write_text("PAR1_t,q1,tau1\n0,0,0\n")
    refuse_binary(text)  # no error: text


def test_damaged_parquet_page(rec, tmp_path):
    """Bytes overwritten inside a column chunk (its footer intact): pyarrow's OSError while decoding
    the page was an internal error, exit 1."""
    pa = pytest.importorskip("pyarrow")
    import pyarrow.parquet as pq

    lines = (rec / "sim.csv").read_text().splitlines()
    table = np.loadtxt(rec / "sim.csv", delimiter=",", skiprows=1)
    good = tmp_path / "good.parquet"
    pq.write_table(pa.Table.from_arrays([pa.array(c) for c in table.T], names=lines[0].split(",")), good, compression="snappy")
    data = good.read_bytes()
    bad = tmp_path / "bad.parquet"
    bad.write_bytes(data[:200] + b"\xff" * 400 + data[600:])
    refused("identify", ROBOT, bad, "--no-diagnose", needle="cannot read Parquet")
    refused("evaluate", rec / "model.json", bad, needle="cannot read Parquet")


def test_evaluate_torque_too_large_to_square(rec, tmp_path):
    """A torque of 1e308 is finite, its square is not: evaluate printed numpy's RuntimeWarning and an
    RMS of inf, exit 0 (identify refuses the same file)."""
    lines = (rec / "sim.csv").read_text().splitlines()
    header = lines[0].split(",")
    table = np.loadtxt(rec / "sim.csv", delimiter=",", skiprows=1)
    table[100, header.index("tau2")] = 1e308
    big = tmp_path / "big.csv"
    np.savetxt(big, table, delimiter=",", header=lines[0], comments="", fmt="%.17g")
    out = tmp_path / "report.txt"
    refused("evaluate", rec / "model.json", big, "-o", out, needle="measured torque too large to use")
    assert not out.exists()


def test_evaluate_names_a_fifo(rec, tmp_path):
    """A FIFO (or a device, a folder that is no bag) given to evaluate is named as what it is, as
    identify names it (it was 'data file not found')."""
    fifo = tmp_path / "pipe.csv"
    os.mkfifo(fifo)
    refused("evaluate", rec / "model.json", fifo, needle="is a named pipe (FIFO)")
    refused("evaluate", rec / "model.json", tmp_path, needle="is a folder")


def test_complex_npz_member_refused(rec, tmp_path):
    """numpy casts complex numbers to floats by dropping the imaginary part, with a ComplexWarning on
    stderr: an .npz member of complex numbers was read so, exit 0."""
    table = np.loadtxt(rec / "sim.csv", delimiter=",", skiprows=1)
    arrays = {"t": table[:, 0], "q": table[:, 1:3] + 0j, "dq": table[:, 3:5], "ddq": table[:, 5:7], "tau": table[:, 7:9]}
    np.savez(tmp_path / "complex.npz", **arrays)
    line = refused("identify", ROBOT, tmp_path / "complex.npz", "--no-diagnose", needle="array 'q' holds complex numbers")
    assert "Warning" not in line


def test_api_dates_and_masks(rec):
    """In memory: a time array of datetime64 was read as nanoseconds (the error then blamed the
    velocities); a masked array's masked entries were used as data.  Masked entries are now missing
    values (their rows dropped and counted, as a NaN's), and data=None (identify, evaluate) is an
    InputError, not a TypeError."""
    import minparam
    from minparam_cli.errors import DataError, InputError

    table = np.loadtxt(rec / "sim.csv", delimiter=",", skiprows=1)
    arrays = {"t": table[:, 0], "q": table[:, 1:3], "dq": table[:, 3:5], "ddq": table[:, 5:7], "tau": table[:, 7:9]}
    with pytest.raises(DataError, match="array 't' holds dates"):
        minparam.identify(ROBOT, {**arrays, "t": (arrays["t"] * 1e9).astype("datetime64[ns]")}, diagnose=False)
    with pytest.raises(InputError, match="got NoneType"):
        minparam.identify(ROBOT, None, diagnose=False)
    with pytest.raises(InputError, match="got NoneType"):
        minparam.evaluate(rec / "model.json", None)
    hidden = arrays["q"].copy()
    hidden[::50] = 1e3  # nonsense under the mask
    masked = minparam.identify(ROBOT, {**arrays, "q": np.ma.masked_array(hidden, mask=hidden == 1e3)}, diagnose=False)
    nan = hidden.copy()
    nan[::50] = np.nan
    dropped = minparam.identify(ROBOT, {**arrays, "q": nan}, diagnose=False)
    assert np.array_equal(masked.theta, dropped.theta)


def test_evaluate_takes_any_iterable_of_data_files(rec):
    """A generator of paths (Path.glob) was refused as a 'generator' after the API's data check was added:
    any iterable of files (not a mapping, not bytes) is read as a list of them."""
    import minparam

    listed = minparam.evaluate(rec / "model.json", [rec / "sim.csv"])
    globbed = minparam.evaluate(rec / "model.json", rec.glob("sim.csv"))
    assert globbed.to_dict()["files"] == listed.to_dict()["files"] and globbed.to_dict()["pooled"] == listed.to_dict()["pooled"]
    assert len(listed.to_dict()["files"]) == 1


def test_decimate_beyond_a_slice(rec):
    """--decimate 1e20 (an int click accepts) overflowed numpy's slice: an internal error, exit 1."""
    refused("identify", ROBOT, rec / "sim.csv", "--no-diagnose", "--decimate", str(10**20), needle="--decimate")


def test_bootstrap_replicates_bounded(rec):
    """--replicates 1e9 ran for ever (each replicate a refit); refused before any fit."""
    refused("identify", ROBOT, rec / "sim.csv", "--no-diagnose", "--sigma", "bootstrap", "--replicates", "1000000000",
            needle="--replicates 1000000000: at most")


def test_gravity_beyond_any_unit(rec):
    """--gravity 1e308,0,0 (finite) overflowed the design: an internal IndexError, exit 1."""
    refused("identify", ROBOT, rec / "sim.csv", "--no-diagnose", "--gravity", "1e308,0,0", needle="--gravity")


def test_report_path_link_loop(rec, tmp_path):
    """-o naming a symbolic link to itself: Path.resolve()'s RuntimeError was an internal error, exit 1."""
    loop = tmp_path / "loop.txt"
    os.symlink(loop, loop)
    refused("identify", ROBOT, rec / "sim.csv", "--no-diagnose", "-o", loop, needle="symbolic link loop")


def test_simulate_sample_count_bounded(tmp_path):
    """--duration 1e9 ran out of memory (exit 1) and 1e6 wrote for hours: refused before any work,
    the -o file untouched."""
    out = tmp_path / "sim.csv"
    out.write_text("kept\n")
    refused("simulate", ROBOT, "--duration", "1e9", "-q", "-o", out, needle="-sample limit")
    assert out.read_text() == "kept\n"


def test_simulate_noise_and_strength_bounded(tmp_path):
    """--strength 1e308 (finite) made the effect's amplitude overflow: numpy's RuntimeWarning on stderr and
    torques of inf written to the CSV, exit 0."""
    out = tmp_path / "sim.csv"
    refused("simulate", ROBOT, "--duration", "2", "--effects", "coulomb", "--strength", "1e308", "-q", "-o", out,
            needle="--strength must be at most")
    refused("simulate", ROBOT, "--duration", "2", "--noise", "1e308", "-q", "-o", out, needle="--noise must be at most")
    assert not out.exists()


def test_simulate_trajectory_csv_with_bom(rec, tmp_path):
    """A sampled --trajectory CSV saved with a byte-order mark was refused as missing its column t."""
    bom = tmp_path / "bom.csv"
    bom.write_bytes(b"\xef\xbb\xbf" + (rec / "sim.csv").read_bytes())
    for src, out in ((rec / "sim.csv", tmp_path / "plain_out.csv"), (bom, tmp_path / "bom_out.csv")):
        r = cli("simulate", ROBOT, "--trajectory", src, "-q", "-o", out)
        assert r.exit_code == 0, r.output
    assert (tmp_path / "bom_out.csv").read_bytes() == (tmp_path / "plain_out.csv").read_bytes()


def test_simulate_trajectory_csv_without_rows(rec, tmp_path):
    """A --trajectory CSV with its header only: numpy's 'input contained no data' UserWarning went to
    stderr beside the error (three lines)."""
    head = tmp_path / "head.csv"
    head.write_text((rec / "sim.csv").read_text().splitlines()[0] + "\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)  # in this process a warning is not printed: make it an error
        refused("simulate", ROBOT, "--trajectory", head, "-q", "-o", tmp_path / "out.csv", needle="expected at least 2 rows")


def test_excite_sample_count_and_starts_bounded(tmp_path):
    """--rate 1e9, --base-frequency 1e-9 or --starts 1e9 ran out of memory (exit 1); refused before any work."""
    out = tmp_path / "exc.csv"
    refused("excite", ROBOT, "--rate", "1e9", "-q", "-o", out, needle="-sample limit")
    refused("excite", ROBOT, "--starts", "1000000000", "-q", "-o", out, needle="--starts must be at most")
    assert not out.exists()
