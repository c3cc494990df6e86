"""Velocity, acceleration and effort limits: read from YAML and URDF; simulate keeps |q̇| and |q̈|
within them at every instant (checked on a grid far finer than the one the trajectory is built on),
and checks (reports) effort."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from conftest import arm  # the shared two-link arm
from typer.testing import CliRunner

from minparam_cli.chain import build_chain
from minparam_cli.describe import load_description
from minparam_cli.errors import DescriptionError
from minparam_cli.experiment.trajectory import LIMIT_MARGIN, fourier_excitation

runner = CliRunner()


@pytest.fixture(scope="module")
def app():
    from minparam_cli.cli.app import app as real_app

    return real_app


def fine(traj, per_period: int = 200_000):
    t = np.linspace(0.0, 1.0 / traj.base_frequency, per_period, endpoint=False)
    return traj.evaluate(t)


# --- reading ---------------------------------------------------------------------------------------


def test_yaml_limits_are_read_in_the_files_units(tmp_path):
    c = build_chain(load_description(arm(tmp_path, "velocity: 90, acceleration: 180, effort: 40,", "effort: 12.5,")))
    assert c.velocity_limits == pytest.approx((math.pi / 2, None))
    assert c.acceleration_limits == pytest.approx((math.pi, None))
    assert c.effort_limits == (40.0, 12.5)


def test_yaml_prismatic_speed_limits_use_the_length_unit(tmp_path):
    p = tmp_path / "p.yaml"
    p.write_text("name: p\nconvention: dh\nunits: {length: mm, angle: deg}\njoints:\n"
                 "  - {type: prismatic, alpha: 0, a: 0, d: 0, theta: 0, velocity: 250, acceleration: 1000, effort: 80}\n")
    c = build_chain(load_description(str(p)))
    assert c.velocity_limits == pytest.approx((0.25,)) and c.acceleration_limits == pytest.approx((1.0,))
    assert c.effort_limits == (80.0,)


@pytest.mark.parametrize(("item", "needle"), [("velocity: 0,", "joints[1].velocity: expected a positive limit"),
                                              ("acceleration: -5,", "joints[1].acceleration: expected a positive limit"),
                                              ("effort: fast,", "joints[1].effort")])
def test_bad_yaml_limits_are_refused(tmp_path, app, item, needle):
    path = arm(tmp_path, item)
    with pytest.raises(DescriptionError, match=needle.replace("[", r"\[").replace("]", r"\]")):
        load_description(path)
    r = runner.invoke(app, ["check", path])
    assert r.exit_code == 2 and needle in r.output and "Traceback" not in r.output


def test_urdf_velocity_and_effort_are_read_zero_means_none(tmp_path):
    c = build_chain(load_description("robots/ur5.urdf"))
    assert c.velocity_limits == (3.15, 3.15, 3.15, 3.2, 3.2, 3.2)
    assert c.effort_limits == (150.0, 150.0, 150.0, 28.0, 28.0, 28.0)
    assert c.acceleration_limits == (None,) * 6  # URDF has no acceleration limit
    text = (
        '<robot name="r"><link name="b"/><link name="l"><inertial><mass value="1"/><origin xyz="0 0 0"/>'
        '<inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>'
        '<joint name="j" type="revolute"><parent link="b"/><child link="l"/><axis xyz="0 0 1"/>'
        '<limit lower="-1" upper="1" velocity="0" effort="7"/></joint></robot>'
    )
    (tmp_path / "r.urdf").write_text(text)
    c = build_chain(load_description(str(tmp_path / "r.urdf")))
    assert c.velocity_limits == (None,) and c.effort_limits == (7.0,)


# --- the trajectory --------------------------------------------------------------------------------


@pytest.mark.parametrize("seed", range(5))
def test_velocity_and_acceleration_stay_within_limits_on_a_fine_grid(seed):
    ranges = [(-1.5, 1.5), (-2.0, 2.0), (-0.3, 0.3)]
    vmax, amax = [0.4, None, 0.05], [None, 0.6, 0.02]
    free = fourier_excitation(ranges, 5, 0.1, np.random.default_rng(seed))
    q_f, dq_f, ddq_f = fine(free)
    # the limits bite: without them the motion would break them
    assert np.abs(dq_f[:, 0]).max() > vmax[0] and np.abs(ddq_f[:, 1]).max() > amax[1]
    traj = fourier_excitation(ranges, 5, 0.1, np.random.default_rng(seed), max_velocity=vmax, max_acceleration=amax)
    q, dq, ddq = fine(traj)
    keep = 1.0 - LIMIT_MARGIN
    assert np.abs(dq[:, 0]).max() <= keep * vmax[0]
    assert np.abs(ddq[:, 1]).max() <= keep * amax[1]
    assert np.abs(dq[:, 2]).max() <= keep * vmax[2] and np.abs(ddq[:, 2]).max() <= keep * amax[2]
    for j, (lo, hi) in enumerate(ranges):
        assert lo < q[:, j].min() and q[:, j].max() < hi
    # the slowing is not needlessly strong: the bound is reached to within a few per cent
    assert np.abs(dq[:, 0]).max() > 0.9 * keep * vmax[0]


def test_no_limits_leave_the_trajectory_unchanged():
    ranges = [(-1.0, 1.0), (-2.0, 2.0)]
    a = fourier_excitation(ranges, 4, 0.2, np.random.default_rng(7))
    b = fourier_excitation(ranges, 4, 0.2, np.random.default_rng(7), max_velocity=[None, 100.0], max_acceleration=None)
    assert np.array_equal(a.a, b.a) and np.array_equal(a.b, b.b) and np.array_equal(a.q0, b.q0)


# --- simulate --------------------------------------------------------------------------------------


def test_simulate_keeps_every_sample_within_the_files_limits(app, tmp_path):
    robot = arm(tmp_path, "velocity: 20, acceleration: 15,", "velocity: 30,")
    out, truth = tmp_path / "d.npz", tmp_path / "t.json"
    r = runner.invoke(app, ["simulate", robot, "--duration", "20", "--rate", "1000", "-o", str(out), "--truth", str(truth)])
    assert r.exit_code == 0, r.output
    d = np.load(out)
    vmax = np.radians([20.0, 30.0])
    assert np.all(np.abs(d["dq"]) <= vmax)
    assert np.all(np.abs(d["ddq"][:, 0]) <= math.radians(15.0))
    assert np.all(np.abs(d["q"]) <= np.radians([90.0, 120.0]))
    lim = json.loads(truth.read_text())["limits"]
    assert lim["velocity"] == pytest.approx(list(vmax)) and lim["acceleration"][1] is None
    assert "limits     max |dq|/limit" in r.stderr


def test_simulate_reports_effort_beyond_the_limit(app, tmp_path):
    robot = arm(tmp_path, "effort: 1,")
    truth = tmp_path / "t.json"
    r = runner.invoke(app, ["simulate", robot, "--duration", "5", "-o", str(tmp_path / "d.csv"), "--truth", str(truth), "-q"])
    assert r.exit_code == 0, r.output
    warn = [ln for ln in r.stderr.splitlines() if ln.startswith("minparam: warning: joint 1:")]
    assert len(warn) == 1 and "exceeds its effort limit 1" in warn[0]
    lim = json.loads(truth.read_text())["limits"]
    assert lim["over_effort"] == [1] and lim["max_abs_tau"][0] > 1.0
