"""minparam excite: the series and its derivatives, the criterion's gradient, limits on a fine grid,
the output read back by simulate and identify, and one test per kind of bad input."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import ARM, ROOT, arm  # the shared two-link arm; the repository root
from typer.testing import CliRunner

from minparam_cli.base.qr import derive_qr
from minparam_cli.chain import build_chain
from minparam_cli.describe import load_description
from minparam_cli.experiment.excite import constraints as cons
from minparam_cli.experiment.excite.criterion import criterion_gradient, criterion_value, sensitivities
from minparam_cli.experiment.excite.design import ExciteOptions, base_regressor, chain_limits, design
from minparam_cli.experiment.simulate import rigid_torque
from minparam_cli.experiment.trajectory import FourierTrajectory, basis, project_to_rest
from minparam_cli.robot import DeriveOptions, load_chain

runner = CliRunner()

LIMITED = ("velocity: 60, acceleration: 100, effort: 40,", "velocity: 90, acceleration: 150, effort: 15,")
FAST = ["--starts", "2", "--max-iterations", "25", "--harmonics", "3", "--rate", "50", "-q"]


@pytest.fixture(scope="module")
def app():
    from minparam_cli.cli.app import app as real_app

    return real_app


def from_json(path) -> FourierTrajectory:
    tr = json.loads(Path(path).read_text())["trajectory"]
    return FourierTrajectory(tr["base_frequency"], np.array(tr["q0"]), np.array(tr["a"]), np.array(tr["b"]))


# --- the series ------------------------------------------------------------------------------------


def test_basis_matches_the_series_and_its_derivatives():
    rng = np.random.default_rng(1)
    traj = FourierTrajectory(0.2, rng.standard_normal(3), rng.standard_normal((3, 4)), rng.standard_normal((3, 4)))
    t = np.linspace(0, 5, 101)
    Bq, Bv, Ba = basis(t, 0.2, 4)
    X = traj.matrix()
    q, dq, ddq = traj.evaluate(t)
    assert np.allclose(Bq @ X.T, q) and np.allclose(Bv @ X.T, dq) and np.allclose(Ba @ X.T, ddq)
    # the derivatives are derivatives: central differences of q and dq
    h = 1e-5
    qp, dqp, _ = traj.evaluate(t + h)
    qm, dqm, _ = traj.evaluate(t - h)
    assert np.allclose((qp - qm) / (2 * h), dq, atol=1e-6) and np.allclose((dqp - dqm) / (2 * h), ddq, atol=1e-5)


def test_rest_projection_puts_every_period_boundary_at_rest():
    rng = np.random.default_rng(2)
    X = project_to_rest(rng.standard_normal((2, 1 + 2 * 5)))
    traj = FourierTrajectory.from_matrix(X, 0.1)
    _, dq, ddq = traj.evaluate(np.array([0.0, 10.0, 20.0]))
    assert np.abs(dq).max() < 1e-12 and np.abs(ddq).max() < 1e-12


# --- the criterion ---------------------------------------------------------------------------------


@pytest.mark.parametrize("kind", ["cond", "logdet"])
@pytest.mark.parametrize("scaled", [True, False])
def test_criterion_gradient_matches_finite_differences(kind, scaled):
    rng = np.random.default_rng(3)
    W = rng.standard_normal((40, 5)) * np.array([1.0, 10.0, 0.1, 3.0, 1.0])
    f, G = criterion_gradient(W, kind, scaled)
    assert f == pytest.approx(criterion_value(W, kind, scaled), rel=1e-10)
    E = rng.standard_normal(W.shape)
    h = 1e-6
    fd = (criterion_value(W + h * E, kind, scaled) - criterion_value(W - h * E, kind, scaled)) / (2 * h)
    assert np.sum(G * E) == pytest.approx(fd, rel=1e-5)


def test_gradient_with_respect_to_the_coefficients(tmp_path):
    """Semi-analytic ∂f/∂X (regressor differences, extras in closed form) against central differences of f."""
    _, chain = load_chain(arm(tmp_path), DeriveOptions(friction=("viscous",), rotor_inertia=True))
    kept = derive_qr(chain).kept
    rng = np.random.default_rng(4)
    X = rng.standard_normal((2, 7)) * 0.5
    Bq, Bv, Ba = basis(np.linspace(0, 10, 64, endpoint=False), 0.1, 3)

    def f(X):
        return criterion_value(base_regressor(chain, kept, Bq @ X.T, Bv @ X.T, Ba @ X.T), "cond")

    s = sensitivities(chain, kept, Bq @ X.T, Bv @ X.T, Ba @ X.T, "cond", phi=chain.phi_nominal)
    grad = s.dq.T @ Bq + s.ddq_v.T @ Bv + s.ddq_a.T @ Ba
    E = rng.standard_normal(X.shape)
    h = 1e-6
    fd = (f(X + h * E) - f(X - h * E)) / (2 * h)
    assert np.sum(grad * E) == pytest.approx(fd, rel=1e-4)
    # the torque derivatives: τ along the same direction
    def tau(X):
        return rigid_torque(chain, Bq @ X.T, Bv @ X.T, Ba @ X.T, chain.phi_nominal)
    J = cons.state_jacobian(s.tau_q, s.tau_v, s.tau_a, Bq, Bv, Ba)
    fd_tau = (tau(X + h * E) - tau(X - h * E)) / (2 * h)
    assert np.allclose(J @ E.ravel(), fd_tau.ravel(), rtol=1e-4, atol=1e-6 * np.abs(fd_tau).max())


# --- the command -----------------------------------------------------------------------------------


def test_every_limit_holds_on_a_fine_grid_and_the_csv_matches_the_json(tmp_path, app):
    path = arm(tmp_path, *LIMITED)
    out, js = tmp_path / "t.csv", tmp_path / "t.json"
    r = runner.invoke(app, ["excite", path, "-o", str(out), "--json", str(js), "--plot", str(tmp_path / "t.png"), *FAST])
    assert r.exit_code == 0, r.output
    chain = build_chain(load_description(path))
    traj = from_json(js)
    t = np.linspace(0.0, 1.0 / traj.base_frequency, 200_001)
    q, dq, ddq = traj.evaluate(t)
    lo, hi = np.radians([-90, -120]), np.radians([90, 120])
    assert np.all(q >= lo) and np.all(q <= hi)
    assert np.all(np.abs(dq).max(axis=0) <= np.radians([60, 90]))
    assert np.all(np.abs(ddq).max(axis=0) <= np.radians([100, 150]))
    tau = rigid_torque(chain, q[::20], dq[::20], ddq[::20], chain.phi_nominal)
    assert np.all(np.abs(tau).max(axis=0) <= [40, 15])
    table = np.loadtxt(out, delimiter=",", skiprows=1)
    header = out.read_text().splitlines()[0].split(",")
    assert header == ["t", "q1", "q2", "dq1", "dq2", "ddq1", "ddq2"]
    q_csv, dq_csv, ddq_csv = traj.evaluate(table[:, 0])
    assert np.allclose(table[:, 1:3], q_csv) and np.allclose(table[:, 3:5], dq_csv) and np.allclose(table[:, 5:7], ddq_csv)
    record = json.loads(js.read_text())
    assert record["seed"] == 0 and record["starts"][record["best_start"] - 1]["end"] <= record["starts"][0]["start"]
    assert (tmp_path / "t.png").stat().st_size > 0


def test_the_plot_draws_each_joints_designed_q_between_its_limits(tmp_path):
    """excite --plot's figure (render/excite_plot.py) on the limited arm, from a short design: one axis per
    joint labelled with its unit, its curve the designed q in degrees, the file's limits as lines and the
    margin's lines inside them."""
    import minparam
    from minparam_cli.render.excite_plot import render_trajectory

    r = minparam.excite(arm(tmp_path, *LIMITED), harmonics=3, rate=50, starts=1, max_iterations=10)
    axes = render_trajectory(r.design, ("revolute", "revolute")).get_axes()
    assert [ax.get_ylabel() for ax in axes] == ["q1 (deg)", "q2 (deg)"] and axes[-1].get_xlabel() == "t (s)"
    for j, (ax, (lo, hi)) in enumerate(zip(axes, [(-90, 90), (-120, 120)], strict=True)):
        curve, *lines = ax.get_lines()
        np.testing.assert_allclose(curve.get_xdata(), r.t)
        np.testing.assert_allclose(curve.get_ydata(), np.degrees(r.q[:, j]))
        levels = [float(line.get_ydata()[0]) for line in lines]
        assert levels[:2] == pytest.approx([lo, hi])
        assert lo < levels[2] < levels[3] < hi  # the margin the design keeps free


def test_torque_limits_that_bind_are_kept(tmp_path, app):
    """An effort limit below what the free design would use: the output still meets it on a fine grid."""
    path = arm(tmp_path, "effort: 22,", "effort: 6,")
    js = tmp_path / "t.json"
    r = runner.invoke(app, ["excite", path, "-o", str(tmp_path / "t.csv"), "--json", str(js), *FAST])
    assert r.exit_code == 0, r.output
    chain = build_chain(load_description(path))
    traj = from_json(js)
    q, dq, ddq = traj.evaluate(np.linspace(0.0, 1.0 / traj.base_frequency, 20_001))
    tau = np.abs(rigid_torque(chain, q, dq, ddq, chain.phi_nominal)).max(axis=0)
    assert np.all(tau <= [22, 6]) and tau[1] > 0.8 * 6  # it binds


def test_cartesian_box_holds_on_a_fine_grid(tmp_path, app):
    path = arm(tmp_path)
    js = tmp_path / "t.json"
    r = runner.invoke(app, ["excite", path, "-o", str(tmp_path / "t.csv"), "--json", str(js), "--box", ":,-0.5:,:", *FAST])
    assert r.exit_code == 0, r.output
    chain = build_chain(load_description(path))
    traj = from_json(js)
    q, _, _ = traj.evaluate(np.linspace(0.0, 1.0 / traj.base_frequency, 20_001))
    assert cons.box_point(chain, q, np.zeros(3))[:, 1].min() >= -0.5
    best = json.loads(js.read_text())["starts"][json.loads(js.read_text())["best_start"] - 1]
    assert best["end"] < 0.5 * best["start"]  # the optimiser moved (an end just outside the box once fell back to the start)


def test_rest_starts_and_ends_at_rest(tmp_path, app):
    out = tmp_path / "t.csv"
    r = runner.invoke(app, ["excite", arm(tmp_path), "-o", str(out), "--rest", *FAST])
    assert r.exit_code == 0, r.output
    table = np.loadtxt(out, delimiter=",", skiprows=1)
    assert table[0, 0] == 0.0 and table[-1, 0] == pytest.approx(10.0)
    assert np.abs(table[[0, -1], 3:7]).max() < 1e-9


def test_design_lowers_the_condition_number_of_simulates_random_series(tmp_path):
    """The start is simulate's own random draw; the design ends well below it, measured on the output
    samples rather than the optimiser's grid (PUMA 560, no inertia needed)."""
    _, chain = load_chain("robots/puma560.yaml", DeriveOptions())
    res = design(chain, derive_qr(chain), ExciteOptions(starts=1, max_iterations=40, harmonics=4, rate=20),
                 chain_limits(chain, 0.1), np.random.default_rng(0))
    assert res.cond_output_si < 0.5 * res.starts[0].start_criterion  # the default criterion: κ in SI units


# --- simulate -> identify ---------------------------------------------------------------------------


def _sigmas(app, robot, data, tmp_path):
    r = runner.invoke(app, ["identify", robot, str(data), "--no-diagnose", "--format", "json", "-q"])
    assert r.exit_code == 0, r.output
    params = json.loads(r.stdout)["parameters"]
    return {k: abs(v["value"]) * v["std_percent"] / 100 for k, v in params.items()}


def test_identify_on_an_excite_trajectory_has_smaller_sigma_than_on_a_random_one(tmp_path, app):
    robot = arm(tmp_path)
    js, csv = tmp_path / "x.json", tmp_path / "x.csv"
    r = runner.invoke(app, ["excite", robot, "-o", str(csv), "--json", str(js), "--starts", "2", "--max-iterations", "40",
                            "--harmonics", "3", "--rate", "50", "-q"])
    assert r.exit_code == 0, r.output
    common = ["--noise", "0.2", "--seed", "5", "--rate", "50", "--duration", "40", "--harmonics", "3", "-q"]
    for name, extra in (("ex.csv", ["--trajectory", str(js)]), ("rnd.csv", [])):
        r = runner.invoke(app, ["simulate", robot, *extra, *common, "-o", str(tmp_path / name)])
        assert r.exit_code == 0, r.output
    ex, rnd = _sigmas(app, robot, tmp_path / "ex.csv", tmp_path), _sigmas(app, robot, tmp_path / "rnd.csv", tmp_path)
    keys = sorted(set(ex) & set(rnd))
    assert len(keys) >= 3
    assert np.exp(np.mean(np.log([ex[k] for k in keys]))) < np.exp(np.mean(np.log([rnd[k] for k in keys])))
    assert max(ex[k] for k in keys) < max(rnd[k] for k in keys)


def test_simulate_reads_the_csv_samples_as_they_are(tmp_path, app):
    robot = arm(tmp_path)
    csv = tmp_path / "x.csv"
    assert runner.invoke(app, ["excite", robot, "-o", str(csv), *FAST]).exit_code == 0
    out = tmp_path / "sim.csv"
    r = runner.invoke(app, ["simulate", robot, "--trajectory", str(csv), "-o", str(out), "-q"])
    assert r.exit_code == 0, r.output
    a, b = np.loadtxt(csv, delimiter=",", skiprows=1), np.loadtxt(out, delimiter=",", skiprows=1)
    assert np.array_equal(a, b[:, :7])


# --- bad input: one line, exit 2 -------------------------------------------------------------------


def _one_line_exit_2(r, needle):
    lines = [ln for ln in r.output.splitlines() if ln.strip()]
    assert r.exit_code == 2 and len(lines) == 1 and needle in lines[0] and "Traceback" not in r.output, r.output


def test_zero_harmonics(tmp_path, app):
    _one_line_exit_2(runner.invoke(app, ["excite", arm(tmp_path), "--harmonics", "0"]), "--harmonics must be at least 1")


def test_rest_with_one_harmonic(tmp_path, app):
    _one_line_exit_2(runner.invoke(app, ["excite", arm(tmp_path), "--harmonics", "1", "--rest"]), "--rest needs at least 2 harmonics")


def test_infeasible_effort_limit(tmp_path, app):
    _one_line_exit_2(runner.invoke(app, ["excite", arm(tmp_path, "effort: 1,")]), "infeasible limits: standing still, joint 1")


def test_empty_box(tmp_path, app):
    _one_line_exit_2(runner.invoke(app, ["excite", arm(tmp_path), "--box", "1:0,:,:"]), "infeasible limits: --box axis x is empty")


def test_harmonic_above_nyquist(tmp_path, app):
    _one_line_exit_2(runner.invoke(app, ["excite", arm(tmp_path), "--rate", "1"]), "must be below half the --rate")


def test_trajectory_file_for_another_robot(tmp_path, app):
    js = tmp_path / "x.json"
    js.write_text(json.dumps({"trajectory": {"base_frequency": 0.1, "q0": [0, 0, 0], "a": [[1], [1], [1]], "b": [[0], [0], [0]]}}))
    _one_line_exit_2(runner.invoke(app, ["simulate", arm(tmp_path), "--trajectory", str(js)]), "must have shapes")


def test_missing_position_limits_use_simulates_defaults_with_a_note(tmp_path, app):
    robot = tmp_path / "free.yaml"
    robot.write_text(ARM.format(j1="", j2="").replace(" limits: [-90, 90],", "").replace(" limits: [-120, 120],", ""))
    js = tmp_path / "x.json"
    r = runner.invoke(app, ["excite", str(robot), "-o", str(tmp_path / "x.csv"), "--json", str(js), *FAST[:-1]])
    assert r.exit_code == 0 and "gives no position limits for joint(s) 1, 2; using ±90°" in r.output
    q, _, _ = from_json(js).evaluate(np.linspace(0, 10, 20_001))
    assert np.abs(q).max() <= np.pi / 2


def test_box_the_point_never_enters(tmp_path, app):
    _one_line_exit_2(runner.invoke(app, ["excite", arm(tmp_path), "--box", "5:,:,:", "-q"]), "the --box point lies outside the box")


def test_trajectory_csv_without_the_joint_columns(tmp_path, app):
    bad = tmp_path / "x.csv"
    bad.write_text("t,q1,dq1,ddq1\n0,0,0,0\n0.1,0,0,0\n")
    _one_line_exit_2(runner.invoke(app, ["simulate", arm(tmp_path), "--trajectory", str(bad)]), "missing column(s) q2")


def test_urdf_velocity_and_effort_limits_hold_on_a_fine_grid(tmp_path, app):
    """UR5 URDF: <limit velocity effort> read, enforced, and met at every one of 100 001 instants."""
    js = tmp_path / "u.json"
    r = runner.invoke(app, ["excite", "robots/ur5.urdf", "-o", str(tmp_path / "u.csv"), "--json", str(js),
                            "--starts", "1", "--max-iterations", "15", "--harmonics", "3", "--rate", "20", "-q"])
    assert r.exit_code == 0, r.output
    chain = build_chain(load_description("robots/ur5.urdf"))
    record = json.loads(js.read_text())
    traj = from_json(js)
    q, dq, ddq = traj.evaluate(np.linspace(0.0, 1.0 / traj.base_frequency, 100_001))
    vel = np.array(chain.velocity_limits, dtype=float)
    assert np.all(np.abs(dq).max(axis=0) <= vel)
    assert max(u["max_abs_dq"] / u["velocity_limit"] for u in record["limits"]["joints"]) > 0.85  # they bind
    lo, hi = np.array([lim[0] for lim in chain.limits]), np.array([lim[1] for lim in chain.limits])
    assert np.all(q >= lo) and np.all(q <= hi)
    tau = rigid_torque(chain, q[::50], dq[::50], ddq[::50], chain.phi_nominal)
    assert np.all(np.abs(tau).max(axis=0) <= np.array(chain.effort_limits, dtype=float))


def test_logdet_criterion_improves_on_its_start(tmp_path, app):
    js = tmp_path / "d.json"
    r = runner.invoke(app, ["excite", arm(tmp_path), "-o", str(tmp_path / "d.csv"), "--json", str(js), "--criterion", "logdet", *FAST])
    assert r.exit_code == 0, r.output
    record = json.loads(js.read_text())
    assert record["criterion"]["name"] == "logdet"
    assert all(s["end"] < s["start"] for s in record["starts"])


# --- --floor: link origins above a table or floor (issue 32) ----------------------------------------


def _ur5_heights_on_a_fine_grid(js: Path) -> np.ndarray:
    """Lowest height of every link origin and the tool point of robots/ur5.urdf along the designed motion."""
    _, chain = load_chain(ROOT / "robots" / "ur5.urdf", DeriveOptions())
    traj = from_json(js)
    q, _, _ = traj.evaluate(np.linspace(0.0, 1.0 / traj.base_frequency, 4001))
    return cons.heights(chain, q).min(axis=0)


def test_floor_keeps_every_link_origin_above_it(tmp_path, app):
    """Without --floor the UR5's design takes link origins below its own mounting plane (the issue: q2 near
    150°); with --floor 0.05 every link origin and the tool point stay 5 cm above it on a grid finer than the
    optimiser's, checked again by MuJoCo's forward kinematics of the same robot written as MJCF."""
    free, floor = tmp_path / "free.json", tmp_path / "floor.json"
    ur5 = str(ROOT / "robots" / "ur5.urdf")
    r = runner.invoke(app, ["excite", ur5, "-o", str(tmp_path / "a.csv"), "--json", str(free), *FAST])
    assert r.exit_code == 0, r.output
    assert _ur5_heights_on_a_fine_grid(free).min() < 0.0
    r = runner.invoke(app, ["excite", ur5, "-o", str(tmp_path / "b.csv"), "--json", str(floor), "--floor", "0.05", *FAST])
    assert r.exit_code == 0, r.output
    assert _ur5_heights_on_a_fine_grid(floor).min() >= 0.05 - 1e-6
    record = json.loads(floor.read_text())["limits"]
    assert record["floor"] == 0.05 and min(record["lowest_heights"]) >= 0.05 - 1e-9
    mujoco = pytest.importorskip("mujoco")
    model = mujoco.MjModel.from_xml_path(str(ROOT / "robots" / "ur5.xml"))
    data = mujoco.MjData(model)
    traj = from_json(floor)
    q, _, _ = traj.evaluate(np.linspace(0.0, 1.0 / traj.base_frequency, 401))
    lowest = np.inf
    for qs in q:
        data.qpos[:] = qs
        mujoco.mj_kinematics(model, data)
        moving = [b for b in range(1, model.nbody) if model.body_dofnum[b] > 0]
        lowest = min(lowest, float(data.xpos[moving, 2].min()))
    assert lowest >= 0.05 - 1e-6


def test_a_floor_no_design_can_meet_is_one_line(tmp_path, app):
    r = runner.invoke(app, ["excite", str(ROOT / "robots" / "ur5.urdf"), "-o", str(tmp_path / "a.csv"), "--floor", "2", *FAST])
    assert r.exit_code == 2 and "infeasible limits: --floor 2 m" in r.output and len(r.output.strip().splitlines()) == 1
    assert not (tmp_path / "a.csv").exists()


@pytest.mark.parametrize("floor", ["nan", "inf", "abc"])
def test_a_floor_that_is_not_a_finite_height_is_one_line(tmp_path, app, floor):
    """The command line refuses it (one line, exit 2) and so does the options record behind minparam.excite."""
    from minparam_cli.api.options.excite import ExciteOptions
    from minparam_cli.errors import InputError

    r = runner.invoke(app, ["excite", str(ROOT / "robots" / "ur5.urdf"), "-o", str(tmp_path / "a.csv"), "--floor", floor, *FAST])
    assert r.exit_code == 2 and "--floor" in r.output and len(r.output.strip().splitlines()) == 1
    assert not (tmp_path / "a.csv").exists()
    value = floor if floor == "abc" else float(floor)
    with pytest.raises(InputError, match="--floor: expected a"):
        ExciteOptions(floor=value)


@pytest.mark.parametrize("end", ["lower", "upper"])
def test_a_mean_position_a_rounding_past_the_range_end_counts_as_on_it(end):
    """SLSQP's bounds hold to rounding: the Stanford arm's seed-0 design put joint 3's mean 1e-17 m below
    its shrunk range, and the repair refused it ("mean position 0.40132 outside the range [0.40132, …]")."""
    nan = np.full(2, np.nan)
    limits = cons.Limits(np.array([-1.0, 0.3048]), np.array([1.0, 1.27]), nan, nan, nan, margin=0.1)
    lo, hi = limits.shrunk_range()
    edge = lo[1] if end == "lower" else hi[1]
    past = np.nextafter(np.nextafter(edge, -np.inf if end == "lower" else np.inf), -np.inf if end == "lower" else np.inf)
    a = np.array([[0.2, 0.0], [0.01, 0.0]])  # joint 2 moves both ways about its mean
    traj = FourierTrajectory(0.1, np.array([0.0, past]), a, np.zeros_like(a))
    s = cons.rigorous_scale(traj, limits)
    assert s[1] == 0.0 and 0.0 < s[0] <= 1.0  # it stays on the end; the other joint keeps its motion
    far = FourierTrajectory(0.1, np.array([0.0, edge + (-1e-6 if end == "lower" else 1e-6)]), a, np.zeros_like(a))
    with pytest.raises(Exception, match="mean position .* outside the range"):
        cons.rigorous_scale(far, limits)


def test_a_joint_the_repair_leaves_still_is_named_in_a_note():
    from types import SimpleNamespace

    from minparam_cli.api.excitation import after_notes

    inf = np.full(3, np.inf)
    limits = cons.Limits(-np.ones(3), np.ones(3), np.array([1.0, np.nan, np.nan]), inf, inf, margin=0.1)
    prep = SimpleNamespace(robot="arm.yaml", limits=limits)
    moving = SimpleNamespace(design=SimpleNamespace(repair_scale=(1.0, 0.5, 0.98)))
    still = SimpleNamespace(design=SimpleNamespace(repair_scale=(1.0, 0.0, 0.98)))
    assert after_notes(prep, moving) == []  # type: ignore[arg-type]
    (note,) = after_notes(prep, still)  # type: ignore[arg-type]
    assert note.startswith("joint(s) 2 do not move in this design")
