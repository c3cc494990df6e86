"""Small fixes of issue 32 (point 6): a --columns key whose columns are missing, evaluate --columns
and -q, what an empty or ';'-separated CSV is, identify --plot interrupted, reversed or equal URDF
joint limits, a truss with two nodes at the same place."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import ROBOTS
from typer.testing import CliRunner

from minparam_cli.cli.app import app

runner = CliRunner()
PLANAR = str(ROBOTS / "planar2r.yaml")


def one_line_exit_2(r, needle: str) -> None:
    lines = r.stderr.strip().splitlines()
    assert r.exit_code == 2 and len(lines) == 1 and "Traceback" not in r.output, r.output
    assert needle in lines[0], lines[0]


@pytest.fixture(scope="module")
def sim(tmp_path_factory):
    """A planar 2R recording (simulate, seed 1, 10 s) and a model identified from it."""
    d = tmp_path_factory.mktemp("sim")
    r = runner.invoke(app, ["simulate", PLANAR, "-o", str(d / "sim.csv"), "--seed", "1", "--duration", "10", "-q"])
    assert r.exit_code == 0, r.output
    r = runner.invoke(app, ["identify", PLANAR, str(d / "sim.csv"), "--no-diagnose", "-q", "--save-model", str(d / "m.json")])
    assert r.exit_code == 0, r.output
    return d


def test_a_columns_key_naming_missing_columns_is_refused(sim):
    r = runner.invoke(app, ["identify", PLANAR, str(sim / "sim.csv"), "--columns", "ddq=acc", "-q"])
    one_line_exit_2(r, "sim.csv: missing columns acc1..acc2")
    t = np.arange(200) * 0.01
    np.savez(sim / "a.npz", t=t, q=np.zeros((200, 2)), tau=np.zeros((200, 2)))
    r = runner.invoke(app, ["identify", PLANAR, str(sim / "a.npz"), "--columns", "dq=vel", "-q"])
    one_line_exit_2(r, "a.npz: no array named by --columns dq=vel")


def test_evaluate_reads_other_column_names_with_columns_and_takes_q(sim):
    text = (sim / "sim.csv").read_text()
    (sim / "renamed.csv").write_text(text.replace("t,q1,q2", "time,pos1,pos2", 1))
    r = runner.invoke(app, ["evaluate", str(sim / "m.json"), str(sim / "renamed.csv"), "-q"])
    one_line_exit_2(r, "missing time column 't' (use --columns t=NAME)")
    same = runner.invoke(app, ["evaluate", str(sim / "m.json"), str(sim / "sim.csv"), "-q", "-f", "json"])
    renamed = runner.invoke(app, ["evaluate", str(sim / "m.json"), str(sim / "renamed.csv"), "--columns", "t=time,q=pos",
                                  "-q", "-f", "json"])
    assert same.exit_code == renamed.exit_code == 0, renamed.output
    assert renamed.stderr == ""
    a, b = json.loads(same.stdout), json.loads(renamed.stdout)
    assert a["files"][0]["rms_total"] == b["files"][0]["rms_total"] and a["files"][0]["samples"] == b["files"][0]["samples"] > 0
    import minparam

    ev = minparam.evaluate(sim / "m.json", sim / "renamed.csv", columns={"t": "time", "q": "pos"})
    assert ev.pooled.rms_total == a["files"][0]["rms_total"]
    r = runner.invoke(app, ["evaluate", str(sim / "m.json"), str(sim / "sim.csv"), "--columns", "x=time"])
    assert r.exit_code == 2 and "--columns" in r.output


@pytest.mark.parametrize("content, needle", [
    ("", "empty file"),
    ("\n\n", "empty file"),
    ("t;q1;q2;tau1;tau2\n0;1;2;3;4\n", "the header has ';' between its names; use comma-separated values"),
    ("t\tq1\tq2\ttau1\ttau2\n0\t1\t2\t3\t4\n", "the header has tabs between its names"),
])
def test_an_empty_or_not_comma_separated_csv_says_what_it_is(tmp_path, content, needle):
    (tmp_path / "d.csv").write_text(content)
    one_line_exit_2(runner.invoke(app, ["identify", PLANAR, str(tmp_path / "d.csv"), "-q"]), needle)


def test_an_interrupted_identify_plot_leaves_no_figure(sim, tmp_path, monkeypatch):
    import minparam_cli.render.identify_plots as plots

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt  # after the residual figures are written, before the last one

    monkeypatch.setattr(plots, "measured_vs_predicted", interrupted)
    figs = tmp_path / "figs"
    r = runner.invoke(app, ["identify", PLANAR, str(sim / "sim.csv"), "-q", "--plot", str(figs)])
    assert r.exit_code == 130 and "interrupted" in r.stderr
    assert list(figs.iterdir()) == [] and sorted(p.name for p in tmp_path.iterdir()) == ["figs"]
    monkeypatch.undo()
    r = runner.invoke(app, ["identify", PLANAR, str(sim / "sim.csv"), "-q", "--plot", str(figs)])
    assert r.exit_code == 0 and "measured_vs_predicted.png" in {p.name for p in figs.iterdir()}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["figs"]


URDF = """<robot name="r">
  <link name="base"/>
  <link name="l1"><inertial><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="j1" type="{kind}"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>
    <limit lower="{lo}" upper="{hi}" effort="10" velocity="1"/></joint>
</robot>
"""


@pytest.mark.parametrize("kind, lo, hi, needle", [
    ("revolute", 1.5, -1.5, "joint[j1]/limit: lower limit 1.5 is above upper limit -1.5"),
    ("prismatic", 0.2, 0.1, "joint[j1]/limit: lower limit 0.2 is above upper limit 0.1"),
    ("revolute", 0.3, 0.3, "lower and upper limit are both 0.3: the revolute joint cannot move"),
    ("revolute", 0, 0, None),  # the specification's defaults: no limits
    ("continuous", 1, -1, None),  # a continuous joint's lower and upper are not used
])
def test_reversed_or_equal_urdf_joint_limits_are_refused_naming_the_joint(tmp_path, kind, lo, hi, needle):
    p = tmp_path / "r.urdf"
    p.write_text(URDF.format(kind=kind, lo=lo, hi=hi))
    r = runner.invoke(app, ["derive", str(p), "-q"])
    if needle is None:
        assert r.exit_code == 0, r.output
    else:
        one_line_exit_2(r, needle)


def test_a_truss_with_two_nodes_at_the_same_place_is_refused(tmp_path):
    text = (ROBOTS / "platforms" / "dodekapod_truss.yaml").read_text()
    p = tmp_path / "t.yaml"
    p.write_text(text.replace("P3: [-68.0, 42.0, 202.0]", "P3: [72.0, 38.0, 198.0]"))
    assert runner.invoke(app, ["platform", "ik", str(ROBOTS / "platforms" / "dodekapod_truss.yaml")]).exit_code == 0
    one_line_exit_2(runner.invoke(app, ["platform", "ik", str(p)]), "nodes 'P2' and 'P3' are at the same place")
