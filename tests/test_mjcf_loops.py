"""MJCF connect/weld equalities as closed chains (issue 35 points 1 and 3): the MJCF versions of the
parallelogram arm and the 3-RRR give the YAML versions' base sets, and minparam's actuated torques
τ_a = Gᵀ·Y_tree·φ equal MuJoCo's own inverse dynamics with the equality constraints, projected on the
tangent space MuJoCo's constraint Jacobian defines (G from MuJoCo's efc_J, not from minparam)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

from minparam_cli.api.options.derive import DeriveOptions  # noqa: E402
from minparam_cli.loops.derive import actuated_regressor, derive_closed  # noqa: E402
from minparam_cli.loops.model import closed_model  # noqa: E402
from minparam_cli.loops.sample import manifold_states  # noqa: E402
from minparam_cli.robot import load_chain  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data" / "mjcf"
ARM_XML, RRR_XML = DATA / "parallelogram_arm.xml", DATA / "planar_3rrr.xml"
ARM_YAML, RRR_YAML = ROOT / "robots" / "parallelogram_arm.yaml", ROOT / "robots" / "planar_3rrr.yaml"
# the parallelogram's rod ends in a pin (a hinge about y, light) welded to the forearm: 6 tree joints,
# a weld whose planar rank is 3, mobility 3 as before
PIN = ('<body name="pin" pos="0 0 1"><joint name="q5" axis="0 1 0"/><inertial pos="0.01 0 0" mass="0.2" diaginertia="1e-3 1e-3 1e-3"/>'
       '<site name="pin_s" euler="0 30 0"/></body>')


def test_enum_values_match_mujoco():
    from minparam_cli.describe import mjcf_geometry, mjcf_loops

    assert mjcf_loops.OBJ_SITE == int(mujoco.mjtObj.mjOBJ_SITE)
    assert (mjcf_loops.TRN_JOINT, mjcf_loops.TRN_JOINTINPARENT) == (int(mujoco.mjtTrn.mjTRN_JOINT), int(mujoco.mjtTrn.mjTRN_JOINTINPARENT))
    assert (mjcf_geometry.GEOM_PLANE, mjcf_geometry.GEOM_HFIELD) == (int(mujoco.mjtGeom.mjGEOM_PLANE), int(mujoco.mjtGeom.mjGEOM_HFIELD))


def _pin_variant(tmp_path: Path, weld: str) -> Path:
    text = ARM_XML.read_text()
    text = text.replace('<geom type="capsule" fromto="0 0 0 0 0 1" size="0.02"/>', '<geom type="capsule" fromto="0 0 0 0 0 1" size="0.02"/>' + PIN)
    text = text.replace('<geom type="capsule" fromto="-0.3 0 0 1.2 0 0"/>', '<geom type="capsule" fromto="-0.3 0 0 1.2 0 0"/><site name="fore_s" pos="-0.3 0 0" euler="0 30 0"/>')
    text = re.sub(r"<connect [^>]*/>", weld, text)
    p = tmp_path / "pin_weld.xml"
    p.write_text(text)
    return p


def _derive(path):
    desc, chain = load_chain(path, DeriveOptions().stage(), loops=True)
    return chain, derive_closed(desc, chain, samples=60, seed=0)


def _keyed(chain, base):
    """Each standard parameter as (kind, joint name): the two files number their joints differently."""
    out = []
    for name in base.standard_names:
        kind, num = re.fullmatch(r"([A-Za-z]+?)(\d+)", name).groups()
        out.append((kind, chain.joint_names[int(num) - 1]))
    return out


def test_parallelogram_mjcf_gives_the_yaml_base_set():
    (cx, bx), (cy, by) = _derive(ARM_XML), _derive(ARM_YAML)
    assert cx.joint_names == cy.joint_names
    assert bx.kept_names == by.kept_names and bx.unidentifiable_names == by.unidentifiable_names and len(bx.kept) == 18
    assert np.allclose(bx.K, by.K, rtol=1e-9, atol=1e-9)


def test_3rrr_mjcf_spans_the_yaml_base_set():
    """MuJoCo numbers the platform right after leg 1 (the YAML lists it last): the same count and the
    same identifiable combinations, the parameters matched by joint name."""
    (cx, bx), (cy, by) = _derive(RRR_XML), _derive(RRR_YAML)
    assert len(bx.kept) == len(by.kept) == 19
    kx, ky = _keyed(cx, bx), _keyed(cy, by)
    assert sorted(kx) == sorted(ky)
    Ky = by.K[:, [ky.index(k) for k in kx]]  # the YAML's K in the MJCF's column order
    r = np.linalg.matrix_rank
    assert r(np.vstack([bx.K, Ky]), tol=1e-6) == r(bx.K, tol=1e-6) == 19
    assert {kx[i] for i in bx.unidentifiable} == {ky[i] for i in by.unidentifiable}


def _mujoco_check(path: Path, samples: int = 12, seed: int = 3):
    desc, chain = load_chain(path, DeriveOptions().stage(), loops=True)
    model = closed_model(desc, chain)
    q, qd, qdd, G = manifold_states(model, samples, seed)
    tau = actuated_regressor(model, q, qd, qdd, G)[:, :, : chain.layout.n_inertial] @ chain.phi_nominal[: chain.layout.n_inertial]
    m = mujoco.MjModel.from_xml_path(str(path))
    m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
    m.opt.jacobian = int(mujoco.mjtJacobian.mjJAC_DENSE)
    m.dof_damping[:] = 0.0  # the inertial part is compared (the friction columns are minparam's own)
    m.dof_frictionloss[:] = 0.0
    d = mujoco.MjData(m)
    dof = [int(m.joint(j.name).dofadr[0]) for j in desc.joints]
    qpos_of = [int(m.joint(j.name).qposadr[0]) for j in desc.joints]
    a = [dof[k] for k in model.actuated]
    p = [i for i in range(m.nv) if i not in a]
    L = chain.length_scale

    def state(qs, vs):
        d.qpos[qpos_of], d.qvel[dof] = qs, vs
        mujoco.mj_forward(m, d)
        eq = d.efc_type == int(mujoco.mjtConstraint.mjCNSTR_EQUALITY)
        return d.efc_J.reshape(d.nefc, m.nv)[eq].copy(), d.efc_pos[eq].copy()

    for s in range(samples):
        Jc, residual = state(q[s], qd[s])
        assert len(residual) and np.abs(residual).max() < 1e-9 * L  # MuJoCo's constraints hold at minparam's states
        v = np.zeros(m.nv)
        v[dof] = qd[s]
        assert np.abs(Jc @ v).max() < 1e-9 * (np.abs(Jc).max() * np.abs(v).max())
        h = 1e-5  # J̇q̇ by central differences of MuJoCo's Jacobian along the motion: J q̈ + J̇ q̇ = 0
        Jp, _ = state(q[s] + h * qd[s], qd[s])
        Jm, _ = state(q[s] - h * qd[s], qd[s])
        acc = np.zeros(m.nv)
        acc[dof] = qdd[s]
        scale = np.abs(Jc).max() * (np.abs(acc).max() + np.abs(v).max() ** 2)
        assert np.abs(Jc @ acc + (Jp - Jm) @ v / (2 * h)).max() < 1e-6 * scale
        # MuJoCo's tangent map from its own Jacobian: q̇_p = −J_p⁺ J_a q̇_a
        Gm = np.zeros((m.nv, len(a)))
        Gm[a] = np.eye(len(a))
        Gm[p] = -np.linalg.pinv(Jc[:, p], rcond=1e-9) @ Jc[:, a]
        d.qpos[qpos_of], d.qvel[dof], d.qacc[:] = q[s], qd[s], acc
        mujoco.mj_inverse(m, d)  # qfrc_inverse = M q̈ + bias − constraint forces (soft), projected out by Gᵀ
        tau_inverse = Gm.T @ d.qfrc_inverse
        rne = np.zeros(m.nv)
        mujoco.mj_rne(m, d, 1, rne)  # M q̈ + bias, no constraint force at all
        tau_rne = Gm.T @ rne
        ref = np.abs(tau[s]).max()
        assert np.abs(tau_inverse - tau[s]).max() < 1e-8 * ref, (tau_inverse, tau[s])
        assert np.abs(tau_rne - tau[s]).max() < 1e-8 * ref


@pytest.mark.parametrize("name", ["parallelogram_arm.xml", "planar_3rrr.xml"])
def test_actuated_torques_equal_mujocos_constrained_inverse_dynamics(name):
    _mujoco_check(DATA / name)


@pytest.mark.parametrize("weld", ['<weld name="pin" body1="pin" body2="forearm"/>',
                                  '<weld name="pin" body1="pin" body2="forearm" relpose="0 0 0 1 0 0 0" anchor="0.1 0 0.2"/>',
                                  '<weld name="pin" site1="pin_s" site2="fore_s"/>'])
def test_weld_equalities_equal_mujocos_constrained_inverse_dynamics(tmp_path, weld):
    """A weld between bodies (relpose from qpos0, and given), and between sites: MuJoCo's residual holds
    at minparam's states and the torques agree."""
    p = _pin_variant(tmp_path, weld)
    desc, chain = load_chain(p, DeriveOptions().stage(), loops=True)
    cut = desc.loops.cuts[0]
    assert cut.kind == "weld" and chain.n == 6 and desc.loops.actuated == (0, 1, 3)
    assert closed_model(desc, chain).mobility == 3
    _mujoco_check(p, samples=6)


# ---------------------------------------------------------------- refused, one line, exit 2
TWO = ('<body name="a" pos="0 0 0.1"><joint name="ja" axis="0 0 1"/><geom size="0.05" mass="1"/>'
       '<body name="b" pos="0.2 0 0"><joint name="jb" axis="0 1 0"/><geom size="0.04" mass="0.5"/>{inner}</body></body>')


def _file(tmp_path: Path, body: str, extra: str) -> Path:
    p = tmp_path / "loop.xml"
    p.write_text(f'<mujoco model="t"><worldbody>{body}</worldbody>{extra}</mujoco>')
    return p


def _cli(*args):
    import subprocess
    import sys

    env = {"PYTHONPATH": str(ROOT / "src"), "PATH": "/usr/bin:/bin"}
    return subprocess.run([sys.executable, "-m", "minparam_cli", *args], capture_output=True, text=True, env=env, timeout=120)


@pytest.mark.parametrize("body, extra, message", [
    (ARM_XML, None, r"connect/weld equalities close kinematic loops, but no actuator drives a joint: add an <actuator> with joint="),
    (TWO.format(inner=""), '<equality><weld name="w" body1="b"/></equality><actuator><motor joint="ja"/></actuator>',
     r"equality\[w\]: .*the loops lock the mechanism|loops: the loops lock the mechanism"),
    (TWO.format(inner='<body name="c" pos="0.1 0 0"/>'), '<equality><connect name="r" body1="c" body2="b" anchor="0 0 0"/></equality>'
     '<actuator><motor joint="ja"/></actuator>', r"equality\[r\]: the equality joins bodies 'c' and 'b', which move as one rigid body"),
    ('<body name="f"><freejoint/><geom size="0.1"/>' + TWO.format(inner="") + "</body>",
     '<equality><connect name="r" body1="b" body2="f" anchor="0 0 0"/></equality><actuator><motor joint="ja"/></actuator>',
     r"equality\[r\]: connect/weld equalities on a floating-base model .* not supported yet"),
    (TWO.format(inner='<body name="c" pos="0.2 0 0"><joint name="jc" axis="0 1 0"/><geom size="0.03" mass="0.2"/></body>'),
     '<equality><connect name="r" body1="c" body2="world" anchor="0 0 0"/><joint joint1="jc" joint2="jb"/></equality>'
     '<actuator><motor joint="ja"/></actuator>', r"joint equalities coupling two joints \(mimic joints\) in a model with connect/weld"),
    (TWO.format(inner='<body name="c" pos="0.2 0 0"><joint name="jc" axis="0 1 0"/><geom size="0.03" mass="0.2"/></body>'),
     '<equality><connect name="r" body1="c" body2="world" anchor="0 0 0"/><joint joint1="jc" polycoef="0.1 0 0 0 0"/></equality>'
     '<actuator><motor joint="jc"/></actuator>', r"actuator #1: an actuator drives joint 'jc', which a joint equality locks"),
], ids=["no actuator", "weld locks", "rigid", "floating base", "mimic", "locked actuated"])
def test_refused_loop_models(tmp_path, body, extra, message):
    if isinstance(body, Path):  # the arm without its <actuator> element
        p = tmp_path / "no_motors.xml"
        p.write_text(re.sub(r"<actuator>.*</actuator>", "", body.read_text(), flags=re.S))
    else:
        p = _file(tmp_path, body, extra)
    r = _cli("derive", str(p))
    assert r.returncode == 2 and r.stdout == "" and r.stderr.strip().count("\n") == 0, r.stderr
    assert re.search(message, r.stderr), r.stderr


def test_inactive_loop_equality_needs_no_actuator(tmp_path):
    desc, chain = load_chain(_file(tmp_path, TWO.format(inner=""), '<equality><weld body1="b" active="false"/></equality>'),
                             DeriveOptions().stage(), loops=True)
    assert desc.loops is None and chain.n == 2
