"""Closed chains (issue 35): the actuated torques τ_a = Gᵀ·Y_tree·φ against independent physics, the
energy route against the torque route, and one refusal per kind of bad loop."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from minparam_cli.api.options.derive import DeriveOptions
from minparam_cli.describe import load_description
from minparam_cli.errors import DescriptionError, UnsupportedError
from minparam_cli.loops.derive import actuated_regressor
from minparam_cli.loops.model import closed_model
from minparam_cli.loops.sample import manifold_states
from minparam_cli.robot import load_chain

ROOT = Path(__file__).resolve().parents[1]
ARM = ROOT / "robots" / "parallelogram_arm.yaml"
RRR = ROOT / "robots" / "planar_3rrr.yaml"


def _model(path):
    desc, chain = load_chain(path, DeriveOptions().stage(), loops=True)
    return desc, chain, closed_model(desc, chain)


def _energy_by_differences(chain, q_of_t, t, h=1e-4):
    """Kinetic + potential energy at time t from link poses alone (velocities by central differences)."""
    from minparam_cli.chain import forward_kinematics

    T0, _, _ = forward_kinematics(chain, q_of_t(t)[None])
    Tp, _, _ = forward_kinematics(chain, q_of_t(t + h)[None])
    Tm, _, _ = forward_kinematics(chain, q_of_t(t - h)[None])
    phi = chain.phi_nominal.reshape(-1, 10)
    E = 0.0
    for j in range(chain.n):
        m, ms = phi[j, 9], phi[j, 6:9]
        c = ms / m
        Io = np.array([[phi[j, 0], phi[j, 1], phi[j, 2]], [phi[j, 1], phi[j, 3], phi[j, 4]], [phi[j, 2], phi[j, 4], phi[j, 5]]])
        Ic = Io - m * (c @ c * np.eye(3) - np.outer(c, c))
        R, Rd = T0[0, j, :3, :3], (Tp[0, j, :3, :3] - Tm[0, j, :3, :3]) / (2 * h)
        W = Rd @ R.T
        w = np.array([W[2, 1], W[0, 2], W[1, 0]])
        cp, cm, c0 = (T[0, j, :3, :3] @ c + T[0, j, :3, 3] for T in (Tp, Tm, T0))
        vc = (cp - cm) / (2 * h)
        E += 0.5 * m * vc @ vc + 0.5 * w @ (R @ Ic @ R.T) @ w - m * chain.gravity @ c0
    return E


@pytest.mark.parametrize("path", [ARM, RRR])
def test_actuated_torques_balance_the_power_of_the_mechanism(path):
    """τ_a·q̇_a = d(T + V)/dt along a motion on the manifold, T and V from link poses only (no
    Newton–Euler, no constraint Jacobian): the mapped regressor times the nominal φ is the torque."""
    desc, chain, model = _model(path)
    f = len(model.actuated)
    ref = model.reference[list(model.actuated)]
    amp, freq = 0.15 * np.linspace(1.0, 0.6, f), np.linspace(1.1, 1.9, f)
    scale = np.array([1.0 if chain.types[j] == "revolute" else chain.length_scale * 0.2 for j in model.actuated])

    def q_of_t(t):
        q, err = model.close((ref + scale * amp * np.sin(freq * t))[None], model.reference[None])
        assert err[0] < 1e-10
        return q[0]

    for t in (0.3, 1.1, 2.0):
        q = q_of_t(t)[None]
        qd_a = (scale * amp * freq * np.cos(freq * t))[None]
        qdd_a = (-scale * amp * freq**2 * np.sin(freq * t))[None]
        G, _ = model.tangent(q)
        qd = np.einsum("snf,sf->sn", G, qd_a)
        _, g = model.tangent(q, qd)
        qdd = np.einsum("snf,sf->sn", G, qdd_a) + g
        tau = actuated_regressor(model, q, qd, qdd, G)[0, :, : chain.layout.n_inertial] @ chain.phi_nominal
        H = 1e-3
        power = (_energy_by_differences(chain, q_of_t, t + H) - _energy_by_differences(chain, q_of_t, t - H)) / (2 * H)
        assert tau @ qd_a[0] == pytest.approx(power, rel=1e-5, abs=1e-5 * np.abs(tau).sum())


def test_tree_torques_minus_loop_forces_vanish_on_the_passive_joints():
    """Lagrange multipliers: τ_tree = Y_tree φ equals S_aᵀτ_a + Jᵀλ with one λ for every tree joint, so
    the passive joints carry no torque once the cut forces are added (τ_a from Gᵀ τ_tree)."""
    from minparam_cli.dynamics.regressor import joint_regressor

    desc, chain, model = _model(ARM)
    q, qd, qdd, G = manifold_states(model, 5, seed=3)
    tau_tree = joint_regressor(chain, q, qd, qdd) @ chain.phi_nominal
    tau_a = np.einsum("snf,sn->sf", G, tau_tree)
    J, h = model.jacobian(q)
    assert np.abs(h).max() < 1e-9
    p, a = list(model.passive), list(model.actuated)
    for s in range(len(q)):
        lam = np.linalg.lstsq(J[s][:, p].T, tau_tree[s, p], rcond=None)[0]
        assert np.allclose(J[s][:, p].T @ lam, tau_tree[s, p], atol=1e-9)
        assert np.allclose(tau_tree[s, a] - J[s][:, a].T @ lam, tau_a[s], atol=1e-8)
        # and the constraint accelerations hold: J q̈ + J̇ q̇ = 0
    assert np.abs(np.einsum("srn,sn->sr", J, qdd) + model.bias(q, qd)).max() < 1e-8


@pytest.mark.parametrize("path", [ARM, RRR])
def test_energy_route_gives_the_torque_routes_base_set(path):
    """Point 3: rank and regrouping of the energy rows (no accelerations) equal the torque rows'."""
    from minparam_cli.api.derivation import derive_file

    base = derive_file(path, DeriveOptions())
    check = base.extra["closed_chain"]["energy_check"]
    friction = sum(1 for i in base.kept if base.standard_names[i].startswith(("Fc", "Fv", "OFF")))
    assert check["rank_torques"] == check["rank_energy"] == base.n_base - friction
    assert check["same_kept"] and check["agrees"]


def test_the_energy_check_can_fail():
    """Without the potential energy the energy route loses the gravity-only combinations: it disagrees."""
    from minparam_cli.base.qr import base_from_regressor
    from minparam_cli.loops.energy import energy_columns, energy_rows

    desc, chain, model = _model(ARM)
    q, qd, _, _ = manifold_states(model, 80, seed=1)
    kin, _ = energy_rows(model, q, qd)
    kept_kin, _, _, _ = base_from_regressor(kin[:, energy_columns(model)])
    from minparam_cli.api.derivation import derive_file

    assert len(kept_kin) != derive_file(ARM, DeriveOptions()).n_base


def _write(tmp_path, text):
    p = tmp_path / "bad.yaml"
    p.write_text(ARM.read_text().replace(*text))
    return p


def test_a_cut_within_one_rigid_body_is_refused(tmp_path):
    bad = _write(tmp_path, ("between: [q4, q2]", "between: [q2, q2]"))
    with pytest.raises(DescriptionError, match="to itself"):
        load_description(bad)


LOCKED = """kind: closed_chain
name: a two-link arm welded to the ground
joints:
  - {name: q1, parent: base, type: revolute, origin: [0, 0, 0, 0, 0, 0], actuated: true}
  - {name: q2, parent: q1, type: revolute, origin: [1, 0, 0, 0, 0, 0]}
loops:
  - {name: weld, type: weld, between: [q2, base], at: [[1, 0, 0, 0, 0, 0], [2, 0, 0, 0, 0, 0]]}
"""


def test_a_loop_that_locks_the_mechanism_is_refused(tmp_path):
    bad = tmp_path / "locked.yaml"
    bad.write_text(LOCKED)
    desc, chain = load_chain(bad, DeriveOptions().stage(), loops=True)
    with pytest.raises(DescriptionError, match="lock the mechanism: 2 tree joints and 2 independent"):
        closed_model(desc, chain)


def test_a_loop_that_does_not_close_is_refused(tmp_path):
    bad = _write(tmp_path, ("[[0, 0, 1.0], [-0.3, 0, 0]]", "[[0, 0, 1.9], [-0.3, 0, 0]]"))
    desc, chain = load_chain(bad, DeriveOptions().stage(), loops=True)
    with pytest.raises(DescriptionError, match="cannot be assembled"):
        closed_model(desc, chain)


def test_a_wrong_count_of_actuated_joints_is_refused(tmp_path):
    bad = _write(tmp_path, ("axis: [0, 1, 0], actuated: true,\n     limits: [-40, 40],\n     inertial: {mass: 3.0",
                            "axis: [0, 1, 0],\n     limits: [-40, 40],\n     inertial: {mass: 3.0"))
    assert bad.read_text() != ARM.read_text()
    desc, chain = load_chain(bad, DeriveOptions().stage(), loops=True)
    with pytest.raises(DescriptionError, match="mobility 3 .* but 2 joints are actuated"):
        closed_model(desc, chain)


@pytest.mark.parametrize("opts", [{"method": "projection"}, {"symbolic": True}])
def test_tree_only_routes_refuse_a_closed_chain(opts):
    from minparam_cli.api.derivation import derive_file

    with pytest.raises(UnsupportedError):
        derive_file(ARM, DeriveOptions(**opts))


@pytest.mark.parametrize("command", ["derive", "check"])
def test_cli_bad_loop_is_one_line_exit_2(tmp_path, command):
    import subprocess
    import sys

    bad = _write(tmp_path, ("[[0, 0, 1.0], [-0.3, 0, 0]]", "[[0, 0, 1.9], [-0.3, 0, 0]]"))
    r = subprocess.run([sys.executable, "-m", "minparam_cli", command, str(bad)], capture_output=True, text=True,
                       env={"PYTHONPATH": str(ROOT / "src"), "PATH": "/usr/bin:/bin"}, timeout=120)
    assert r.returncode == 2
    assert len(r.stderr.strip().splitlines()) == 1 and "cannot be assembled" in r.stderr


@pytest.mark.parametrize("command", [["singular", "{robot}", "--scan"], ["codegen", "{robot}", "--lang", "python", "--model",
                                                                 "{tmp}/none.json", "-o", "{tmp}/cg.py"]])
def test_commands_without_loops_refuse_a_closed_chain_in_one_line(command, tmp_path):
    """The commands that do not read loops must not take the spanning tree for the robot."""
    from typer.testing import CliRunner

    from minparam_cli.cli.app import app

    if "--model" in command:  # a model file for the closed chain, from identify
        data = tmp_path / "d.csv"
        assert CliRunner().invoke(app, ["simulate", str(ARM), "-o", str(data), "--duration", "6", "--noise", "0.3"]).exit_code == 0
        r = CliRunner().invoke(app, ["identify", str(ARM), str(data), "--no-diagnose", "--save-model", str(tmp_path / "none.json")])
        assert r.exit_code == 0, r.output
        data.unlink()
    before = set(tmp_path.iterdir())
    r = CliRunner().invoke(app, [c.format(robot=ARM, tmp=tmp_path) for c in command])
    assert r.exit_code == 2, r.output
    assert "is a closed chain" in r.output and "Traceback" not in r.output
    assert set(tmp_path.iterdir()) == before


def test_actuated_joints_that_do_not_drive_the_passive_ones_are_refused(tmp_path):
    """Motors on q1, q2, q3 (the loop's own three) and the base yaw q0 passive: the count matches the
    mobility, but nothing drives q0 (the loop does not involve it), so the choice is refused."""
    text = ARM.read_text().replace("axis: [0, 0, 1], actuated: true,", "axis: [0, 0, 1],")
    text = text.replace("origin: [0, 0, 1.0, 0, 0, 0], axis: [0, 1, 0],", "origin: [0, 0, 1.0, 0, 0, 0], axis: [0, 1, 0], actuated: true,")
    assert text.count("actuated: true") == 3
    bad = tmp_path / "bad.yaml"
    bad.write_text(text)
    desc, chain = load_chain(bad, DeriveOptions().stage(), loops=True)
    with pytest.raises(DescriptionError, match="do not determine the passive ones"):
        closed_model(desc, chain)
