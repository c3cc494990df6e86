"""``minparam simulate``: trajectory, torques, random inertia, files, and every bad input."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import cli

from minparam_cli.chain import build_chain
from minparam_cli.describe import load_description
from minparam_cli.dynamics.regressor import regressor
from minparam_cli.errors import InputError
from minparam_cli.dynamics.effects import COGGING_GRID, EFFECT_IDS, EFFECTS, STRIBECK_GRID, Signals
from minparam_cli.dynamics.inertia import pseudo_inertia_from_standard, random_inertia, standard_from_com
from minparam_cli.experiment.simulate import simulate
from minparam_cli.experiment.simulate_spec import SimulationOptions, data_columns, parse_effects
from minparam_cli.experiment.trajectory import LIMIT_MARGIN, excursion_bounds, fourier_excitation, joint_ranges
from minparam_cli.params import standard_names

ROBOTS = Path(__file__).resolve().parents[1] / "robots"
PUMA = str(ROBOTS / "puma560_mdh.yaml")
PLANAR = str(ROBOTS / "planar2r.yaml")
PANDA = str(ROBOTS / "panda.yaml")
EVERY_EFFECT = (
    "coulomb,viscous,offset@1,rotor_inertia@2,stribeck@1:vs=0.05,asymmetric_coulomb@2,spring@2,"
    "cogging@1:k=12,load_coulomb@1,gain@2:g=0.03,drift@1:amp=0.2"
)


def chain_of(path):
    return build_chain(load_description(path))


def short(*extra):
    """Short records keep the tests fast: 4 s at 100 Hz, one base period of 0.25 Hz."""
    return ["--duration", "4", "--rate", "100", "--base-frequency", "0.25", "--harmonics", "4", *extra]


# --- trajectory --------------------------------------------------------------------------------------


@pytest.mark.parametrize("path", [PUMA, PLANAR, PANDA], ids=["puma560_mdh", "planar2r", "panda"])
def test_trajectory_stays_inside_the_limits_with_the_margin(path):
    chain = chain_of(path)
    ranges = np.array(joint_ranges(chain.types, chain.limits))
    for seed in range(5):
        traj = fourier_excitation(ranges, 5, 0.1, np.random.default_rng(seed))
        t = np.linspace(0.0, 10.0, 20001)  # one full period, far finer than any written rate
        q, _, _ = traj.evaluate(t)
        width = ranges[:, 1] - ranges[:, 0]
        inner_lo = ranges[:, 0] + LIMIT_MARGIN * width
        inner_hi = ranges[:, 1] - LIMIT_MARGIN * width
        assert np.all(q >= inner_lo - 1e-12 * width) and np.all(q <= inner_hi + 1e-12 * width)
        # the bound is tight: the motion uses most of the allowed band on every joint
        assert np.all(np.ptp(q, axis=0) > 0.9 * (inner_hi - inner_lo))


def test_default_ranges_when_the_file_has_no_limits():
    chain = chain_of(PLANAR)
    assert chain.limits == (None, None)
    assert joint_ranges(chain.types, chain.limits) == ((-np.pi / 2, np.pi / 2),) * 2
    assert joint_ranges(("prismatic",), (None,)) == ((-0.1, 0.1),)


def test_excursion_bound_encloses_the_motion():
    traj = fourier_excitation([(-1.0, 2.0)] * 3, 6, 0.2, np.random.default_rng(7), margin=0.0)
    lo, hi = excursion_bounds(traj)
    q, _, _ = traj.evaluate(np.linspace(0, 5, 50001))
    x = q - traj.q0
    assert np.all(x.min(axis=0) >= lo) and np.all(x.max(axis=0) <= hi)


def test_velocity_and_acceleration_are_the_exact_derivatives():
    traj = fourier_excitation([(-2.0, 1.0), (0.0, 3.0), (-0.1, 0.1)], 5, 0.1, np.random.default_rng(3))
    t = np.linspace(0.0, 20.0, 401)
    h = 1e-4
    q, dq, ddq = traj.evaluate(t)
    qp, dqp, _ = traj.evaluate(t + h)
    qm, dqm, _ = traj.evaluate(t - h)
    # central differences: error O(h²·max|d³q/dt³|), about 1e-8 of the signal here
    np.testing.assert_allclose(dq, (qp - qm) / (2 * h), rtol=0, atol=1e-6 * np.abs(dq).max())
    np.testing.assert_allclose(ddq, (dqp - dqm) / (2 * h), rtol=0, atol=1e-6 * np.abs(ddq).max())
    np.testing.assert_allclose(ddq, (qp - 2 * q + qm) / h**2, rtol=0, atol=1e-4 * np.abs(ddq).max())


# --- torques -----------------------------------------------------------------------------------------


def effect_torque(effect_id: str, s: Signals, joint: int, coefficients, hyper: float | None = None) -> np.ndarray:
    """Torque (N,) that ``effect_id`` with these coefficients adds on ``joint``: its columns times them."""
    cols = EFFECTS[effect_id].columns(s, joint, hyper)
    return cols @ np.asarray(coefficients, dtype=float).reshape(-1)


def independent_torque(chain, data, truth):
    """Regressor·φ plus every effect of the truth record, recomputed from the written data."""
    phi = np.array(truth["phi"])
    q, dq, ddq, t = data["q"], data["dq"], data["ddq"], data["t"]
    rigid = regressor(chain, q, dq, ddq, include_extras=False) @ phi
    s = Signals(t=t, q=q, dq=dq, ddq=ddq, tau_model=rigid)
    tau = rigid.copy()
    for e in truth["effects"]:
        for joint, coeffs in e["coefficients"].items():
            j = int(joint) - 1
            tau[:, j] += effect_torque(e["effect"], s, j, coeffs, e["hyper"])
    return rigid, tau


@pytest.mark.parametrize("path", [PLANAR, PUMA], ids=["planar2r", "puma560_mdh"])
def test_torque_is_regressor_times_phi_plus_effects(tmp_path, path):
    out, truth = tmp_path / "d.npz", tmp_path / "t.json"
    effects = EVERY_EFFECT if path == PLANAR else "coulomb,viscous,spring@2,cogging@3:k=12,gain:g=0.05"
    r = cli("simulate", path, *short("--effects", effects, "-o", str(out), "--truth", str(truth), "--quiet"))
    assert r.exit_code == 0, r.output
    data = dict(np.load(out))
    rec = json.loads(truth.read_text())
    chain = chain_of(path)
    np.testing.assert_array_equal(rec["phi"], chain.phi_nominal)
    rigid, expected = independent_torque(chain, data, rec)
    scale = np.abs(expected).max()
    np.testing.assert_allclose(data["tau"], expected, rtol=0, atol=1e-12 * scale)
    assert np.abs(data["tau"] - rigid).max() > 1e-3 * scale  # the effects are really there


def test_noise_is_the_only_difference_and_has_the_requested_size():
    chain = chain_of(PLANAR)
    specs = parse_effects("coulomb,viscous", chain.n)
    clean = simulate(chain, SimulationOptions(effects=specs), np.random.default_rng(4))
    noisy = simulate(chain, SimulationOptions(effects=specs, noise=0.2), np.random.default_rng(4))
    np.testing.assert_array_equal(clean.q, noisy.q)
    assert clean.effects == noisy.effects
    residual = noisy.tau - clean.tau
    # 8000 draws: the sample std is within 5% of 0.2 with overwhelming probability
    assert residual.std() == pytest.approx(0.2, rel=0.05)
    assert abs(residual.mean()) < 0.02


def test_position_noise_leaves_torques_and_rates_exact():
    chain = chain_of(PLANAR)
    clean = simulate(chain, SimulationOptions(duration=4, rate=100), np.random.default_rng(1))
    noisy = simulate(chain, SimulationOptions(duration=4, rate=100, noise_q=0.01), np.random.default_rng(1))
    np.testing.assert_array_equal(clean.tau, noisy.tau)
    np.testing.assert_array_equal(clean.dq, noisy.dq)
    assert (noisy.q - noisy.q_true).std() == pytest.approx(0.01, rel=0.1)


def test_default_amplitude_is_strength_times_rigid_rms():
    chain = chain_of(PUMA)
    specs = parse_effects("coulomb,spring@2,cogging@3,offset@1:amp=0.7", chain.n)
    sim = simulate(chain, SimulationOptions(duration=4, rate=100, effects=specs, strength=0.2), np.random.default_rng(2))
    rms_rigid = np.sqrt(np.mean(sim.tau_rigid**2, axis=0))
    coulomb, spring, cogging, offset = sim.effects
    np.testing.assert_allclose(coulomb.rms, 0.2 * rms_rigid, rtol=1e-12)
    assert spring.rms[0] == pytest.approx(0.2 * rms_rigid[1], rel=1e-12)
    assert cogging.hyper == 12.0 and cogging.rms[0] == pytest.approx(0.2 * rms_rigid[2], rel=1e-12)
    assert offset.rms[0] == pytest.approx(0.7, rel=1e-12)
    assert all(c[0] > 0 for c in coulomb.coefficients)  # friction opposes the motion


def test_gain_adds_g_times_the_rigid_torque():
    chain = chain_of(PLANAR)
    base = simulate(chain, SimulationOptions(duration=2, rate=100), np.random.default_rng(0))
    g = simulate(chain, SimulationOptions(duration=2, rate=100, effects=parse_effects("gain@2:g=-0.04", 2)),
                 np.random.default_rng(0))
    np.testing.assert_allclose(g.tau[:, 1], 0.96 * base.tau[:, 1], rtol=1e-13)
    np.testing.assert_array_equal(g.tau[:, 0], base.tau[:, 0])
    assert g.effects[0].coefficients == ((-0.04,),)


def test_effect_spec_parsing():
    specs = parse_effects("coulomb, spring@2, cogging@1+3:k=20:amp=0.5, stribeck@2-3", 3)
    assert [s.effect for s in specs] == ["coulomb", "spring", "cogging", "stribeck"]
    assert specs[0].joints == (0, 1, 2) and specs[1].joints == (1,)
    assert specs[2].joints == (0, 2) and specs[2].hyper == 20.0 and specs[2].amplitude == 0.5
    assert specs[3].joints == (1, 2) and specs[3].hyper == 0.05
    assert 0.05 in STRIBECK_GRID and 12.0 in COGGING_GRID
    assert parse_effects("", 3) == ()
    assert set(EFFECT_IDS) == {"coulomb", "viscous", "offset", "rotor_inertia", "stribeck", "asymmetric_coulomb",
                               "spring", "gravity_error", "cogging", "position_error", "load_coulomb", "gain", "drift",
                               "motor_coulomb", "motor_viscous", "motor_inertia"}  # coupled motors (issue 16)
    assert set(EFFECTS) == set(EFFECT_IDS) | {"spring_v1"}  # version 1 model files' spring: read, never injected
    rest = parse_effects("spring@2:amp=0.1:q0=0.3", 3)[0]
    assert rest.rest == 0.3 and rest.amplitude == 0.1


@pytest.mark.parametrize(
    "text, message",
    [
        ("colomb", "unknown effect 'colomb'"),
        ("spring@3", "joint 3 is out of range 1..2"),
        ("spring@0", "joint 0 is out of range 1..2"),
        ("coulomb@x", "expected joints like"),
        ("stribeck:k=12", "unknown key 'k' for stribeck"),
        ("gain:amp=1", "unknown key 'amp' for gain"),
        ("cogging:k=12.5", "k=12.5 is not on the grid"),
        ("stribeck:vs=0.07", "vs=0.07 is not on the grid"),
        ("offset:amp=-1", "amp must be positive"),
        ("offset:amp=big", "amp must be a number"),
        ("coulomb,coulomb@2", "already injected on joint 2"),
    ],
)
def test_bad_effect_specs(text, message):
    with pytest.raises(InputError, match=message):
        parse_effects(text, 2)


# --- random inertia --------------------------------------------------------------------------------


def test_random_inertia_is_physically_consistent():
    for seed in range(20):
        body = random_inertia(7, 0.8, np.random.default_rng(seed))
        assert np.all(body.mass > 0)
        assert np.all(np.abs(body.com) <= 0.4)
        for j in range(7):
            J = pseudo_inertia_from_standard(body.phi[10 * j : 10 * j + 10])
            eig = np.linalg.eigvalsh(J)
            assert eig.min() > 1e-9 * eig.max(), (seed, j, eig)
            moments = np.linalg.eigvalsh(body.inertia_com[j])
            assert moments.min() > 0 and moments[0] + moments[1] > moments[2]


def test_pseudo_inertia_rejects_a_body_that_breaks_the_triangle_inequality():
    # principal moments 1, 1, 3: positive definite about the CoM, but 1 + 1 < 3
    phi = standard_from_com(2.0, [0.1, 0.0, 0.0], np.diag([1.0, 1.0, 3.0]))
    assert np.linalg.eigvalsh(pseudo_inertia_from_standard(phi)).min() < 0
    ok = standard_from_com(2.0, [0.1, 0.0, 0.0], np.diag([1.0, 1.5, 2.0]))
    assert np.linalg.eigvalsh(pseudo_inertia_from_standard(ok)).min() > 0


def test_standard_parameters_round_trip_to_mass_com_and_central_inertia():
    body = random_inertia(3, 1.0, np.random.default_rng(11))
    for j in range(3):
        p = body.phi[10 * j : 10 * j + 10]
        m = p[9]
        c = p[6:9] / m
        Io = np.array([[p[0], p[1], p[2]], [p[1], p[3], p[4]], [p[2], p[4], p[5]]])
        Ic = Io - m * (c @ c * np.eye(3) - np.outer(c, c))
        assert m == pytest.approx(body.mass[j], rel=1e-14)
        np.testing.assert_allclose(c, body.com[j], rtol=1e-13)
        np.testing.assert_allclose(Ic, body.inertia_com[j], atol=1e-12 * np.abs(Io).max())


def test_robot_without_inertia_gets_random_consistent_parameters(tmp_path):
    truth = tmp_path / "t.json"
    stanford = str(ROBOTS / "stanford.yaml")  # 6 joints, no inertial data
    r = cli("simulate", stanford, *short("-o", str(tmp_path / "d.csv"), "--truth", str(truth)))
    assert r.exit_code == 0, r.output
    assert "does not give inertial data" in r.stderr and r.stdout == ""
    rec = json.loads(truth.read_text())
    assert rec["inertia_source"] == "random" and rec["standard_parameters"] == list(standard_names(6))
    phi = np.array(rec["phi"])
    for j in range(6):
        assert np.linalg.eigvalsh(pseudo_inertia_from_standard(phi[10 * j : 10 * j + 10])).min() > 0
    quiet = cli("simulate", stanford, *short("-o", str(tmp_path / "e.csv"), "--quiet"))
    assert quiet.exit_code == 0 and quiet.stderr == ""


def test_random_inertia_flag_overrides_the_file(tmp_path):
    truth = tmp_path / "t.json"
    r = cli("simulate", PLANAR, *short("--random-inertia", "-o", str(tmp_path / "d.csv"), "--truth", str(truth), "-q"))
    assert r.exit_code == 0, r.output
    rec = json.loads(truth.read_text())
    assert rec["inertia_source"] == "random"
    assert not np.allclose(rec["phi"], chain_of(PLANAR).phi_nominal)


# --- files -------------------------------------------------------------------------------------------


def test_csv_header_and_columns(tmp_path):
    out = tmp_path / "d.csv"
    r = cli("simulate", PUMA, *short("-o", str(out), "-q"))
    assert r.exit_code == 0 and r.stdout == ""
    lines = out.read_text().splitlines()
    header = "t,q1,q2,q3,q4,q5,q6,dq1,dq2,dq3,dq4,dq5,dq6,ddq1,ddq2,ddq3,ddq4,ddq5,ddq6,tau1,tau2,tau3,tau4,tau5,tau6"
    assert lines[0] == header == ",".join(data_columns(6))
    assert len(lines) == 1 + 400
    table = np.loadtxt(out, delimiter=",", skiprows=1)
    assert table.shape == (400, 25)
    np.testing.assert_allclose(table[:, 0], np.arange(400) / 100.0, rtol=0, atol=1e-15)

    no_ddq = tmp_path / "n.csv"
    assert cli("simulate", PUMA, *short("-o", str(no_ddq), "-q", "--no-ddq")).exit_code == 0
    head = no_ddq.read_text().splitlines()[0].split(",")
    assert head == list(data_columns(6, include_ddq=False)) and not any(h.startswith("ddq") for h in head)
    full = np.loadtxt(no_ddq, delimiter=",", skiprows=1)
    np.testing.assert_array_equal(full, np.delete(table, np.s_[13:19], axis=1))


def test_csv_on_stdout_without_output():
    r = cli("simulate", PLANAR, "--duration", "0.05", "--rate", "100", "-q")
    assert r.exit_code == 0 and r.stderr == ""
    lines = r.stdout.splitlines()
    assert lines[0] == "t,q1,q2,dq1,dq2,ddq1,ddq2,tau1,tau2" and len(lines) == 6


def test_npz_round_trip_matches_the_csv(tmp_path):
    csv, npz = tmp_path / "d.csv", tmp_path / "d.npz"
    for out in (csv, npz):
        assert cli("simulate", PLANAR, *short("--effects", "coulomb", "--noise", "0.1", "--seed", "5", "-o", str(out), "-q")).exit_code == 0
    data = np.load(npz)
    assert sorted(data.files) == ["ddq", "dq", "q", "t", "tau"]
    table = np.loadtxt(csv, delimiter=",", skiprows=1)
    n = 2
    np.testing.assert_array_equal(table[:, 0], data["t"])
    for k, key in enumerate(("q", "dq", "ddq", "tau")):
        np.testing.assert_array_equal(table[:, 1 + k * n : 1 + (k + 1) * n], data[key])  # repr reads back exactly
    assert not any(p.name.endswith(".tmp") for p in tmp_path.iterdir())

    no_ddq = tmp_path / "n.npz"
    assert cli("simulate", PLANAR, *short("-o", str(no_ddq), "-q", "--no-ddq")).exit_code == 0
    assert sorted(np.load(no_ddq).files) == ["dq", "q", "t", "tau"]


def test_same_seed_same_files_different_seed_different(tmp_path):
    def make(name, seed):
        out, truth = tmp_path / f"{name}.csv", tmp_path / f"{name}.json"
        args = short("--effects", "coulomb,spring@1", "--noise", "0.05", "--seed", str(seed), "-o", str(out), "--truth", str(truth), "-q")
        assert cli("simulate", PLANAR, *args).exit_code == 0
        return out.read_bytes(), truth.read_bytes()

    a, b, c = make("a", 9), make("b", 9), make("c", 10)
    assert a == b
    assert a[0] != c[0] and a[1] != c[1]


def test_truth_record_keys(tmp_path):
    truth = tmp_path / "t.json"
    r = cli("simulate", PLANAR, *short("--effects", "coulomb@1,stribeck@2,cogging@1:k=12", "--noise", "0.01", "--seed", "3",
                                       "-o", str(tmp_path / "d.csv"), "--truth", str(truth), "-q"))
    assert r.exit_code == 0, r.output
    rec = json.loads(truth.read_text())
    for key in ("robot", "seed", "effects", "noise", "phi", "standard_parameters"):
        assert key in rec
    assert rec["seed"] == 3 and rec["noise"] == 0.01 and len(rec["phi"]) == 20
    assert rec["effects"][0] == {**rec["effects"][0], "effect": "coulomb", "joints": [1], "hyper": None}
    assert list(rec["effects"][0]["coefficients"]) == ["1"] and len(rec["effects"][0]["coefficients"]["1"]) == 1
    assert rec["effects"][1]["hyper"] == 0.05 and rec["effects"][1]["joints"] == [2]
    assert rec["effects"][2]["hyper"] == 12.0 and len(rec["effects"][2]["coefficients"]["1"]) == 2


def test_summary_on_stderr(tmp_path):
    r = cli("simulate", PLANAR, *short("--effects", "coulomb", "-o", str(tmp_path / "d.csv")))
    assert r.exit_code == 0 and r.stdout == ""
    assert "400 samples" in r.stderr and "effects    coulomb@all" in r.stderr


# --- one test per bad input, through the real entry point --------------------------------------------


def assert_one_line_error(r, text):
    assert r.exit_code == 2, (r.exit_code, r.output)
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("minparam: error:"), r.stderr
    assert text in lines[0]
    assert r.stdout == ""


def test_cli_unknown_effect(tmp_path):
    r = cli("simulate", PLANAR, "--effects", "coulomb,backlash", "-o", str(tmp_path / "d.csv"))
    assert_one_line_error(r, "--effects: unknown effect 'backlash'")
    assert not (tmp_path / "d.csv").exists()


def test_cli_joint_out_of_range(tmp_path):
    r = cli("simulate", PLANAR, "--effects", "spring@3", "-o", str(tmp_path / "d.csv"))
    assert_one_line_error(r, "joint 3 is out of range 1..2")


def test_cli_bad_key(tmp_path):
    r = cli("simulate", PLANAR, "--effects", "cogging@1:period=12", "-o", str(tmp_path / "d.csv"))
    assert_one_line_error(r, "unknown key 'period' for cogging; expected amp, k")


def test_cli_hyper_not_on_grid(tmp_path):
    r = cli("simulate", PLANAR, "--effects", "cogging:k=100", "-o", str(tmp_path / "d.csv"))
    assert_one_line_error(r, "k=100 is not on the grid")


def test_cli_negative_noise(tmp_path):
    r = cli("simulate", PLANAR, "--noise", "-0.1", "-o", str(tmp_path / "d.csv"))
    assert_one_line_error(r, "--noise must be a number >= 0")


def test_cli_negative_position_noise(tmp_path):
    r = cli("simulate", PLANAR, "--noise-q", "-1", "-o", str(tmp_path / "d.csv"))
    assert_one_line_error(r, "--noise-q must be a number >= 0")


def test_cli_negative_coulomb_smoothing(tmp_path):
    r = cli("simulate", PLANAR, "--coulomb-smoothing", "-1", "-o", str(tmp_path / "d.csv"))
    assert_one_line_error(r, "--coulomb-smoothing must be a number >= 0")
    assert not (tmp_path / "d.csv").exists()


def test_cli_negative_seed(tmp_path):
    r = cli("simulate", PLANAR, "--seed", "-1", "-o", str(tmp_path / "d.csv"))
    assert_one_line_error(r, "Invalid value for '--seed': -1 is not in the range x>=0")


def test_cli_bad_output_folder(tmp_path):
    r = cli("simulate", PLANAR, "-o", str(tmp_path / "missing" / "d.csv"))
    assert_one_line_error(r, "does not exist")


def test_cli_bad_truth_folder(tmp_path):
    r = cli("simulate", PLANAR, "-o", str(tmp_path / "d.csv"), "--truth", str(tmp_path / "missing" / "t.json"))
    assert_one_line_error(r, "does not exist")
    assert not (tmp_path / "d.csv").exists()


def test_cli_unknown_output_type(tmp_path):
    r = cli("simulate", PLANAR, "-o", str(tmp_path / "d.txt"))
    assert_one_line_error(r, "expected .csv or .npz")


def test_cli_harmonics_above_nyquist(tmp_path):
    r = cli("simulate", PLANAR, "--rate", "1", "--harmonics", "5", "-o", str(tmp_path / "d.csv"))
    assert_one_line_error(r, "below half the --rate")


def test_cli_non_positive_duration(tmp_path):
    r = cli("simulate", PLANAR, "--duration", "0", "-o", str(tmp_path / "d.csv"))
    assert_one_line_error(r, "--duration must be a positive number")


def test_cli_help_has_examples():
    r = cli("simulate", "--help")
    assert r.exit_code == 0
    assert "Examples" in r.output and "cogging@3:k=12" in r.output and "Swevers" in r.output


def test_body_from_standard_inverts_standard_from_com():
    from minparam_cli.dynamics.inertia import body_from_standard

    rng = np.random.default_rng(11)
    bodies = random_inertia(4, 0.5, rng)
    for m, c, Ic, phi in zip(bodies.mass, bodies.com, bodies.inertia_com, bodies.phi.reshape(4, 10), strict=True):
        m2, c2, Ic2 = body_from_standard(phi)
        assert m2 == m and np.allclose(c2, c, rtol=1e-12, atol=1e-15) and np.allclose(Ic2, Ic, rtol=1e-10, atol=1e-14)
        assert np.allclose(standard_from_com(m2, c2, Ic2), phi, rtol=1e-10, atol=1e-14)
