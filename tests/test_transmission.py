"""Transmissions (issue 16, point 1 and 7): motor-side columns, their regrouping, and bad coupling matrices.

The motor-side columns are checked against two computations that do not use them: Lagrange's
equations of the motor energy and dissipation written with matrices, and the power balance
τᵀq̇ = Σ_k f_k θ̇_m,k.  The regrouping is checked by rank and by the coefficients the base set gives.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import ROBOTS
from typer.testing import CliRunner

from minparam_cli.base.qr import derive_qr
from minparam_cli.chain import build_chain
from minparam_cli.cli.app import app
from minparam_cli.describe import load_description
from minparam_cli.describe.yaml_dh import description_from_mapping
from minparam_cli.dynamics.regressor import regressor
from minparam_cli.dynamics.transmission import (
    joint_from_motor,
    joint_torque,
    motor_from_joint,
    motor_torque,
)
from minparam_cli.errors import DescriptionError

TX40_N = np.diag([32.0, 32.0, 45.0, -48.0, 45.0, 32.0])
TX40_N[5, 4] = 32.0


def tx40(transmission: dict | None, **top) -> dict:
    """robots/tx40.yaml as a mapping, with this transmission block (None: none)."""
    import yaml

    doc = yaml.safe_load((ROBOTS / "tx40.yaml").read_text())
    doc.pop("transmission", None)
    doc.update(top)
    if transmission is not None:
        doc["transmission"] = transmission
    return doc


def chain_of(doc):
    return build_chain(description_from_mapping(doc, "tx40-test.yaml"))


def random_matrix(rng, n):
    while True:
        N = rng.normal(size=(n, n)) * (rng.random((n, n)) < 0.5) + np.diag(rng.uniform(5, 50, n) * rng.choice([-1, 1], n))
        if np.linalg.cond(N) < 1e3:
            return N


def test_motor_columns_match_lagrange_and_power():
    """Y_motor·φ_m = Nᵀ(diag(Iam) N q̈ + diag(Fvm) N q̇ + diag(Fcm) sign(N q̇)) for a random dense N."""
    rng = np.random.default_rng(7)
    N = random_matrix(rng, 6)
    doc = tx40({"matrix": N.tolist(), "motor_friction": ["coulomb", "viscous"], "motor_inertia": True})
    chain = chain_of(doc)
    q, qd, qdd = (rng.normal(size=(40, 6)) for _ in range(3))
    Y = regressor(chain, q, qd, qdd)
    names = chain.layout.names
    iam, fcm, fvm = (rng.uniform(0.1, 2.0, 6) for _ in range(3))
    phi = np.zeros(len(names))
    for k in range(6):
        phi[names.index(f"Iam{k + 1}")], phi[names.index(f"Fcm{k + 1}")], phi[names.index(f"Fvm{k + 1}")] = iam[k], fcm[k], fvm[k]
    tau = Y @ phi
    # Lagrange: T_m = ½ θ̇ᵀ diag(Iam) θ̇ with θ̇ = N q̇ gives Nᵀ diag(Iam) N q̈; dissipation likewise
    want = (N.T @ (np.diag(iam) @ N @ qdd.T + np.diag(fvm) @ N @ qd.T + np.diag(fcm) @ np.sign(N @ qd.T))).T
    np.testing.assert_allclose(tau, want, rtol=1e-12, atol=1e-9)
    # power balance: joint power of the motor terms = Σ_k (motor torque k)·(motor speed k)
    th_d, th_dd = qd @ N.T, qdd @ N.T
    motor_power = ((iam * th_dd + fvm * th_d + fcm * np.sign(th_d)) * th_d).sum(axis=1)
    np.testing.assert_allclose((tau * qd).sum(axis=1), motor_power, rtol=1e-10)


def test_tx40_coupled_motor_regroups_and_uncoupled_motors_join_their_joint():
    """With the real TX40 coupling, motor 6's three columns each add one to the rank, and every
    uncoupled motor's columns regroup into its joint's with r² (inertia, viscous) or |r| (Coulomb)."""
    plain = chain_of(tx40(None, friction=["coulomb", "viscous"], rotor_inertia=True))
    block = {"ratios": [32, 32, 45, -48, 45, 32], "coupling": [[6, 5, 32]], "motor_friction": ["coulomb", "viscous"],
             "motor_inertia": True}
    coupled = chain_of(tx40(block, friction=["coulomb", "viscous"], rotor_inertia=True))
    b0, b1 = derive_qr(plain), derive_qr(coupled)
    assert len(b1.kept) == len(b0.kept) + 3
    kept = {b1.standard_names[i] for i in b1.kept}
    assert {"Iam6", "Fcm6", "Fvm6"} <= kept
    names = b1.standard_names
    K = np.asarray(b1.K)
    for motor, r in ((1, 32), (3, 45), (4, -48), (5, 45)):
        for joint_name, motor_name, coef in ((f"Fv{motor}", f"Fvm{motor}", r * r), (f"Fc{motor}", f"Fcm{motor}", abs(r))):
            row = [i for i, k in enumerate(b1.kept) if names[k] == joint_name]
            assert row, f"{joint_name} should be kept"
            assert K[row[0], names.index(motor_name)] == pytest.approx(coef, rel=1e-8)
    # a diagonal N: every motor column regroups, the rank does not change
    diag = dict(block, coupling=[])
    assert len(derive_qr(chain_of(tx40(diag, friction=["coulomb", "viscous"], rotor_inertia=True))).kept) == len(b0.kept)


def test_coupled_motor_inertia_is_not_a_joint_rotor_inertia():
    """Iam6 with motor 6 on joints 5 and 6 is independent of Ia5, Ia6 and the links (rank + 1)."""
    block = {"ratios": [32, 32, 45, -48, 45, 32], "coupling": [[6, 5, 32]], "motor_inertia": True, "motors": [6]}
    b_joint = derive_qr(chain_of(tx40(None, rotor_inertia=True)))
    b_motor = derive_qr(chain_of(tx40(block, rotor_inertia=True)))
    assert len(b_motor.kept) == len(b_joint.kept) + 1
    assert "Iam6" in {b_motor.standard_names[i] for i in b_motor.kept}


def test_conversions_round_trip():
    rng = np.random.default_rng(3)
    q = rng.normal(size=(20, 6))
    zero = rng.normal(size=6)
    tau = rng.normal(size=(20, 6))
    gains = rng.uniform(0.5, 2.0, 6)
    np.testing.assert_allclose(joint_from_motor(motor_from_joint(q, TX40_N, zero), TX40_N, zero), q, atol=1e-12)
    np.testing.assert_allclose(joint_torque(motor_torque(tau, TX40_N, gains), TX40_N, gains), tau, atol=1e-12)
    # the README's TX40 relations: q6 = θ6/32 − q5, τ5 = 45 c5 + 32 c6
    th = motor_from_joint(q, TX40_N)
    np.testing.assert_allclose(th[:, 5] / 32 - q[:, 4], q[:, 5], atol=1e-12)
    c = rng.normal(size=(5, 6))
    np.testing.assert_allclose(joint_torque(c, TX40_N)[:, 4], 45 * c[:, 4] + 32 * c[:, 5], atol=1e-12)


def test_yaml_zero_and_gains_are_read():
    block = {"ratios": [32, 32, 45, -48, 45, 32], "coupling": [[6, 5, 32]], "zero": [0, "-pi/2", "pi/2", 0, 0, 0],
             "drive_gains": [1, 2, 3, 4, 5, 6]}
    tr = description_from_mapping(tx40(block), "x.yaml").transmission
    assert tr.zero[1] == pytest.approx(-np.pi / 2) and tr.zero[2] == pytest.approx(np.pi / 2)
    assert tr.drive_gains == (1, 2, 3, 4, 5, 6)
    np.testing.assert_array_equal(np.array(tr.matrix), TX40_N)


def test_urdf_side_file(tmp_path):
    urdf = tmp_path / "ur5.urdf"
    urdf.write_text((ROBOTS / "ur5.urdf").read_text())
    assert load_description(urdf).transmission is None
    (tmp_path / "ur5.transmission.yaml").write_text(
        "transmission:\n  ratios: [101, 101, 101, 101, 101, 101]\n  coupling: [[6, 5, 1]]\n  motor_friction: [viscous]\n  motors: [6]\n")
    desc = load_description(urdf)
    assert desc.transmission.matrix[5][4] == 1.0
    chain = build_chain(desc)
    assert "Fvm6" in chain.layout.names and "Fvm5" not in chain.layout.names


BAD = [
    ({"matrix": [[1, 0], [0, 1]]}, "expected a 6x6 matrix"),
    ({"matrix": [[1, 0, 0], [0, 1]]}, "must be square"),
    ({"matrix": (np.eye(6) * [1, 1, 1, 1, 1, 0]).tolist()}, "singular"),
    ({"ratios": [32, 32, 45, -48, 45, 32], "coupling": [[6, 5, 32], [5, 6, 45]]}, "singular"),
    ({"ratios": [32, 32, 45, -48, 0, 32]}, "gear ratio of motor 5 is 0"),
    ({"ratios": [32, 32, 45, -48, 45, ".nan"]}, "finite"),
    ({"ratios": [32, 32, 45]}, "expected 6 numbers"),
    ({"ratios": [32, 32, 45, -48, 45, 32], "drive_gains": [1, 1, 1, 1, 0, 1]}, "drive gain of motor 5 is 0"),
    ({"ratios": [32, 32, 45, -48, 45, 32], "drive_gains": [1, 1, 1, -2, 1, 1]}, "must be positive"),
    ({"ratios": [32, 32, 45, -48, 45, 32], "coupling": [[7, 5, 1]]}, "motor or joint number 1..6"),
    ({"ratios": [32, 32, 45, -48, 45, 32], "motor_friction": ["stiction"]}, "unknown motor friction"),
]


@pytest.mark.parametrize("block,needle", BAD, ids=[b[1] for b in BAD])
def test_bad_transmission_is_one_line_exit_2(tmp_path, block, needle):
    import yaml

    doc = tx40(block)
    text = yaml.safe_dump(doc).replace("'.nan'", ".nan")
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(DescriptionError):
        load_description(path)
    for command in ("check", "derive"):
        r = CliRunner().invoke(app, [command, str(path)])
        assert r.exit_code == 2, r.output
        lines = [ln for ln in r.output.strip().splitlines() if "error" in ln and str(path) + ":" in ln]
        assert len(lines) == 1 and needle in lines[0] and "Traceback" not in r.output, r.output
        if command == "derive":
            assert len(r.output.strip().splitlines()) == 1, r.output


def test_check_reports_the_transmission():
    import json

    r = CliRunner().invoke(app, ["check", str(ROBOTS / "tx40.yaml"), "--json"])
    assert r.exit_code == 0, r.output
    tr = json.loads(r.output)["transmission"]
    assert tr["motors"] == 6 and tr["coupled_motors"] == [6] and tr["drive_gains"] is False
    assert tr["condition_number"] == pytest.approx(np.linalg.cond(TX40_N))
    r = CliRunner().invoke(app, ["check", str(ROBOTS / "puma560.yaml"), "--json"])
    assert json.loads(r.output)["transmission"] is None
