"""A recording split over several CSV files (measured/recording.py): the joined files read as the one
file they were cut from (both CSV readers, across chunk edges), identify gives the same report, the
TX40 recording's two files give the same report as their shell join, and every kind of broken
description is one line, exit 2."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import cli as run

from minparam_cli.errors import DataError
from minparam_cli.measured.blocks import time_span
from minparam_cli.measured.records import DataOptions
from minparam_cli.measured.reading import raw_chunks

ROOT = Path(__file__).resolve().parents[1]
ROBOT = ROOT / "robots" / "planar3r.yaml"
N = 3
STEP = 0.004
# the shared data beside the repository (../shared), or beside a worktree's parent folder
TX40 = next((p / "shared" / "data" / "staubli-tx40" for p in (ROOT.parent, ROOT.parent.parent)
             if (p / "shared" / "data" / "staubli-tx40" / "curr_data.csv").exists()), ROOT.parent / "shared" / "data" / "staubli-tx40")



def write(path: Path, names: list[str], table: np.ndarray) -> Path:
    np.savetxt(path, table, delimiter=",", header=",".join(names), comments="", fmt="%.17g")
    return path


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """One file t,q,dq,tau (rows i·STEP), and the same columns cut into a q file (with dq) and a tau
    file, neither with a time column, plus their description."""
    d = tmp_path_factory.mktemp("rec")
    rng = np.random.default_rng(11)
    rows = 1003  # not a multiple of the chunk sizes below
    t = np.arange(rows) * STEP
    q, dq, tau = (rng.normal(size=(rows, N)) for _ in range(3))
    whole = write(d / "whole.csv", ["t"] + [f"{k}{j}" for k in ("q", "dq", "tau") for j in range(1, N + 1)],
                  np.column_stack([t, q, dq, tau]))
    write(d / "pos.csv", [f"Joint_{j}" for j in range(1, N + 1)] + [f"v{j}" for j in range(1, N + 1)], np.column_stack([q, dq]))
    write(d / "cur.csv", [f"Joint_{j}" for j in range(1, N + 1)], tau)
    desc = d / "rec.yaml"
    desc.write_text(f"rate: {1 / STEP}\nfiles:\n  - path: pos.csv\n    columns: {{q: Joint_, dq: v}}\n"
                    "  - path: cur.csv\n    columns: {tau: Joint_}\n")
    return {"dir": d, "whole": whole, "desc": desc}


def read(path: Path, **kw) -> tuple[np.ndarray, dict]:
    chunks = list(raw_chunks(path, N, DataOptions(joint_names=("a", "b", "c"), **kw)))
    return np.vstack([c for c, _ in chunks]), chunks[0][1]


@pytest.mark.parametrize("reader", ["pyarrow", "numpy"])
@pytest.mark.parametrize("chunk_rows", [7, 1003, 5000])
def test_joined_files_read_as_the_whole_file(files, monkeypatch, reader, chunk_rows):
    if reader == "numpy":
        monkeypatch.setenv("MINPARAM_CSV_READER", "numpy")
    else:
        pytest.importorskip("pyarrow")
    ref, layout = read(files["whole"], chunk_rows=chunk_rows)
    got, layout2 = read(files["desc"], chunk_rows=chunk_rows)
    assert layout2 == layout
    np.testing.assert_allclose(got[:, 0], ref[:, 0], rtol=1e-15, atol=0)  # i / rate against i·step
    np.testing.assert_array_equal(got[:, 1:], ref[:, 1:])
    assert time_span(files["desc"], DataOptions(joint_names=("a", "b", "c"))) == pytest.approx(
        time_span(files["whole"], DataOptions()), rel=1e-15)


def test_a_time_column_in_one_file_instead_of_a_rate(files, tmp_path):
    whole = np.loadtxt(files["whole"], delimiter=",", skiprows=1)
    write(tmp_path / "a.csv", ["stamp_ms"] + [f"q{j}" for j in range(1, N + 1)], np.column_stack([whole[:, 0] * 1e3, whole[:, 1:1 + N]]))
    write(tmp_path / "b.csv", [f"dq{j}" for j in range(1, N + 1)] + [f"tau{j}" for j in range(1, N + 1)], whole[:, 1 + N:])
    desc = tmp_path / "r.yml"
    desc.write_text("time_unit: ms\nfiles:\n  - {path: a.csv, columns: {t: stamp_ms, q: q}}\n  - {path: b.csv, columns: {dq: dq, tau: tau}}\n")
    ref, _ = read(files["whole"], chunk_rows=100)
    got, _ = read(desc, chunk_rows=100)
    np.testing.assert_allclose(got[:, 0], ref[:, 0], rtol=1e-15)
    np.testing.assert_array_equal(got[:, 1:], ref[:, 1:])
    first, last = time_span(desc, DataOptions())
    assert (first, last) == pytest.approx((0.0, 1002 * STEP), rel=1e-12)


def test_identify_reports_the_same_on_the_description_as_on_the_whole_file(files):
    out = []
    for data in (files["whole"], files["desc"]):
        r = run("identify", ROBOT, data, "--no-diagnose", "--friction", "coulomb,viscous", "--format", "json", "-q")
        assert r.exit_code == 0, r.output
        out.append(json.loads(r.output))
    a, b = out
    assert list(a["parameters"]) == list(b["parameters"])
    assert [p["value"] for p in a["parameters"].values()] == pytest.approx([p["value"] for p in b["parameters"].values()], rel=1e-9, abs=1e-12)
    assert a["samples_used"] == b["samples_used"] > 0


@pytest.mark.skipif(not (TX40 / "curr_data.csv").exists(), reason="the shared TX40 recording is not here")
def test_tx40_description_equals_the_shell_join(tmp_path):
    pos = np.loadtxt(TX40 / "pos_read_data.csv", delimiter=",", skiprows=1)
    cur = np.loadtxt(TX40 / "curr_data.csv", delimiter=",", skiprows=1)
    t = np.arange(len(pos)) * 0.0002
    joined = write(tmp_path / "tx40_motor.csv", ["t"] + [f"theta{j}" for j in range(1, 7)] + [f"c{j}" for j in range(1, 7)],
                   np.column_stack([t, pos, cur]))
    # the example description, its paths pointed at where the recording is found
    text = (ROOT / "examples" / "tx40.recording.yaml").read_text(encoding="utf-8")
    assert text.count("../../shared/data/staubli-tx40/") == 2
    desc = tmp_path / "tx40.recording.yaml"
    desc.write_text(text.replace("../../shared/data/staubli-tx40/", f"{TX40}/"), encoding="utf-8")
    common = ("--side", "motor", "--cutoff", "20", "--no-diagnose", "--format", "json", "-q")
    a = run("identify", ROOT / "robots" / "tx40.yaml", joined, "--columns", "q=theta,tau=c", *common)
    b = run("identify", ROOT / "robots" / "tx40.yaml", desc, *common)
    assert a.exit_code == 0 and b.exit_code == 0, a.output + b.output
    ra, rb = json.loads(a.output), json.loads(b.output)
    assert list(ra["parameters"]) == list(rb["parameters"])
    assert [p["value"] for p in ra["parameters"].values()] == pytest.approx([p["value"] for p in rb["parameters"].values()], rel=1e-6, abs=1e-9)


BROKEN = {
    "rows": ("rate: 250\nfiles:\n  - {path: pos.csv, columns: {q: Joint_}}\n  - {path: short.csv, columns: {tau: Joint_}}\n",
             "different numbers of rows"),
    "duplicate": ("rate: 250\nfiles:\n  - {path: pos.csv, columns: {q: Joint_}}\n  - {path: dup.csv, columns: {tau: Joint_}}\n",
                  "appears twice in the header"),
    "missing": ("rate: 250\nfiles:\n  - {path: pos.csv, columns: {q: Joint_}}\n  - {path: nowhere.csv, columns: {tau: Joint_}}\n",
                "no such file"),
    "rate0": ("rate: 0\nfiles:\n  - {path: pos.csv, columns: {q: Joint_}}\n  - {path: cur.csv, columns: {tau: Joint_}}\n", "rate must be"),
    "rate_nan": ("rate: .nan\nfiles:\n  - {path: pos.csv, columns: {q: Joint_}}\n  - {path: cur.csv, columns: {tau: Joint_}}\n", "rate must be"),
    "rate_text": ("rate: fast\nfiles:\n  - {path: pos.csv, columns: {q: Joint_}}\n  - {path: cur.csv, columns: {tau: Joint_}}\n", "rate must be"),
    "no_rate": ("files:\n  - {path: pos.csv, columns: {q: Joint_}}\n  - {path: cur.csv, columns: {tau: Joint_}}\n", "give either 'rate'"),
    "twice": ("rate: 250\nfiles:\n  - {path: pos.csv, columns: {q: Joint_}}\n  - {path: cur.csv, columns: {q: Joint_, tau: Joint_}}\n",
              "already named"),
    "no_tau": ("rate: 250\nfiles:\n  - {path: pos.csv, columns: {q: Joint_}}\n", "signal 'tau'"),
    "unknown": ("rate: 250\nspeed: 3\nfiles:\n  - {path: pos.csv, columns: {q: Joint_}}\n", "unknown key 'speed'"),
    "not_csv": ("rate: 250\nfiles:\n  - {path: pos.npz, columns: {q: Joint_}}\n  - {path: cur.csv, columns: {tau: Joint_}}\n", "not a .csv"),
    "no_match": ("rate: 250\nfiles:\n  - {path: pos.csv, columns: {q: Axis_}}\n  - {path: cur.csv, columns: {tau: Joint_}}\n", "no columns match"),
    "not_mapping": ("- pos.csv\n- cur.csv\n", "is a mapping"),
    "yaml": ("rate: [250\n", "malformed YAML"),
}


@pytest.mark.parametrize("case", sorted(BROKEN))
def test_broken_description_is_one_line_exit_2(files, tmp_path, case):
    text, expected = BROKEN[case]
    d = files["dir"]
    cur = np.loadtxt(d / "cur.csv", delimiter=",", skiprows=1)
    write(tmp_path / "short.csv", [f"Joint_{j}" for j in range(1, N + 1)], cur[:-1])
    write(tmp_path / "dup.csv", ["Joint_1", "Joint_2", "Joint_3", "Joint_2"], np.column_stack([cur, cur[:, 1]]))
    for name in ("pos.csv", "cur.csv"):
        (tmp_path / name).write_bytes((d / name).read_bytes())
    desc = tmp_path / "bad.yaml"
    desc.write_text(text)
    r = run("identify", ROBOT, desc, "--no-diagnose", "-q")
    assert r.exit_code == 2, r.output
    line = r.output.strip()
    assert "\n" not in line and "Traceback" not in line, r.output
    assert expected in line, line
    with pytest.raises(DataError):  # the stage's error too, not only the CLI's
        read(desc, chunk_rows=100)


def test_columns_option_with_a_description_is_refused(files):
    r = run("identify", ROBOT, files["desc"], "--columns", "q=pos", "--no-diagnose", "-q")
    assert r.exit_code == 2 and "--columns does not apply" in r.output.strip(), r.output


def test_a_batch_manifest_row_may_be_a_description(files, tmp_path):
    manifest = files["dir"] / "fleet.csv"
    manifest.write_text("recording,robot\nrec.yaml,\nwhole.csv,\n")
    r = run("identify", ROBOT, manifest, "-o", tmp_path / "out", "--no-diagnose", "-q")
    assert r.exit_code == 0, r.output
    a = json.loads((tmp_path / "out" / "rec.yaml.report.json").read_text())
    b = json.loads((tmp_path / "out" / "whole.csv.report.json").read_text())
    assert [p["value"] for p in a["parameters"].values()] == pytest.approx([p["value"] for p in b["parameters"].values()], rel=1e-9, abs=1e-12)
