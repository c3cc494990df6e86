"""minparam codegen: the generated C, NumPy and CasADi code against an independent inverse dynamics.

The identity checked at 100 random states per robot: Y_b(q, q̇, q̈)·(K φ) = τ(φ), with τ from
tests/reference_dynamics.py (Euler–Lagrange with complex-step derivatives, its own kinematics)
plus the declared extras written out by hand (Ia q̈ + Fc sign q̇ + Fv q̇ + OFF), for random
standard parameters φ.  The C output is compiled with the system compiler and called through
ctypes.
"""

from __future__ import annotations

import ctypes
import importlib.util
import json
import re
import shutil
import subprocess
import sys

import numpy as np
import pytest
import reference_dynamics as ref
from conftest import ROOT, refused
from typer.testing import CliRunner

from minparam_cli.cli.app import app

CC = shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")
needs_cc = pytest.mark.skipif(CC is None, reason="no C compiler (cc, gcc or clang) on PATH: the C output cannot be compiled here")
EXTRAS = ["--friction", "coulomb,viscous,offset", "--rotor-inertia"]
STATES = 100
ROBOT_KEYS = ["puma560", "panda", "ur5_urdf", "branched_urdf", "stanford_prismatic", "tx40_transmission"]
FULL_KEYS = ("panda", "branched_urdf")
SEED = 20261125  # the random states and parameters of every test below


def cli(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def branched_urdf(path):
    """A tree: a waist carrying two arms, one with a prismatic joint, axes along and across."""

    def link(n, x):
        return (f'<link name="{n}"><inertial><mass value="1.5"/><origin xyz="{x} 0.02 -0.01"/>'
                f'<inertia ixx="0.02" ixy="0.001" ixz="0" iyy="0.03" iyz="0" izz="0.04"/></inertial></link>\n')

    def joint(n, kind, parent, child, xyz, axis, rpy):
        return (f'<joint name="{n}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
                f'<origin xyz="{xyz}" rpy="{rpy}"/><axis xyz="{axis}"/>'
                f'<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>\n')

    body = '<link name="world"/>\n' + "".join(link(n, 0.05 * (i + 1)) for i, n in enumerate(("torso", "l1", "l2", "r1", "r2")))
    body += joint("waist", "revolute", "world", "torso", "0 0 0.5", "0 0 1", "0 0 0")
    body += joint("l_sh", "revolute", "torso", "l1", "0 0.3 0.2", "0 1 0", "0.3 0 0")
    body += joint("l_el", "revolute", "l1", "l2", "0.3 0 0", "0.6 0 0.8", "0 0.2 0")
    body += joint("r_sh", "revolute", "torso", "r1", "0 -0.3 0.2", "1 0 0", "0 0 0")
    body += joint("r_slide", "prismatic", "r1", "r2", "0.25 0.05 0", "0 0 1", "0.1 0 0")
    path.write_text(f'<?xml version="1.0"?>\n<robot name="tree">\n{body}</robot>\n')
    return path


@pytest.fixture(scope="module")
def robots(tmp_path_factory):
    d = tmp_path_factory.mktemp("robots")
    return {
        "puma560": ROOT / "robots" / "puma560.yaml",
        "panda": ROOT / "robots" / "panda.yaml",
        "ur5_urdf": ROOT / "robots" / "ur5.urdf",
        "branched_urdf": branched_urdf(d / "tree.urdf"),
        "stanford_prismatic": ROOT / "robots" / "stanford.yaml",
        "tx40_transmission": ROOT / "robots" / "tx40.yaml",  # coupled wrist: motor 6 moves joints 5 and 6
    }


def _skew(x):
    """(N, 3) -> (N, 3, 3) with skew(x) y = x × y."""
    z = np.zeros(x.shape[:-1])
    return np.stack([np.stack([z, -x[..., 2], x[..., 1]], -1), np.stack([x[..., 2], z, -x[..., 0]], -1),
                     np.stack([-x[..., 1], x[..., 0], z], -1)], -2)


def _motion_transform(T):
    """Featherstone's X (N, 6, 6) taking motion vectors (ω; v) from frame A to frame B = A·T."""
    R, p = T[..., :3, :3], T[..., :3, 3]
    Rt = np.swapaxes(R, -1, -2)
    X = np.zeros(T.shape[:-2] + (6, 6))
    X[..., :3, :3] = Rt
    X[..., 3:, 3:] = Rt
    X[..., 3:, :3] = -Rt @ _skew(p)
    return X


def _cross_motion(v):
    X = np.zeros(v.shape[:-1] + (6, 6))
    X[..., :3, :3] = _skew(v[..., :3])
    X[..., 3:, 3:] = _skew(v[..., :3])
    X[..., 3:, :3] = _skew(v[..., 3:])
    return X


def newton_euler(chain, phi, q, qd, qdd):
    """τ (N, n) by the textbook recursive Newton–Euler in joint frames (Featherstone 2008, RNEA),
    from the chain's per-joint Pre · Motion(q) · Post and axes only: frames sit on the joint
    axis, the link's 6x6 inertia is moved there by Post (I_J = Xᵀ I_F X).  Nothing here calls the
    package's regressor or kinematics."""
    N, n = q.shape
    v, a, f, X = [None] * n, [None] * n, [None] * n, [None] * n
    for j in range(n):
        ax = chain.axes[j]
        S = np.concatenate([ax, np.zeros(3)]) if chain.types[j] == "revolute" else np.concatenate([np.zeros(3), ax])
        M = np.tile(np.eye(4), (N, 1, 1))
        if chain.types[j] == "revolute":
            K = _skew(ax[None])[0]
            M[:, :3, :3] = np.eye(3) + np.sin(q[:, j, None, None]) * K + (1 - np.cos(q[:, j, None, None])) * (K @ K)
        else:
            M[:, :3, 3] = q[:, j, None] * ax
        p = chain.parents[j]
        T = (chain.pre[j] if p < 0 else chain.post[p] @ chain.pre[j]) @ M
        X[j] = _motion_transform(T)
        vp = np.zeros((N, 6)) if p < 0 else v[p]
        ap = np.tile(np.concatenate([np.zeros(3), -chain.gravity]), (N, 1)) if p < 0 else a[p]
        v[j] = np.einsum("nij,nj->ni", X[j], vp) + S * qd[:, j, None]
        a[j] = np.einsum("nij,nj->ni", X[j], ap) + S * qdd[:, j, None] + np.einsum("nij,j->ni", _cross_motion(v[j]), S) * qd[:, j, None]
        XX, XY, XZ, YY, YZ, ZZ, MX, MY, MZ, m = phi[10 * j : 10 * j + 10]
        IF = np.zeros((6, 6))
        IF[:3, :3] = [[XX, XY, XZ], [XY, YY, YZ], [XZ, YZ, ZZ]]
        IF[:3, 3:] = _skew(np.array([MX, MY, MZ]))
        IF[3:, :3] = -IF[:3, 3:]
        IF[3:, 3:] = m * np.eye(3)
        Xp = _motion_transform(chain.post[j][None])[0]
        IJ = Xp.T @ IF @ Xp
        Iv = v[j] @ IJ.T
        f[j] = a[j] @ IJ.T - np.einsum("nji,nj->ni", _cross_motion(v[j]), Iv)  # v ×* (I v) = −(v ×)ᵀ (I v)
    tau = np.zeros((N, n))
    for j in reversed(range(n)):
        ax = chain.axes[j]
        S = np.concatenate([ax, np.zeros(3)]) if chain.types[j] == "revolute" else np.concatenate([np.zeros(3), ax])
        tau[:, j] = f[j] @ S
        p = chain.parents[j]
        if p >= 0:
            f[p] = f[p] + np.einsum("nji,nj->ni", X[j], f[j])
    return tau


def reference_torques(chain, phi, q, qd, qdd):
    """Independent τ: Newton–Euler for the links, the extras written out from their definitions."""
    n = chain.n
    tau = newton_euler(chain, phi[: 10 * n], q, qd, qdd)
    names = chain.layout.names
    for k in range(n):
        j = k + 1
        for name, signal in ((f"Ia{j}", qdd[:, k]), (f"Fc{j}", np.sign(qd[:, k])), (f"Fv{j}", qd[:, k]), (f"OFF{j}", 1.0)):
            if name in names:
                tau[:, k] += phi[names.index(name)] * signal
    if chain.transmission is not None:  # motor k's torque f_k on its shaft reaches the joints as Nᵀ e_k f_k
        N = np.asarray(chain.transmission.matrix, dtype=float)
        rate, accel = qd @ N.T, qdd @ N.T  # θ̇_m = N q̇, θ̈_m = N q̈
        for k in range(N.shape[0]):
            j = k + 1
            for name, signal in ((f"Iam{j}", accel[:, k]), (f"Fcm{j}", np.sign(rate[:, k])), (f"Fvm{j}", rate[:, k])):
                if name in names:
                    tau += phi[names.index(name)] * signal[:, None] * N[k][None, :]
    return tau


@pytest.fixture(scope="module")
def cases(robots):
    """Per robot: chain, base set, random states, random φ and the reference torques."""
    from minparam_cli.base.qr import derive_qr
    from minparam_cli.robot import DeriveOptions, load_chain

    out = {}
    rng = np.random.default_rng(SEED)
    for key, path in robots.items():
        _, chain = load_chain(path, DeriveOptions(friction=("coulomb", "viscous", "offset"), rotor_inertia=True))
        base = derive_qr(chain)
        n = chain.n
        q = rng.uniform(-np.pi, np.pi, (STATES, n))
        pris = ~chain.revolute
        q[:, pris] = rng.uniform(-0.5, 0.5, (STATES, int(pris.sum())))
        qd, qdd = rng.standard_normal((2, STATES, n))
        phi = rng.standard_normal(chain.layout.size)
        tau = reference_torques(chain, phi, q, qd, qdd)
        out[key] = (path, chain, base, q, qd, qdd, phi, tau)
    return out


@pytest.mark.parametrize("key", ROBOT_KEYS)
def test_the_test_newton_euler_is_the_euler_lagrange_reference(cases, key):
    """The reference above agrees with tests/reference_dynamics.py (Euler–Lagrange, complex step)."""
    _, chain, _, q, qd, qdd, phi, _ = cases[key]
    n = chain.n
    tau = newton_euler(chain, phi[: 10 * n], q[:2], qd[:2], qdd[:2])
    for s in range(2):
        tau_ref = ref.inverse_dynamics(chain, phi[: 10 * n], q[s], qd[s], qdd[s])
        assert np.linalg.norm(tau[s] - tau_ref) <= 1e-11 * np.linalg.norm(tau_ref)


def assert_identity(Yb, base, phi, tau, what):
    """Y_b·(Kφ) = τ to 1e-12 relative over the 100 states (‖error‖ / ‖τ‖, every state's joints).

    derive rounds the regrouping coefficients β to 12 significant digits (base/result.py,
    BETA_DIGITS), so on a geometry with irrational β (the branched URDF's tilted axes) K φ itself
    carries ~1e-13 relative error, and a state whose torque nearly cancels can show 1e-12; the
    full regressor (no K) is checked state by state at 1e-13 in the C test."""
    pred = Yb @ (base.K @ phi)
    err = np.linalg.norm(pred - tau) / np.linalg.norm(tau)
    assert err <= 1e-12, f"{what}: relative error {err:.3g}"


def import_file(path, name):
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def compile_shared(c_file, so):
    """Compile as strict C99 with every warning an error (-O0: the tests check numbers, not speed; compiling is the slow part)."""
    cmd = [CC, "-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror", "-O0", "-shared", "-fPIC", "-o", str(so), str(c_file), "-lm"]
    r = subprocess.run(cmd, capture_output=True, text=True, check=False)
    assert r.returncode == 0, r.stderr[-2000:]
    return ctypes.CDLL(str(so))


def call_c(fn, q, qd, qdd, size):
    P = ctypes.POINTER(ctypes.c_double)
    out = np.zeros((len(q), size))
    for s in range(len(q)):
        args = [np.ascontiguousarray(x[s], dtype=float) for x in (q, qd, qdd)]
        fn(*(a.ctypes.data_as(P) for a in args), out[s].ctypes.data_as(P))
    return out




@needs_cc
@pytest.mark.parametrize("key", ROBOT_KEYS)
def test_c_base_regressor_times_base_parameters_is_newton_euler(cases, key, tmp_path):
    path, chain, base, q, qd, qdd, phi, tau = cases[key]
    full = key in FULL_KEYS  # the full regressor doubles the code to compile: two robots show it
    r = cli("codegen", path, "--lang", "c", "-o", tmp_path / "gen.c", *EXTRAS, *(["--full"] if full else []))
    assert r.exit_code == 0, r.output
    lib = compile_shared(tmp_path / "gen.c", tmp_path / "gen.so")
    dof, nb = chain.dof, base.n_base
    Yb = call_c(lib.gen_base_regressor, q, qd, qdd, dof * nb).reshape(-1, dof, nb)
    assert_identity(Yb, base, phi, tau, f"{key} C")
    if not full:
        return
    # the full regressor and K written beside it: Y·φ = τ, K as derive's
    Y = call_c(lib.gen_regressor, q, qd, qdd, dof * base.n_standard).reshape(-1, dof, base.n_standard)
    err = np.linalg.norm(np.einsum("nkp,p->nk", Y, phi) - tau, axis=1) / np.linalg.norm(tau, axis=1)
    assert err.max() <= 1e-13, f"{key} C full regressor: largest relative error {err.max():.3g}"
    K = np.ctypeslib.as_array((ctypes.c_double * base.K.size).in_dll(lib, "gen_K")).reshape(base.K.shape)
    assert np.array_equal(K, base.K)


@pytest.mark.parametrize("key", ROBOT_KEYS)
def test_python_base_regressor_times_base_parameters_is_newton_euler(cases, key, tmp_path):
    path, chain, base, q, qd, qdd, phi, tau = cases[key]
    r = cli("codegen", path, "--lang", "python", "-o", tmp_path / "gen.py", *EXTRAS)
    assert r.exit_code == 0, r.output
    mod = import_file(tmp_path / "gen.py", f"gen_{key}")
    Yb = mod.base_regressor(q, qd, qdd)  # vectorised: every state at once
    assert Yb.shape == (STATES, chain.dof, base.n_base)
    assert_identity(Yb, base, phi, tau, f"{key} NumPy")
    assert np.array_equal(mod.base_regressor(q[0], qd[0], qdd[0]), Yb[0])  # one state: (dof, n_base)
    assert mod.BASE_NAMES == base.base_names


@pytest.mark.parametrize("key", ["branched_urdf", "stanford_prismatic"])
def test_casadi_base_regressor_times_base_parameters_is_newton_euler(cases, key, tmp_path):
    pytest.importorskip("casadi", reason="casadi is the optional extra minparam[casadi]")
    path, _, base, q, qd, qdd, phi, tau = cases[key]
    r = cli("codegen", path, "--lang", "casadi", "-o", tmp_path / "gen_ca.py", *EXTRAS)
    assert r.exit_code == 0, r.output
    mod = import_file(tmp_path / "gen_ca.py", f"gen_ca_{key}")
    Yb = np.array([mod.base_regressor(q[s], qd[s], qdd[s]).full() for s in range(STATES)])
    assert_identity(Yb, base, phi, tau, f"{key} CasADi")


def test_mimic_joints_give_the_generalized_forces(tmp_path):
    """A URDF whose right finger mimics the left: the rows are Gᵀ τ_joints at q_joint = G q + offset."""
    import test_mimic

    from minparam_cli.base.qr import derive_qr
    from minparam_cli.robot import DeriveOptions, load_chain

    path = test_mimic.gripper_arm(tmp_path)
    _, chain = load_chain(path, DeriveOptions())
    assert chain.coupling is not None
    base = derive_qr(chain)
    r = cli("codegen", path, "--lang", "python", "-o", tmp_path / "grip.py")
    assert r.exit_code == 0, r.output
    rng = np.random.default_rng(SEED + 3)
    q = rng.uniform(-1, 1, (STATES, chain.dof)) * 0.05
    qd, qdd = rng.standard_normal((2, STATES, chain.dof))
    phi = rng.standard_normal(chain.layout.size)
    G, off = chain.coupling.G, chain.coupling.offset
    tau = newton_euler(chain, phi, q @ G.T + off, qd @ G.T, qdd @ G.T) @ G
    Yb = import_file(tmp_path / "grip.py", "grip").base_regressor(q, qd, qdd)
    assert_identity(Yb, base, phi, tau, "mimic NumPy")


@pytest.mark.parametrize("key", ["branched_urdf", "stanford_prismatic", "mimic"])
def test_the_torque_program_is_the_regressor_times_parameters(cases, key, tmp_path):
    """codegen.programs.torque (what inverse_dynamics is made of: each link's wrench K_j φ_j once)
    equals the recorded regressor times φ, extras and mimic coupling included."""
    import test_mimic

    from minparam_cli.codegen.programs import record_regressor, torque
    from minparam_cli.codegen.trace import evaluate
    from minparam_cli.robot import DeriveOptions, load_chain

    if key == "mimic":
        _, chain = load_chain(test_mimic.gripper_arm(tmp_path), DeriveOptions(friction=("viscous", "offset"), rotor_inertia=True))
        rng = np.random.default_rng(SEED + 5)
        q = rng.uniform(-0.05, 0.05, (STATES, chain.dof))
        qd, qdd = rng.standard_normal((2, STATES, chain.dof))
        phi = rng.standard_normal(chain.layout.size)
    else:
        _, chain, _, q, qd, qdd, phi, _ = cases[key]
    rec = record_regressor(chain)
    tau = np.array(evaluate(rec.prog, torque(rec, phi), {"q": q, "qd": qd, "qdd": qdd}, np)).T
    Y = np.array([np.broadcast_to(v, (STATES,)) for v in evaluate(rec.prog, [x for row in rec.Y for x in row],
                                                                   {"q": q, "qd": qd, "qdd": qdd}, np)])
    expected = np.einsum("kpn,p->nk", Y.reshape(chain.dof, chain.layout.size, STATES), phi)
    assert np.linalg.norm(tau - expected) <= 1e-13 * np.linalg.norm(expected)


def test_names_and_order_are_derives(robots, tmp_path):
    path = robots["ur5_urdf"]
    r = cli("derive", path, "--format", "json", "--friction", "viscous", "--seed", "3")
    assert r.exit_code == 0, r.output
    names = tuple(p["name"] for p in json.loads(r.stdout)["base_parameters"])
    r = cli("codegen", path, "--lang", "python", "-o", tmp_path / "g.py", "--friction", "viscous", "--seed", "3")
    assert r.exit_code == 0, r.output
    assert import_file(tmp_path / "g.py", "g_names").BASE_NAMES == names
    text = (tmp_path / "g.py").read_text()
    assert "--seed 3" in text and "sha256 " in text and "Base parameters (beta_b = K * phi)" in text
    scara = ROOT / "robots" / "scara.yaml"  # and the projection route's
    r = cli("derive", scara, "--format", "json", "--method", "projection")
    assert r.exit_code == 0, r.output
    names = tuple(p["name"] for p in json.loads(r.stdout)["base_parameters"])
    r = cli("codegen", scara, "--lang", "python", "-o", tmp_path / "s.py", "--method", "projection")
    assert r.exit_code == 0, r.output
    assert import_file(tmp_path / "s.py", "s_names").BASE_NAMES == names


@needs_cc
def test_c_output_is_self_contained(robots, tmp_path):
    """One header, one source; only math.h and its own header included; no allocation, no static state."""
    r = cli("codegen", robots["puma560"], "--lang", "c", "-o", tmp_path / "puma.c", "--name", "pm")
    assert r.exit_code == 0, r.output
    src, hdr = (tmp_path / "puma.c").read_text(), (tmp_path / "puma.h").read_text()
    assert re.findall(r"#include\s*\S+", src) == ['#include "puma.h"', "#include <math.h>"]
    assert not re.findall(r"#include", hdr)
    for word in ("malloc", "calloc", "realloc", "free(", "static "):
        assert word not in src, word
    assert "void pm_base_regressor(const double q[PM_DOF]" in hdr
    assert "robots/puma560.yaml" in hdr and "sha256" in hdr and "minparam codegen" in hdr


@needs_cc
def test_a_regressor_that_reads_only_qdd_compiles_strictly(tmp_path):
    """One vertical revolute joint under vertical gravity: Y_b = [q̈] (ZZR1); q and q̇ unused, and the
    C still compiles with -Wall -Wextra -Werror."""
    robot = tmp_path / "turntable.yaml"
    robot.write_text("name: turntable\nconvention: dh\nunits: {length: m, angle: deg}\ngravity: [0, 0, -9.81]\n"
                     "joints:\n  - {name: j1, type: revolute, alpha: 0, a: 0.3, d: 0.1, theta: 0}\n")
    r = cli("codegen", robot, "--lang", "c", "-o", tmp_path / "tt.c")
    assert r.exit_code == 0, r.output
    lib = compile_shared(tmp_path / "tt.c", tmp_path / "tt.so")
    rng = np.random.default_rng(SEED + 4)
    q, qd, qdd = rng.standard_normal((3, 5, 1))
    assert np.array_equal(call_c(lib.tt_base_regressor, q, qd, qdd, 1), qdd)


def test_operation_counts_are_printed_and_generation_is_quick(robots, tmp_path):
    r = cli("codegen", robots["panda"], "--lang", "python", "-o", tmp_path / "p.py")
    assert r.exit_code == 0, r.output
    m = re.search(r"base_regressor: (\d+) multiplications, (\d+) additions", r.output)
    assert m and int(m.group(1)) > 0 and int(m.group(2)) > 0, r.output
    assert f"base_regressor: {m.group(1)} multiplications" in (tmp_path / "p.py").read_text()


def test_unknown_language_is_one_line_exit_2(robots, tmp_path):
    refused("codegen", robots["puma560"], "--lang", "fortran", "-o", tmp_path / "x.f", needle="fortran")


def test_c_to_stdout_is_refused(robots):
    refused("codegen", robots["puma560"], "--lang", "c", needle="two files")


# --- the identified model: τ = Y_b θ_b + effects ---------------------------------------------------------

MODEL_ROBOT = ROOT / "robots" / "puma560_mdh.yaml"


def saved_model_file(tmp_path, robot, smoothing):
    """A model file as identify --save-model writes it (random θ, every effect with a code form, a drift)."""
    from minparam_cli.base.qr import derive_qr
    from minparam_cli.measured.records import DataOptions
    from minparam_cli.identify.passes.design import Design, Term
    from minparam_cli.model.file import LoadSettings, SavedModel, dumps, sha256_hex
    from minparam_cli.robot import load_chain

    load = LoadSettings(friction=("viscous",), coulomb_smoothing=smoothing)
    _, chain = load_chain(robot, load.derive_options(0))
    chain = chain.with_coulomb_smoothing(smoothing)
    base = derive_qr(chain, seed=0)
    terms = (Term("coulomb", (0, 1)), Term("stribeck", (2,), 0.05), Term("asymmetric_coulomb", (3,)),
             Term("spring", (1,)), Term("cogging", (4,), 6.0), Term("gain", (5,)), Term("load_coulomb", (2,)),
             Term("offset", (0,)), Term("drift", (1,)), Term("gravity_error", (3,)), Term("position_error", (5,), 2.0),
             Term("spring_v1", (4,)))
    # the evidence saved with each term (identify's diagnosis): one named, one not, the others unknown
    evidence = ({"named": True, "delta_bic_eff": -25.0, "n_eff": 40.0},
                {"named": False, "delta_bic_eff": 3.0, "n_eff": 41.0}) + (None,) * (len(terms) - 2)
    rng = np.random.default_rng(SEED + 1)
    theta_model = rng.standard_normal(base.n_base)
    design = Design(chain, base.kept, base.base_names, terms, theta_model, 0.0)
    theta = rng.standard_normal(design.p)
    m = SavedModel(str(robot), sha256_hex(robot.read_bytes()), load, 0, tuple(base.kept), tuple(base.base_names), terms,
                   theta_model, 0.0, design.names, theta, (None,) * design.p, DataOptions(), evidence=evidence)
    path = tmp_path / f"model_{smoothing}.json"
    path.write_text(dumps(m))
    return path, design, theta


def model_reference(design, theta, q, qd, qdd):
    """τ by identify's own design matrix, the drift column left out (its time is not a state)."""
    from minparam_cli.measured.records import Block

    t = np.zeros(len(q))  # drift column t − t0 = 0: the generated code leaves the drift out
    X = design.columns(Block(t, q, qd, qdd, np.zeros_like(q)))
    return X @ theta


@pytest.mark.parametrize("smoothing", [0.0, 0.05], ids=["sign", "tanh"])
def test_inverse_dynamics_of_a_saved_model_is_identifys_prediction(tmp_path, smoothing):
    model, design, theta = saved_model_file(tmp_path, MODEL_ROBOT, smoothing)
    r = cli("codegen", MODEL_ROBOT, "--model", model, "--lang", "python", "-o", tmp_path / "m.py")
    assert r.exit_code == 0, r.output
    assert "left out of inverse_dynamics: drift (joint 2)" in r.output
    text = (tmp_path / "m.py").read_text()  # each effect named as saved, with its evidence
    assert "Effect coulomb (joints 1,2): delta BIC_eff -25.0 (N_eff 40)" in text
    assert "Effect stribeck (joint 3, vs=0.05): a model error of this form, not named" in text
    assert "Effect position_error (joint 6, k=2): no evidence recorded" in text
    mod = import_file(tmp_path / "m.py", f"m_{int(smoothing * 100)}")
    rng = np.random.default_rng(SEED + 2)
    q = rng.uniform(-np.pi, np.pi, (STATES, 6))
    qd, qdd = rng.standard_normal((2, STATES, 6))
    expected = model_reference(design, theta, q, qd, qdd)
    tau = mod.inverse_dynamics(q, qd, qdd)
    assert np.linalg.norm(tau - expected, axis=1).max() <= 1e-12 * np.linalg.norm(expected, axis=1).min()
    if CC is not None and smoothing == 0.0:  # the C of one model: the emitters share the program
        r = cli("codegen", MODEL_ROBOT, "--model", model, "--lang", "c", "-o", tmp_path / "m.c")
        assert r.exit_code == 0, r.output
        lib = compile_shared(tmp_path / "m.c", tmp_path / "m.so")
        tau_c = call_c(lib.m_inverse_dynamics, q, qd, qdd, 6)
        assert np.linalg.norm(tau_c - expected, axis=1).max() <= 1e-12 * np.linalg.norm(expected, axis=1).min()


def test_model_of_another_robot_file_is_refused(tmp_path):
    model, _, _ = saved_model_file(tmp_path, MODEL_ROBOT, 0.0)
    other = tmp_path / "puma_changed.yaml"
    other.write_text(MODEL_ROBOT.read_text() + "\n# edited\n")
    refused("codegen", other, "--model", model, "--lang", "python", needle="was made for")


@needs_cc
def test_the_documented_c_example_compiles_and_prints_the_regressor(tmp_path):
    """docs/commands/codegen.md's C example, compiled against the generated PUMA code, prints
    what the generated NumPy code computes at the same state."""
    doc = (ROOT / "docs" / "commands" / "codegen.md").read_text()
    example = re.search(r"\$ cat > main.c <<'EOF'\n(#include <stdio.h>.*?\n)EOF\n", doc, re.DOTALL).group(1)
    puma = ROOT / "robots" / "puma560.yaml"
    for lang, out in (("c", tmp_path / "puma.c"), ("python", tmp_path / "puma_np.py")):
        r = cli("codegen", puma, "--lang", lang, "-o", out)
        assert r.exit_code == 0, r.output
    (tmp_path / "main.c").write_text(example)
    exe = tmp_path / "main"
    r = subprocess.run([CC, "-std=c99", "-Wall", "-Werror", "-O0", "-o", str(exe), str(tmp_path / "main.c"),
                        str(tmp_path / "puma.c"), "-lm"], capture_output=True, text=True, cwd=tmp_path, check=False)
    assert r.returncode == 0, r.stderr[-2000:]
    printed = subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout
    values = [float(x) for x in re.findall(r"=\s*(\S+)", printed)]
    mod = import_file(tmp_path / "puma_np.py", "puma_doc")
    q = np.array([0.1, -0.4, 0.3, 0.2, -0.5, 0.6])
    Yb = mod.base_regressor(q, np.full(6, 0.5), np.ones(6))
    assert np.allclose(values, Yb[1], rtol=1e-9, atol=1e-12), (printed, Yb[1])


if __name__ == "__main__":  # pragma: no cover
    sys.exit(pytest.main([__file__, "-q"]))
