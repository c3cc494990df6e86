"""--columns specs (prefix, {} pattern, explicit list, numbering from 0 or 1), --time-unit, and the
refusal of a CSV without a header: a renamed file reads as the same table as the original."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import cli

from minparam_cli.errors import DataError
from minparam_cli.measured.blocks import time_span
from minparam_cli.measured.records import DataOptions
from minparam_cli.measured.reading import raw_chunks
from minparam_cli.measured.columns import parse_columns

ROBOT = Path(__file__).resolve().parents[1] / "robots" / "planar3r.yaml"
N = 3


@pytest.fixture(scope="module")
def table():
    rng = np.random.default_rng(7)
    t = np.arange(400) * 0.004
    return np.column_stack([t, rng.normal(size=(400, 4 * N))])  # t, q, dq, ddq, tau


def write(path: Path, names: list[str], table: np.ndarray, header=True) -> Path:
    np.savetxt(path, table, delimiter=",", header=",".join(names) if header else "", comments="", fmt="%.17g")
    return path


def read(path: Path, **kw) -> tuple[np.ndarray, dict]:
    chunks = list(raw_chunks(path, N, DataOptions(**kw)))
    return np.vstack([c for c, _ in chunks]), chunks[0][1]


def default_names():
    return ["t"] + [f"{k}{j}" for k in ("q", "dq", "ddq", "tau") for j in range(1, N + 1)]


def test_pattern_suffix_list_and_zero_based_read_as_the_default(tmp_path, table):
    ref, layout = read(write(tmp_path / "ref.csv", default_names(), table))
    names = (["time"] + [f"position_{j}" for j in range(N)] + [f"vel_{c}" for c in "abc"]
             + [f"acc{j}" for j in range(N)] + [f"{j}_effort" for j in range(1, N + 1)])
    # the file's columns in another order too: the specs pick them by name
    perm = [0] + list(range(1 + 3 * N, 1 + 4 * N)) + list(range(1, 1 + 3 * N))
    other = write(tmp_path / "other.csv", [names[i] for i in perm], table[:, perm])
    got, layout2 = read(other, columns=parse_columns("t=time,q=position_{},dq=vel_a|vel_b|vel_c,ddq=acc,tau={}_effort"))
    assert layout2 == layout
    np.testing.assert_array_equal(got, ref)


def test_time_unit_divides_to_seconds(tmp_path, table):
    ref, _ = read(write(tmp_path / "s.csv", default_names(), table))
    for unit, scale in (("ms", 1e3), ("us", 1e6), ("ns", 1e9)):
        t_unit = table.copy()
        t_unit[:, 0] = np.round(table[:, 0] * scale)  # whole units, as a logger writes them
        path = write(tmp_path / f"{unit}.csv", default_names(), t_unit)
        got, _ = read(path, time_unit=unit)
        np.testing.assert_array_equal(got[:, 1:], ref[:, 1:])
        np.testing.assert_allclose(got[:, 0], ref[:, 0], rtol=0, atol=1e-15)
        first, last = time_span(path, DataOptions(time_unit=unit))
        assert (first, last) == (got[0, 0], got[-1, 0])


def test_cli_time_unit_and_pattern_give_the_same_report(tmp_path):
    sim = tmp_path / "sim.csv"
    assert cli("simulate", ROBOT, "--duration", "6", "--noise", "0.01", "-o", sim).exit_code == 0
    header = open(sim).readline().strip().split(",")
    data = np.loadtxt(sim, delimiter=",", skiprows=1)
    data[:, 0] = np.round(data[:, 0] * 1e3, 9)
    renamed = ["stamp_ms" if h == "t" else h.replace("tau", "") + "_torque" if h.startswith("tau") else h for h in header]
    write(tmp_path / "ms.csv", renamed, data)
    a = cli("identify", ROBOT, sim, "-f", "json", "-q")
    b = cli("identify", ROBOT, tmp_path / "ms.csv", "-f", "json", "-q", "--columns", "t=stamp_ms,tau={}_torque",
            "--time-unit", "ms")
    assert a.exit_code == 0 and b.exit_code == 0, b.output
    import json

    pa, pb = json.loads(a.output)["parameters"], json.loads(b.output)["parameters"]
    assert list(pa) == list(pb)
    for k in pa:
        assert pb[k]["value"] == pytest.approx(pa[k]["value"], rel=1e-9, abs=1e-12)


def test_headerless_file_says_which_header_to_add(tmp_path, table):
    path = write(tmp_path / "bare.csv", [], table[:, : 1 + 2 * N], header=False)
    with open(path) as fh:
        lines = fh.read().splitlines()[1:]  # savetxt wrote an empty header line
    path.write_text("\n".join(lines) + "\n")
    r = cli("identify", ROBOT, path)
    assert r.exit_code == 2 and "Traceback" not in r.output
    assert len(r.output.strip().splitlines()) == 1
    assert "no header row (line 1 holds 7 numbers)" in r.output and "sed -i '1i t,q1,q2,q3,tau1,tau2,tau3'" in r.output
    # a width that fits no layout still says what the columns are
    odd = tmp_path / "odd.csv"
    odd.write_text("0,1,2,3\n0.1,1,2,3\n")
    r = cli("identify", ROBOT, odd)
    assert r.exit_code == 2 and "no header row (line 1 holds 4 numbers); add a first line naming the columns" in r.output


@pytest.mark.parametrize("spec,needle", [
    ("q", "expected KEY=NAME items"),
    ("speed=v", "keys are"),
    ("t=a|b", "t is one column"),
    ("q=a||b", "an empty name in the list"),
    ("q=a|a|b", "a column named twice"),
    ("q={}_{}", "one '{}' for the joint number"),
    ("q={}", "a pattern needs text beside"),
    ("q=a,q=b", "q given twice"),
])
def test_bad_specs_are_refused(spec, needle):
    with pytest.raises(ValueError, match=None) as e:
        parse_columns(spec)
    assert needle in str(e.value)
    r = cli("identify", ROBOT, "x.csv", "--columns", spec)
    assert r.exit_code == 2 and needle in r.output


def test_list_of_the_wrong_length_or_missing_names(tmp_path, table):
    path = write(tmp_path / "d.csv", default_names(), table)
    with pytest.raises(DataError, match=r"--columns q= lists 2 columns, the robot has 3 joints"):
        read(path, columns={"q": "q1|q2"})
    with pytest.raises(DataError, match=r"missing column 'q9' \(listed in --columns q=\)"):
        read(path, columns={"q": "q1|q2|q9"})


def test_numbering_must_be_one_run(tmp_path, table):
    names = default_names()
    names[1:1 + N] = ["q0", "q1", "q3"]
    path = write(tmp_path / "gap.csv", names, table)
    with pytest.raises(DataError, match=r"the data have columns q0, q1, q3, the robot has 3 joints \(q2 missing; q3 beyond joint 3\)"):
        read(path)
    names[1:1 + N] = ["q0", "q1", "q2"]
    got, _ = read(write(tmp_path / "zero.csv", names, table))
    np.testing.assert_array_equal(got[:, 1:1 + N], table[:, 1:1 + N])
