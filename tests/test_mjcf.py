"""MJCF input (issue 33): the regressor times the nominal parameters read from the compiled MuJoCo
model equals MuJoCo's own inverse dynamics (``mj_rne``, M·q̈ + bias with the model's gravity) on
random states, for fixed and floating bases and a linear joint coupling; the armature, damping and
frictionloss columns equal MuJoCo's own terms.  Models: gymnasium's (MIT, tests/data/mjcf/LICENSE-gymnasium)
and a small arm written for these tests (tests/data/mjcf/arm_coupled.xml)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

from minparam_cli.dynamics.regressor import regressor  # noqa: E402
from minparam_cli.robot import DeriveOptions, load_chain  # noqa: E402

DATA = Path(__file__).parent / "data" / "mjcf"
REL = 1e-10


def _rel(a, b) -> float:
    return float(np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300))


def _mj_rne(m, qpos, qvel, qacc) -> np.ndarray:
    d = mujoco.MjData(m)
    d.qpos[:] = qpos
    d.qvel[:] = qvel
    mujoco.mj_forward(m, d)
    d.qacc[:] = qacc
    out = np.zeros(m.nv)
    mujoco.mj_rne(m, d, 1, out)
    return out


def _moving(m, locked=()) -> list[int]:
    return [j for j in range(m.njnt) if int(m.jnt_type[j]) in (2, 3) and j not in locked]


def test_enum_values_match_mujoco():
    from minparam_cli.describe import mjcf_tree as mjcf

    assert (mjcf.JNT_FREE, mjcf.JNT_BALL, mjcf.JNT_SLIDE, mjcf.JNT_HINGE) == tuple(
        int(getattr(mujoco.mjtJoint, k)) for k in ("mjJNT_FREE", "mjJNT_BALL", "mjJNT_SLIDE", "mjJNT_HINGE"))
    assert (mjcf.EQ_CONNECT, mjcf.EQ_WELD, mjcf.EQ_JOINT, mjcf.EQ_TENDON) == tuple(
        int(getattr(mujoco.mjtEq, k)) for k in ("mjEQ_CONNECT", "mjEQ_WELD", "mjEQ_JOINT", "mjEQ_TENDON"))
    assert mjcf.DSBL_GRAVITY == int(mujoco.mjtDisableBit.mjDSBL_GRAVITY)


def _fixed_base_check(path: Path, seed: int, samples: int = 20, with_extras: bool = True):
    """regressor·φ (coordinates) against Gᵀ·mj_rne (every joint) on states that obey the coupling."""
    m = mujoco.MjModel.from_xml_path(str(path))
    desc, chain = load_chain(path, DeriveOptions())
    joints = _moving(m)
    assert [desc.joints[k].name for k in range(chain.n)] == [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) or desc.joints[k].name
                                                           for k, j in enumerate(joints)]
    rng = np.random.default_rng(seed)
    G = np.eye(chain.n) if chain.coupling is None else chain.coupling.G
    off = np.zeros(chain.n) if chain.coupling is None else chain.coupling.offset
    qc, qdc, qddc = (rng.uniform(-1.5, 1.5, (samples, chain.dof)) for _ in range(3))
    phi = np.concatenate([chain.phi_nominal, chain.nominal_extra_values()])
    Y = regressor(chain, qc, qdc, qddc, include_extras=True)
    mine_rigid = regressor(chain, qc, qdc, qddc, include_extras=False) @ chain.phi_nominal
    qpos_adr = [int(m.jnt_qposadr[j]) for j in joints]
    dof_adr = [int(m.jnt_dofadr[j]) for j in joints]
    for s in range(samples):
        q, qd, qdd = G @ qc[s] + off, G @ qdc[s], G @ qddc[s]
        qpos, qvel, qacc = m.qpos0.copy(), np.zeros(m.nv), np.zeros(m.nv)
        qpos[qpos_adr], qvel[dof_adr], qacc[dof_adr] = q, qd, qdd
        tau = _mj_rne(m, qpos, qvel, qacc)[dof_adr]
        assert _rel(mine_rigid[s], G.T @ tau) < REL
        if with_extras:  # armature·q̈ + damping·q̇ + frictionloss·sign q̇ on every joint, through the coupling
            extra = (m.dof_armature[dof_adr] * qdd + m.dof_damping[dof_adr] * qd + m.dof_frictionloss[dof_adr] * np.sign(qd))
            assert _rel(Y[s] @ phi, G.T @ (tau + extra)) < REL
    return desc, chain


def test_written_arm_with_coupling_matches_mj_rne():
    desc, chain = _fixed_base_check(DATA / "arm_coupled.xml", seed=1)
    assert chain.dof == 5 and chain.n == 6  # fr follows fl
    names = list(desc.joints[k].name for k in range(chain.n))
    assert names == ["j1", "j2a", "j2b", "j3", "fl", "fr"]
    assert desc.joints[1].massless and not desc.joints[2].massless  # j2a: the frame between link2's two joints
    fr = desc.joints[5]
    assert fr.mimic is not None and fr.mimic[0] == 4 and fr.mimic[1] == pytest.approx(1.5)
    assert chain.gravity.tolist() == pytest.approx([0.3, -0.2, -9.7]) and desc.gravity_source == "file"
    assert desc.joints[0].limits == pytest.approx((math.radians(-170), math.radians(170)))
    assert dict(desc.joints[0].nominal_extras) == pytest.approx({"rotor_inertia": 0.02, "viscous": 0.1})
    assert dict(desc.joints[4].nominal_extras) == pytest.approx({"coulomb": 0.3})
    assert "tcp" in [name for name, _, _ in desc.tool_links]
    assert "XX2" not in chain.layout.names and "Ia2" in chain.layout.names  # numbered, no columns


def test_mimic_fixed_freezes_the_coupled_joint():
    m = mujoco.MjModel.from_xml_path(str(DATA / "arm_coupled.xml"))
    desc, chain = load_chain(DATA / "arm_coupled.xml", DeriveOptions(mimic="fixed"))
    assert chain.n == chain.dof == 5 and "fr" not in desc.joints[-1].name
    rng = np.random.default_rng(3)
    joints = _moving(m)[:5]
    qpos_adr = [int(m.jnt_qposadr[j]) for j in joints]
    dof_adr = [int(m.jnt_dofadr[j]) for j in joints]
    fr = _moving(m)[5]
    # fr frozen where fl = 0 puts it: y − y0 = c0 + c1 (x − x0)
    y_fixed = m.qpos0[m.jnt_qposadr[fr]] + 0.002 + 1.5 * (0 - m.qpos0[m.jnt_qposadr[_moving(m)[4]]])
    for _ in range(5):
        q, qd, qdd = (rng.uniform(-1, 1, 5) for _ in range(3))
        qpos, qvel, qacc = m.qpos0.copy(), np.zeros(m.nv), np.zeros(m.nv)
        qpos[qpos_adr], qvel[dof_adr], qacc[dof_adr] = q, qd, qdd
        qpos[m.jnt_qposadr[fr]] = y_fixed
        tau = _mj_rne(m, qpos, qvel, qacc)[dof_adr]
        mine = regressor(chain, q[None], qd[None], qdd[None], include_extras=False)[0] @ chain.phi_nominal
        assert _rel(mine, tau) < REL


@pytest.mark.parametrize("name", ["gymnasium_reacher.xml", "gymnasium_pusher.xml"])
def test_gymnasium_arms_match_mj_rne(name):
    _fixed_base_check(DATA / name, seed=2, with_extras=True)


def _rx(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def _ry(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _rz(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


@pytest.mark.parametrize("name", ["gymnasium_ant.xml", "gymnasium_humanoid.xml"])
def test_floating_base_matches_mj_rne(name):
    """The six virtual joints (translations in the free body's compiled frame, then x-y-z rotations)
    against MuJoCo's free joint (world-frame linear, body-frame angular velocity): states and torques
    mapped between the two coordinate sets by hand."""
    path = DATA / name
    m = mujoco.MjModel.from_xml_path(str(path))
    desc, chain = load_chain(path, DeriveOptions())
    assert chain.floating_base and chain.n == 6 + len(_moving(m))
    free = int(m.jnt_bodyid[0])
    assert int(m.jnt_type[0]) == 0
    R0 = np.zeros(9)
    mujoco.mju_quat2Mat(R0, m.body_quat[free])
    R0 = R0.reshape(3, 3)
    p0 = np.asarray(m.body_pos[free], dtype=float)
    joints = _moving(m)
    qpos_adr = [int(m.jnt_qposadr[j]) for j in joints]
    dof_adr = [int(m.jnt_dofadr[j]) for j in joints]
    rng = np.random.default_rng(5)
    q, qd, qdd = (rng.uniform(-1.2, 1.2, (10, chain.n)) for _ in range(3))
    mine = regressor(chain, q, qd, qdd, include_extras=False) @ chain.phi_nominal
    for s in range(10):
        t, (a, b, c) = q[s, :3], q[s, 3:6]
        ex, ey, ez = np.eye(3)
        u = [ex, _rx(a) @ ey, _rx(a) @ _ry(b) @ ez]  # rotation axes in the R0 frame
        R = R0 @ _rx(a) @ _ry(b) @ _rz(c)
        w_l = sum(u[i] * qd[s, 3 + i] for i in range(3))
        w1, w2 = u[0] * qd[s, 3], u[0] * qd[s, 3] + u[1] * qd[s, 4]
        al_l = sum(u[i] * qdd[s, 3 + i] for i in range(3)) + np.cross(w1, u[1]) * qd[s, 4] + np.cross(w2, u[2]) * qd[s, 5]
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, R.ravel())
        qpos, qvel, qacc = m.qpos0.copy(), np.zeros(m.nv), np.zeros(m.nv)
        qpos[:3], qpos[3:7] = p0 + R0 @ t, quat
        qvel[:3], qvel[3:6] = R0 @ qd[s, :3], R.T @ R0 @ w_l
        qacc[:3], qacc[3:6] = R0 @ qdd[s, :3], R.T @ R0 @ al_l
        qpos[qpos_adr], qvel[dof_adr], qacc[dof_adr] = q[s, 6:], qd[s, 6:], qdd[s, 6:]
        tau = _mj_rne(m, qpos, qvel, qacc)
        torque_l = R0.T @ R @ tau[3:6]  # torque about the body origin, in the R0 frame
        expected = np.concatenate([R0.T @ tau[:3], [u[i] @ torque_l for i in range(3)], tau[dof_adr]])
        assert _rel(mine[s], expected) < REL


def test_gravity_disabled_is_zero(tmp_path):
    text = (DATA / "arm_coupled.xml").read_text().replace('<option gravity="0.3 -0.2 -9.7"/>',
                                                          '<option gravity="0.3 -0.2 -9.7"><flag gravity="disable"/></option>')
    p = tmp_path / "nograv.xml"
    p.write_text(text)
    desc, chain = load_chain(p, DeriveOptions())
    assert chain.gravity.tolist() == [0.0, 0.0, 0.0]


def test_inferred_inertia_is_mujocos(tmp_path):
    """A body whose inertia MuJoCo infers from its geoms: the compiled values are the nominal ones."""
    p = tmp_path / "geoms.xml"
    p.write_text('<mujoco><compiler inertiafromgeom="true"/><worldbody><body pos="0 0 1"><joint axis="0 1 0"/>'
                 '<geom type="box" size="0.1 0.2 0.3" pos="0.4 0 0" density="500"/></body></worldbody></mujoco>')
    m = mujoco.MjModel.from_xml_path(str(p))
    desc, chain = load_chain(p, DeriveOptions())
    assert desc.joints[0].inertial.mass == pytest.approx(float(m.body_mass[1]), rel=1e-14)
    assert desc.joints[0].inertial.mass == pytest.approx(500 * 0.2 * 0.4 * 0.6)


def test_ur5_mjcf_equals_its_urdf():
    """robots/ur5.xml, written from robots/ur5.urdf (same numbers): the same regressor, inertials,
    limits and tool point through two loaders that share no code but chain.py."""
    root = Path(__file__).resolve().parents[1] / "robots"
    du, cu = load_chain(root / "ur5.urdf", DeriveOptions())
    dm, cm = load_chain(root / "ur5.xml", DeriveOptions())
    rng = np.random.default_rng(0)
    q, qd, qdd = (rng.uniform(-2, 2, (30, 6)) for _ in range(3))
    assert cm.layout.names == cu.layout.names and dm.convention == "mjcf"
    assert np.allclose(regressor(cm, q, qd, qdd), regressor(cu, q, qd, qdd), rtol=0, atol=1e-13)
    assert np.allclose(cm.phi_nominal, cu.phi_nominal, rtol=0, atol=1e-15)
    assert cm.limits == cu.limits and cm.effort_limits == cu.effort_limits
    assert (dm.tool_link, dm.tool) == (du.tool_link, du.tool)


def test_snap_angles_and_right_angles_are_exact(tmp_path):
    """--snap-angles rounds the UR5's 1.570796325 to π/2 (recorded), which makes the geometry exact;
    euler="0 90 0" in degrees is exact without it (the compiler's cos 45° read back as 90°)."""
    root = Path(__file__).resolve().parents[1] / "robots"
    desc, chain = load_chain(root / "ur5.xml", DeriveOptions(snap_angles=1e-3))
    assert [a["degrees"] for a in desc.adjustments] == [90, 90]
    assert chain.exact is not None
    p = tmp_path / "deg.xml"
    p.write_text('<mujoco><compiler angle="degree"/><worldbody><body><joint axis="0 0 1"/><geom size=".1"/>'
                 '<body pos="0.5 0 0" euler="0 90 0"><joint axis="0 0 1"/><geom size=".1"/></body></body></worldbody></mujoco>')
    desc, chain = load_chain(p, DeriveOptions())
    assert desc.joints[1].origin["pitch"].exact == 90 and chain.exact is not None and not desc.adjustments
