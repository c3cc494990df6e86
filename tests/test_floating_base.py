"""Floating bases (issue 24, point 4): six virtual joints in front of the free link.

The robots are made here: a pelvis with two legs of revolute joints, free through a URDF
`floating` joint from a `world` link, or with no floating joint and --floating-base.  References:
tests/reference_dynamics.py (Euler–Lagrange) on the whole chain, virtual joints included, with
zero parameters on the massless virtual links; the base force rows against Newton's law for the
whole robot, Σ m_i (p̈_i − g), from finite differences of the centres of mass; and the count
against pinocchio with a free-flyer root (skipped without pinocchio).
"""

from __future__ import annotations

import numpy as np
import pytest
import reference_dynamics as ref
from typer.testing import CliRunner

from minparam_cli.base.qr import derive_qr
from minparam_cli.cli.app import app
from minparam_cli.dynamics.regressor import regressor
from minparam_cli.errors import DescriptionError, UnsupportedError
from minparam_cli.robot import load_chain
from minparam_cli.api.derivation import derive_file as _derive_file
from minparam_cli.api.options.derive import DeriveOptions


def derive_file(path, opts):
    """The derive JSON of one robot file (the API's base set, as a dict)."""
    return _derive_file(path, opts).to_dict()



def link(name: str, k: int) -> str:
    return (
        f'<link name="{name}"><inertial><origin xyz="{0.01 * k} {0.02 - 0.003 * k} {-0.05 + 0.004 * k}" rpy="0.1 {0.03 * k} -0.2"/>'
        f'<mass value="{1.5 + 0.2 * k}"/><inertia ixx="{0.02 + 0.001 * k}" ixy="0.001" ixz="-0.0006" iyy="{0.03 - 0.001 * k}" '
        f'iyz="0.0005" izz="{0.025 + 0.002 * k}"/></inertial></link>\n'
    )


def joint(name, kind, parent, child, xyz="0 0 0", axis="0 1 0", rpy="0 0 0") -> str:
    limit = '<limit lower="-2" upper="2" effort="1" velocity="1"/>' if kind == "revolute" else ""
    return (
        f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
        f'<origin xyz="{xyz}" rpy="{rpy}"/><axis xyz="{axis}"/>{limit}</joint>\n'
    )


LEG = [("0 {s}0.1 -0.05", "1 0 0"), ("0 {s}0.02 -0.03", "0 1 0"), ("0.01 0 -0.3", "0 1 0")]  # hip roll, hip pitch, knee


def biped(tmp_path, per_leg=3, floating_joint=True, name="biped"):
    """A pelvis and two legs of ``per_leg`` revolute joints (n = 2·per_leg)."""
    links, joints = ["pelvis"], []
    if floating_joint:
        links.insert(0, "world")
        joints.append(joint("root", "floating", "world", "pelvis", xyz="0 0 0.8"))
    for side, s in (("l", ""), ("r", "-")):
        parent = "pelvis"
        for i in range(per_leg):
            xyz, axis = LEG[i % 3]
            child = f"{side}{i}"
            joints.append(joint(f"{side}_j{i}", "revolute", parent, child, xyz=xyz.format(s=s), axis=axis))
            links.append(child)
            parent = child
        joints.append(joint(f"{side}_foot", "fixed", parent, f"{side}_foot", xyz="0 0 -0.3"))
        links.append(f"{side}_foot")
    body = "".join(("<link name=\"world\"/>\n" if n == "world" else link(n, k)) for k, n in enumerate(links)) + "".join(joints)
    path = tmp_path / f"{name}.urdf"
    path.write_text(f'<?xml version="1.0"?>\n<robot name="{name}">\n{body}</robot>\n')
    return path


def full_phi(chain, phi):
    """10 parameters per joint of the chain, zeros on the massless virtual links."""
    out = np.zeros(10 * chain.n)
    for k, j in enumerate(chain.layout.links_with_columns):
        out[10 * j : 10 * j + 10] = phi[10 * k : 10 * k + 10]
    return out


@pytest.mark.parametrize("floating_joint", [True, False])
def test_regressor_times_phi_is_lagrange_with_the_base_wrench_rows(tmp_path, floating_joint):
    _, chain = load_chain(biped(tmp_path, 2, floating_joint), DeriveOptions(floating_base=not floating_joint))
    assert chain.floating_base and chain.n == chain.dof == 6 + 4
    assert chain.layout.n_inertial == 10 * 5  # pelvis + 4 leg links; the 5 massless virtual links have no columns
    assert chain.layout.names[:10] == ("XX0", "XY0", "XZ0", "YY0", "YZ0", "ZZ0", "MX0", "MY0", "MZ0", "M0")
    rng = np.random.default_rng(42)
    phi = rng.standard_normal(chain.layout.n_inertial)
    q = rng.uniform(-np.pi, np.pi, (3, chain.n))
    qd, qdd = rng.standard_normal((2, 3, chain.n))
    Y = regressor(chain, q, qd, qdd)
    for s in range(3):
        tau_ref = ref.inverse_dynamics(chain, full_phi(chain, phi), q[s], qd[s], qdd[s])
        assert np.linalg.norm(Y[s] @ phi - tau_ref) <= 1e-9 * np.linalg.norm(tau_ref)


def test_base_force_rows_are_newtons_law_for_the_whole_robot(tmp_path):
    """Rows 1-3 (the base translations) = Σ m_i (p̈_i − g), p_i the world centre of mass of link i."""
    desc, chain = load_chain(biped(tmp_path, 3), DeriveOptions())
    masses = np.array([j.inertial.mass for j in desc.joints if not j.massless])
    coms = [np.asarray(j.inertial.com) for j in desc.joints if not j.massless]
    bodies = chain.layout.links_with_columns
    rng = np.random.default_rng(9)
    q0 = rng.uniform(-np.pi, np.pi, chain.n)
    qd, qdd = rng.standard_normal((2, chain.n))

    def centres(t):
        frames, _, _ = ref._fk(chain, q0 + qd * t + 0.5 * qdd * t * t)
        return np.array([(frames[j][:3, :3] @ c + frames[j][:3, 3]).real for j, c in zip(bodies, coms, strict=True)])

    h = 1e-4
    acc = (centres(h) - 2 * centres(0.0) + centres(-h)) / (h * h)
    newton = masses @ (acc - chain.gravity)
    tau = regressor(chain, q0[None], qd[None], qdd[None])[0] @ chain.phi_nominal
    assert np.allclose(tau[:3], newton, rtol=1e-5, atol=1e-5 * np.abs(newton).max())


def reference_rank(chain, samples=12, seed=1):
    """Singular-value rank of the regressor built column by column from the Euler–Lagrange reference."""
    rng = np.random.default_rng(seed)
    P = chain.layout.n_inertial
    rows = []
    for _ in range(samples):
        q = rng.uniform(-np.pi, np.pi, chain.n)
        qd, qdd = rng.standard_normal((2, chain.n))
        rows.append(np.column_stack([ref.inverse_dynamics(chain, full_phi(chain, e), q, qd, qdd) for e in np.eye(P)]))
    W = np.vstack(rows)
    sv = np.linalg.svd(W / np.linalg.norm(W, axis=0), compute_uv=False)
    return int(np.sum(sv > 1e-9 * sv[0]))


def test_base_count_is_the_rank_of_the_lagrange_reference(tmp_path):
    _, chain = load_chain(biped(tmp_path, 1), DeriveOptions())
    assert chain.dof == 8
    assert derive_qr(chain).n_base == reference_rank(chain)


def test_base_count_against_pinocchio_free_flyer(tmp_path):
    pin = pytest.importorskip("pinocchio")
    import scipy.linalg

    for per_leg in (2, 3):
        path = biped(tmp_path, per_leg, floating_joint=False, name=f"b{per_leg}")
        model = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
        data = model.createData()
        rng = np.random.default_rng(0)
        rows = []
        for _ in range(40):
            q = pin.randomConfiguration(model, -np.pi * np.ones(model.nq), np.pi * np.ones(model.nq))
            v, a = rng.standard_normal((2, model.nv))
            rows.append(pin.computeJointTorqueRegressor(model, data, q, v, a).copy())
        R = scipy.linalg.qr(np.vstack(rows), mode="r", pivoting=True)[0]
        r = np.abs(np.diagonal(R))
        expected = int(np.sum(r > 1e-8 * r[0]))
        _, chain = load_chain(path, DeriveOptions(floating_base=True))
        assert derive_qr(chain).n_base == expected, per_leg


def test_cli_derive_floating_base(tmp_path):
    path = biped(tmp_path, 2, floating_joint=False)
    r = CliRunner().invoke(app, ["derive", str(path), "--floating-base", "-f", "json"])
    assert r.exit_code == 0, r.output
    assert '"floating_base": true' in r.output and '"dof": 10' in r.output
    r = CliRunner().invoke(app, ["derive", str(path)])  # without the flag: the pelvis is fixed
    assert r.exit_code == 0 and "floating base" not in r.output
    r = CliRunner().invoke(app, ["derive", str(path), "--floating-base", "--method", "projection"])
    assert r.exit_code == 2 and "floating base" in r.stderr and r.stderr.count("\n") == 1


@pytest.mark.parametrize("command", ["identify", "simulate"])
def test_identify_and_simulate_refuse_floating_bases_in_one_line(tmp_path, command):
    path = biped(tmp_path, 2)
    data = tmp_path / "d.csv"
    data.write_text("t,q1,dq1,ddq1,tau1\n0,0,0,0,0\n")
    args = [command, str(path)] + ([str(data)] if command == "identify" else [])
    r = CliRunner().invoke(app, args)
    assert r.exit_code == 2, r.output
    assert f"{command} of floating-base robots needs base motion columns: not supported yet" in r.stderr
    assert r.stderr.count("\n") == 1


def test_planar_and_inner_floating_joints_are_one_line_exit_2(tmp_path):
    path = tmp_path / "p.urdf"
    path.write_text(
        '<robot name="p">' + link("a", 0) + link("b", 1) + link("c", 2)
        + joint("j1", "revolute", "a", "b") + joint("free", "floating", "b", "c") + "</robot>"
    )
    with pytest.raises(UnsupportedError, match="floating joint inside the tree"):
        load_chain(path, DeriveOptions())
    path.write_text('<robot name="p">' + link("a", 0) + link("b", 1) + joint("slide", "planar", "a", "b") + "</robot>")
    r = CliRunner().invoke(app, ["derive", str(path)])
    assert r.exit_code == 2 and "joint[slide]: planar joints are not supported yet" in r.stderr and r.stderr.count("\n") == 1


def test_floating_base_flag_on_a_dh_table_is_refused():
    with pytest.raises(DescriptionError, match="--floating-base applies to URDF files"):
        load_chain("robots/planar2r.yaml", DeriveOptions(floating_base=True))
    r = CliRunner().invoke(app, ["derive", "robots/planar2r.yaml", "--floating-base"])
    assert r.exit_code == 2 and r.stderr.count("\n") == 1


def test_floating_base_alone_is_a_robot(tmp_path):
    """A single free body: 10 parameters, all identifiable from the base wrench."""
    path = tmp_path / "box.urdf"
    path.write_text('<robot name="box"><link name="world"/>' + link("box", 1) + joint("root", "floating", "world", "box") + "</robot>")
    rep = derive_file(path, DeriveOptions())
    assert rep["dof"] == 6 and rep["n_standard"] == 10 and rep["n_base"] == 10
