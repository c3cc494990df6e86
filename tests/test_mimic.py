"""Mimic joints (issue 24, point 3): q_mimic = m·q_master + o, the mimic link moving with its master.

The robots are made here: a 3-joint arm with a parallel gripper (two prismatic fingers, one
mimicking the other with multiplier 1, as the Panda's hand), and an arm whose revolute joint
mimics another with multiplier -0.5 and an offset, through a mimic of a mimic.  The reference
is tests/reference_dynamics.py (Euler–Lagrange, complex-step derivatives) on every joint of the
tree, knowing nothing of mimic joints, and the coupling written here from the URDF text:
τ_independent = Gᵀ τ_joints at q_joints = G q + o (virtual work).
"""

from __future__ import annotations

import numpy as np
import pytest
import reference_dynamics as ref
from typer.testing import CliRunner

from minparam_cli.base.qr import chain_scales, derive_qr, sample_rng, stacked_regressor
from minparam_cli.cli.app import app
from minparam_cli.dynamics.regressor import joint_regressor, random_states, regressor
from minparam_cli.errors import DescriptionError, UnsupportedError
from minparam_cli.robot import load_chain
from minparam_cli.api.derivation import derive_file as _derive_file
from minparam_cli.api.options.derive import DeriveOptions


def derive_file(path, opts):
    """The derive JSON of one robot file (the API's base set, as a dict)."""
    return _derive_file(path, opts).to_dict()



def link(name: str, k: int) -> str:
    """A link with generic inertial values (different per link, so no two links are alike)."""
    a, b = 0.1 + 0.013 * k, 0.07 - 0.004 * k
    return (
        f'<link name="{name}"><inertial><origin xyz="{0.011 * k} {b / 3:.4f} {a / 5:.4f}" rpy="0.1 {0.05 * k} 0.2"/>'
        f'<mass value="{0.7 + 0.3 * k}"/><inertia ixx="{0.02 + 0.001 * k}" ixy="0.001" ixz="-0.0007" iyy="{0.03 - 0.001 * k}" '
        f'iyz="0.0004" izz="{0.025 + 0.002 * k}"/></inertial></link>\n'
    )


def joint(name, kind, parent, child, xyz, axis, rpy="0 0 0", mimic=None) -> str:
    limit = '<limit lower="-0.04" upper="0.04" effort="1" velocity="1"/>' if kind == "prismatic" else '<limit lower="-2" upper="2" effort="1" velocity="1"/>'
    if kind == "fixed":
        limit = ""
    tag = ""
    if mimic is not None:
        master, m, o = mimic
        tag = f'<mimic joint="{master}" multiplier="{m}" offset="{o}"/>'
    return (
        f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
        f'<origin xyz="{xyz}" rpy="{rpy}"/><axis xyz="{axis}"/>{limit}{tag}</joint>\n'
    )


def write(tmp_path, name, joints_xml, links):
    path = tmp_path / f"{name}.urdf"
    body = "".join(link(n, k) for k, n in enumerate(links)) + "".join(joints_xml)
    path.write_text(f'<?xml version="1.0"?>\n<robot name="{name}">\n{body}</robot>\n')
    return path


def gripper_arm(tmp_path, finger_mimic=("finger_left", 1, 0), name="gripper_arm", right=None):
    """3 revolute joints, a fixed hand, two prismatic fingers (the right one mimics the left, unless
    ``right`` gives its joint element instead)."""
    joints = [
        joint("j1", "revolute", "base", "l1", "0 0 0.333", "0 0 1"),
        joint("j2", "revolute", "l1", "l2", "0 0 0", "0 1 0", rpy="-1.5707963267948966 0 0"),
        joint("j3", "revolute", "l2", "l3", "0.0825 -0.316 0", "0 0 1", rpy="1.5707963267948966 0 0"),
        joint("hand", "fixed", "l3", "hand", "0 0 0.107", "0 0 1", rpy="0 0 -0.785398163397"),
        joint("finger_left", "prismatic", "hand", "left", "0 0 0.0584", "0 1 0"),
        right or joint("finger_right", "prismatic", "hand", "right", "0 0 0.0584", "0 -1 0", mimic=finger_mimic),
    ]
    return write(tmp_path, name, joints, ["base", "l1", "l2", "l3", "hand", "left", "right"])


def revolute_mimic_arm(tmp_path):
    """j4 mimics j2 (x -0.5, offset 0.3); j5 mimics j4 (x 2, offset -0.1), so j5 = -j2 + 0.5."""
    joints = [
        joint("j1", "revolute", "base", "l1", "0 0 0.3", "0 0 1"),
        joint("j2", "revolute", "l1", "l2", "0.05 0 0.1", "0 1 0"),
        joint("j3", "continuous", "l2", "l3", "0.3 0.02 0", "0 1 0"),
        joint("j4", "revolute", "l3", "l4", "0.25 0 0", "1 0 0", mimic=("j2", -0.5, 0.3)),
        joint("j5", "revolute", "l4", "l5", "0.1 0.03 0.02", "0 0 1", rpy="0.3 0 0", mimic=("j4", 2, -0.1)),
    ]
    return write(tmp_path, "revolute_mimic", joints, ["base", "l1", "l2", "l3", "l4", "l5"])


# the coupling of each robot, written from the URDF text above: joint -> (independent joint, m, o)
COUPLINGS = {
    "gripper_arm": (["j1", "j2", "j3", "finger_left", "finger_right"], {"finger_right": ("finger_left", 1.0, 0.0)}),
    "revolute_mimic": (["j1", "j2", "j3", "j4", "j5"], {"j4": ("j2", -0.5, 0.3), "j5": ("j2", -1.0, 0.5)}),
}


def coupling_matrix(name):
    """(G, o, independent joints) from COUPLINGS, joints in document (= chain) order."""
    joints, mimic = COUPLINGS[name]
    indep = [j for j in joints if j not in mimic]
    G, o = np.zeros((len(joints), len(indep))), np.zeros(len(joints))
    for k, j in enumerate(joints):
        master, m, off = mimic.get(j, (j, 1.0, 0.0))
        G[k, indep.index(master)], o[k] = m, off
    return G, o, indep


ROBOTS = {"gripper_arm": gripper_arm, "revolute_mimic": revolute_mimic_arm}


@pytest.mark.parametrize("name", sorted(ROBOTS))
@pytest.mark.parametrize("backend", ["numpy", "auto"])
def test_regressor_times_phi_is_lagrange_through_the_coupling(tmp_path, name, backend):
    _, chain = load_chain(ROBOTS[name](tmp_path), DeriveOptions())
    G, o, indep = coupling_matrix(name)
    assert chain.joint_names == tuple(COUPLINGS[name][0])
    assert chain.dof == len(indep)
    rng = np.random.default_rng(24)
    phi = rng.standard_normal(10 * chain.n)
    q = rng.uniform(-np.pi, np.pi, (3, chain.dof))
    qd, qdd = rng.standard_normal((2, 3, chain.dof))
    Y = regressor(chain, q, qd, qdd, backend=backend)
    assert Y.shape == (3, chain.dof, 10 * chain.n)
    for s in range(3):
        tau_joints = ref.inverse_dynamics(chain, phi, G @ q[s] + o, G @ qd[s], G @ qdd[s])
        tau_ref = G.T @ tau_joints
        assert np.linalg.norm(Y[s] @ phi - tau_ref) <= 1e-9 * np.linalg.norm(tau_ref)


@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_base_count_is_the_rank_of_the_projected_joint_regressor(tmp_path, name):
    """The count of derive = the singular-value rank of Gᵀ·Y_joints over random states, G from the test."""
    _, chain = load_chain(ROBOTS[name](tmp_path), DeriveOptions(friction=("viscous",)))
    G, o, _ = coupling_matrix(name)
    base = derive_qr(chain)
    rng = np.random.default_rng(7)
    q = rng.uniform(-np.pi, np.pi, (60, chain.dof))
    qd, qdd = rng.standard_normal((2, 60, chain.dof))
    Yj = joint_regressor(chain, *(np.ascontiguousarray(x) for x in (q @ G.T + o, qd @ G.T, qdd @ G.T)))
    W = np.matmul(G.T, Yj).reshape(-1, chain.layout.size)
    W = W * chain_scales(chain)[0]  # the same physical units as derive's cut
    sv = np.linalg.svd(W, compute_uv=False)
    assert base.n_base == int(np.sum(sv > 1e-8 * sv[0]))
    # the mimic joint's friction regroups with its master's (the same velocity, times m)
    names = [base.standard_names[c] for c in base.kept]
    assert sum(n.startswith("Fv") for n in names) == chain.dof


def test_base_count_against_pinocchio(tmp_path):
    pin = pytest.importorskip("pinocchio")
    import scipy.linalg

    for name, make in ROBOTS.items():
        path = make(tmp_path)
        _, chain = load_chain(path, DeriveOptions())
        model = pin.buildModelFromUrdf(str(path))  # every joint independent: the mimic tags are not read
        data = model.createData()
        G, o, _ = coupling_matrix(name)
        names = [model.names[i] for i in range(1, model.njoints)]
        order = [names.index(j) for j in COUPLINGS[name][0]]
        assert all(model.joints[i + 1].nv == 1 for i in range(len(names)))
        rng = np.random.default_rng(3)
        rows = []
        for _ in range(40):
            qi, vi, ai = rng.uniform(-np.pi, np.pi, G.shape[1]), rng.standard_normal(G.shape[1]), rng.standard_normal(G.shape[1])
            x = {}
            for k, j in enumerate(order):
                x[j] = (G[k] @ qi + o[k], G[k] @ vi, G[k] @ ai)
            q = pin.neutral(model)
            v, a = np.zeros(model.nv), np.zeros(model.nv)
            for j, (qq, vv, aa) in x.items():
                jm = model.joints[j + 1]
                if jm.nq == 2:  # continuous
                    q[jm.idx_q : jm.idx_q + 2] = np.cos(qq), np.sin(qq)
                else:
                    q[jm.idx_q] = qq
                v[jm.idx_v], a[jm.idx_v] = vv, aa
            Yp = pin.computeJointTorqueRegressor(model, data, q, v, a)
            rows.append(G.T @ Yp[[model.joints[j + 1].idx_v for j in order]])
        R = scipy.linalg.qr(np.vstack(rows), mode="r", pivoting=True)[0]
        r = np.abs(np.diagonal(R))
        assert derive_qr(chain).n_base == int(np.sum(r > 1e-8 * r[0])), name


def test_random_states_cover_the_independent_joints_only(tmp_path):
    _, chain = load_chain(gripper_arm(tmp_path), DeriveOptions())
    q, qd, qdd = random_states(chain, 50, sample_rng(0))
    assert q.shape == (50, 4)
    assert np.abs(q[:, 3]).max() <= chain.length_scale  # the finger is prismatic: within the robot's size
    assert stacked_regressor(chain, 5, sample_rng(0)).shape == (20, 50)


def test_mimic_fixed_equals_the_joint_written_as_fixed(tmp_path):
    """--mimic fixed freezes the mimic joint at its offset: the same as a fixed joint moved by it."""
    a = gripper_arm(tmp_path, finger_mimic=("finger_left", 1, 0.01), name="a")
    rep = derive_file(a, DeriveOptions(mimic="fixed"))
    # the right finger written as a fixed joint at the offset: 0.01 along its axis -y
    b = gripper_arm(tmp_path, name="b", right=joint("finger_right", "fixed", "hand", "right", "0 -0.01 0.0584", "0 -1 0"))
    ref_rep = derive_file(b, DeriveOptions())
    assert rep["dof"] == ref_rep["dof"] == 4 and rep["n_standard"] == 40
    assert [p["expression"] for p in rep["base_parameters"]] == [p["expression"] for p in ref_rep["base_parameters"]]
    coupled = derive_file(a, DeriveOptions())
    assert coupled["dof"] == 4 and coupled["n_standard"] == 50 and coupled["links"][4]["mimic"] == {"joint": "finger_left", "multiplier": 1.0, "offset": 0.01}


def test_cli_derive_names_the_mimic_joints_and_accepts_mimic_fixed(tmp_path):
    path = revolute_mimic_arm(tmp_path)
    r = CliRunner().invoke(app, ["derive", str(path)])
    assert r.exit_code == 0, r.output
    assert "j4 = -0.5·j2 + 0.3; j5 = -j2 + 0.5" in r.output
    r = CliRunner().invoke(app, ["derive", str(path), "--mimic", "fixed", "-f", "json"])
    assert r.exit_code == 0, r.output
    assert '"dof": 3' in r.output and '"n_standard": 30' in r.output
    r = CliRunner().invoke(app, ["derive", str(path), "--mimic", "free"])
    assert r.exit_code == 2 and "'free' is not one of 'coupled', 'fixed'" in r.output


def test_projection_refuses_mimic_joints_in_one_line(tmp_path):
    path = gripper_arm(tmp_path)
    with pytest.raises(UnsupportedError, match="mimic joints"):
        derive_file(path, DeriveOptions(method="projection"))
    r = CliRunner().invoke(app, ["derive", str(path), "--method", "projection"])
    assert r.exit_code == 2
    assert r.stderr.count("\n") == 1 and "use --method qr" in r.stderr


@pytest.mark.parametrize(
    "mimic, message",
    [
        (("nowhere", 1, 0), "mimic joint 'nowhere' is not defined"),
        (("finger_right", 1, 0), "a joint cannot mimic itself"),
        (("hand", 1, 0), "mimic joint 'hand' is a fixed joint"),
        (("finger_left", "two", 0), "expected a number, got 'two'"),
        (("finger_left", 1, "nan"), "expected a finite number"),
    ],
)
def test_bad_mimic_is_one_line_exit_2(tmp_path, mimic, message):
    path = gripper_arm(tmp_path, finger_mimic=mimic)
    with pytest.raises(DescriptionError, match="joint\\[finger_right\\]/mimic"):
        load_chain(path, DeriveOptions())
    r = CliRunner().invoke(app, ["derive", str(path)])
    assert r.exit_code == 2 and message in r.stderr and r.stderr.count("\n") == 1


def test_mimic_loop_is_refused(tmp_path):
    joints = [
        joint("j1", "revolute", "base", "l1", "0 0 0.3", "0 0 1"),
        joint("j2", "revolute", "l1", "l2", "0.1 0 0", "0 1 0", mimic=("j3", 1, 0)),
        joint("j3", "revolute", "l2", "l3", "0.1 0 0", "0 1 0", mimic=("j2", 1, 0)),
    ]
    path = write(tmp_path, "loop", joints, ["base", "l1", "l2", "l3"])
    with pytest.raises(DescriptionError, match="mimic joints form a loop: j2 -> j3 -> j2"):
        load_chain(path, DeriveOptions())


@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_simulate_and_identify_treat_mimic_joints_as_driven_by_their_master(tmp_path, name):
    """Data files carry the independent joints only; identify recovers the model from data made
    through the coupling: no effect, the test error at the noise floor, and the torques that a
    Newton–Euler of every joint pushed through G would give."""
    import json

    path = ROBOTS[name](tmp_path)
    chain = load_chain(path, DeriveOptions())[1]
    data = tmp_path / "d.csv"
    r = CliRunner().invoke(app, ["simulate", str(path), "--noise", "0.001", "--seed", "2", "-o", str(data), "-q"])
    assert r.exit_code == 0, r.output
    header = data.read_text().splitlines()[0].split(",")
    assert [h for h in header if h.startswith("q")] == [f"q{k}" for k in range(1, chain.dof + 1)]
    r = CliRunner().invoke(app, ["identify", str(path), str(data), "--format", "json", "-q"])
    assert r.exit_code == 0, r.output
    rep = json.loads(r.output)
    assert rep["effects"] == [] and len(rep["before"]["rms_per_joint"]) == chain.dof
    assert rep["test"]["final"]["rms_total"] <= 1.5 * 0.001
    # the simulated torque is the Lagrange reference of every joint pushed through the coupling
    table = np.loadtxt(data, delimiter=",", skiprows=1, max_rows=50)
    d = chain.dof
    q, qd, qdd, tau = (table[:, 1 + k * d : 1 + (k + 1) * d] for k in range(4))
    G, o, _ = coupling_matrix(name)
    phi = np.asarray(chain.phi_nominal)
    expected = np.array([G.T @ ref.inverse_dynamics(chain, phi, G @ q[i] + o, G @ qd[i], G @ qdd[i]) for i in range(len(q))])
    assert np.max(np.abs(tau - expected)) < 0.01  # the noise is 0.001: 10 sigma


def test_mimic_fixed_data_have_the_free_joints_only_and_identify_takes_mimic_fixed(tmp_path):
    path = gripper_arm(tmp_path)
    data = tmp_path / "d.csv"
    r = CliRunner().invoke(app, ["simulate", str(path), "--duration", "2", "--mimic", "fixed", "-o", str(data), "-q"])
    assert r.exit_code == 0, r.output
    assert data.read_text().splitlines()[0] == "t,q1,q2,q3,q4,dq1,dq2,dq3,dq4,ddq1,ddq2,ddq3,ddq4,tau1,tau2,tau3,tau4"
    r = CliRunner().invoke(app, ["identify", str(path), str(data), "--mimic", "fixed", "--noise-free"][:-1] + ["-q", "-f", "json"])
    assert r.exit_code == 0, r.output
    import json

    rep = json.loads(r.output)
    assert rep["effects"] == [] and rep["test"]["final"]["relative_error"] < 1e-6  # noise-free data, same model


def test_a_mimic_tag_on_a_fixed_joint_moves_nothing(tmp_path):
    """Talos' reduced URDFs put <mimic> on fixed joints: both modes load them as plain fixed joints."""
    path = gripper_arm(tmp_path, right=joint("finger_right", "fixed", "hand", "right", "0 0 0.0584", "0 -1 0",
                                             mimic=("finger_left", 1, 0)))
    for mode in ("coupled", "fixed"):
        rep = derive_file(path, DeriveOptions(mimic=mode))
        assert rep["dof"] == 4 and rep["n_standard"] == 40
