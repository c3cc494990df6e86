"""Regressor · phi equals an independent Euler–Lagrange inverse dynamics."""

from __future__ import annotations

import numpy as np
import pytest
import reference_dynamics as ref

from minparam_cli.chain import build_chain, forward_kinematics
from minparam_cli.describe import load_description
from minparam_cli.dynamics.regressor import regressor


def test_regressor_times_phi_is_lagrangian_torque(robot_path):
    chain = build_chain(load_description(robot_path))
    rng = np.random.default_rng(20261121)
    n = chain.n
    phi = rng.standard_normal(10 * n)
    q = rng.uniform(-np.pi, np.pi, (3, n))
    qd, qdd = rng.standard_normal((2, 3, n))
    Y = regressor(chain, q, qd, qdd, include_extras=False)  # the inertial columns; a transmission's motor
    for s in range(3):                                        # columns are tested in test_transmission.py
        tau = Y[s] @ phi
        tau_ref = ref.inverse_dynamics(chain, phi, q[s], qd[s], qdd[s])
        assert np.linalg.norm(tau - tau_ref) <= 1e-9 * np.linalg.norm(tau_ref)


def test_nominal_parameters_give_gravity_torque_at_rest(robot_path):
    """At rest, tau = dV/dq: check against a finite difference of the potential energy."""
    chain = build_chain(load_description(robot_path))
    if chain.phi_nominal is None:
        pytest.skip("no inertial values in this description")
    rng = np.random.default_rng(3)
    q = rng.uniform(-1, 1, chain.n)
    zero = np.zeros((1, chain.n))
    tau = regressor(chain, q[None], zero, zero)[0] @ chain.phi_nominal
    h = 1e-6
    num = []
    for k in range(chain.n):
        e = np.zeros(chain.n)
        e[k] = h
        num.append((ref.potential(chain, chain.phi_nominal, q + e).real - ref.potential(chain, chain.phi_nominal, q - e).real) / (2 * h))
    assert np.allclose(tau, num, rtol=1e-6, atol=1e-8 * max(1.0, np.abs(num).max()))


def test_extra_columns_are_the_documented_terms():
    desc = load_description("robots/puma560_mdh.yaml")
    extras = tuple(("rotor_inertia", "coulomb", "viscous", "offset") for _ in desc.joints)
    chain = build_chain(desc, extras=extras)
    rng = np.random.default_rng(5)
    q, qd, qdd = rng.standard_normal((3, 4, 6))
    Y = regressor(chain, q, qd, qdd)
    names = chain.layout.names
    for k in range(6):
        j = k + 1
        for name, expected in ((f"Ia{j}", qdd[:, k]), (f"Fc{j}", np.sign(qd[:, k])), (f"Fv{j}", qd[:, k]), (f"OFF{j}", np.ones(4))):
            col = names.index(name)
            assert np.array_equal(Y[:, k, col], expected)
            others = [i for i in range(6) if i != k]
            assert not Y[:, others, col].any()


def test_dh_and_urdf_of_the_ur5_agree_on_tool_position():
    """Both UR5 files describe the same arm up to a constant base/tool frame change:
    the distance from the base axis to the wrist axis chain matches at random q."""
    a = build_chain(load_description("robots/ur5.yaml"))
    rng = np.random.default_rng(9)
    q = rng.uniform(-np.pi, np.pi, (5, 6))
    T, _, _ = forward_kinematics(a, q)
    # UR5 DH: at q = 0 the flange sits at x = a2 + a3, y = -(d4 + d6)... check one known pose
    T0, _, _ = forward_kinematics(a, np.zeros((1, 6)))
    assert np.allclose(T0[0, -1, :3, 3], [-0.425 - 0.39225, -0.10915 - 0.0823, 0.089159 - 0.09465], atol=1e-12)
    assert np.all(np.isfinite(T))
