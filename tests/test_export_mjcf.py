"""identify --export-mjcf / --export-urdf, checked by an independent engine: MuJoCo.

MuJoCo compiles the exported MJCF, and the exported URDF through its own URDF reader; its inverse
dynamics (``mj_inverse``: the mass matrix with ``armature``, the bias forces, minus the passive
``damping`` force) must equal minparam's regressor · φ for the rigid bodies plus rotor inertia and
viscous friction to 1e-8 relative at random states.  Coulomb friction is a constraint force in
MuJoCo (``frictionloss``): the comparison disables constraints, and a separate test shows where
MuJoCo's soft friction-loss force equals Fc·sign(q̇) (a sliding joint: the force saturates) and where
it does not (near rest).
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import ROOT

from minparam_cli.dynamics.inertia import random_inertia
from minparam_cli.dynamics.regressor import regressor
from minparam_cli.model import export_extra, export_mjcf, export_urdf
from minparam_cli.robot import DeriveOptions, load_chain

mujoco = pytest.importorskip("mujoco")

ROBOTS = ["puma560_mdh.yaml", "panda.yaml", "puma560.yaml", "ur5.urdf", "iiwa14.urdf"]


def chain_and_phi(robot: str, seed: int = 1):
    """The chain with Coulomb, viscous and rotor-inertia columns, random bodies and positive extras."""
    _, chain = load_chain(ROOT / "robots" / robot, DeriveOptions(friction=("coulomb", "viscous"), rotor_inertia=True))
    rng = np.random.default_rng(seed)
    phi = np.zeros(chain.layout.size)
    phi[: chain.layout.n_inertial] = random_inertia(chain.n, chain.length_scale, rng).phi
    phi[chain.layout.n_inertial :] = rng.uniform(0.1, 1.0, chain.layout.size - chain.layout.n_inertial)
    return chain, phi


def without(chain, phi, *prefixes):
    out = phi.copy()
    for i, name in enumerate(chain.layout.names):
        if name.rstrip("0123456789") in prefixes:
            out[i] = 0.0
    return out


def dof_order(model, chain):
    """MuJoCo's dof address of each chain joint, by name."""
    return np.array([model.jnt_dofadr[model.joint(name).id] for name in chain.joint_names])


def inverse(model, data, order, q, dq, ddq):
    data.qpos[order], data.qvel[order], data.qacc[order] = q, dq, ddq
    mujoco.mj_inverse(model, data)
    return data.qfrc_inverse[order].copy()


def assert_same_torques(model, chain, phi_compared, seed=0, count=20):
    """mj_inverse (constraints off) equals regressor · φ to 1e-8 relative at held-out random states."""
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
    data, order = mujoco.MjData(model), dof_order(model, chain)
    rng = np.random.default_rng(1000 + seed)
    for _ in range(count):
        q, dq, ddq = rng.uniform(-2, 2, chain.n), rng.uniform(-2, 2, chain.n), rng.uniform(-3, 3, chain.n)
        expected = regressor(chain, q[None], dq[None], ddq[None])[0] @ phi_compared
        got = inverse(model, data, order, q, dq, ddq)
        assert np.linalg.norm(got - expected) <= 1e-8 * np.linalg.norm(expected), (got, expected)


def mjcf(chain, phi):
    return export_mjcf.mjcf_from_chain(chain, phi, export_extra.joint_terms(chain, phi), "test")


@pytest.mark.parametrize("robot", ROBOTS)
def test_mujoco_inverse_dynamics_of_the_mjcf_equals_minparams(robot):
    """Rigid bodies + armature (Ia) + damping (Fv): DH (standard, with its Post frames), MDH and URDF robots."""
    chain, phi = chain_and_phi(robot)
    model = mujoco.MjModel.from_xml_string(mjcf(chain, phi))
    assert np.allclose(model.opt.gravity, chain.gravity, rtol=0, atol=0)
    assert_same_torques(model, chain, without(chain, phi, "Fc"))


def test_a_wrong_body_would_be_seen():
    """The comparison can fail: one link's mass changed in the MJCF is more than 1e-8 off."""
    chain, phi = chain_and_phi("puma560.yaml")
    other = phi.copy()
    other[9 + 10 * 2] *= 1.001  # M3
    model = mujoco.MjModel.from_xml_string(mjcf(chain, other))
    with pytest.raises(AssertionError):
        assert_same_torques(model, chain, without(chain, phi, "Fc"), count=3)


@pytest.mark.parametrize("robot", ["puma560_mdh.yaml", "ur5.urdf"])
def test_frictionloss_is_coulomb_friction_while_the_joint_slides(robot):
    """MuJoCo's friction loss is a soft constraint: in mj_inverse its force is Fc·sign(q̇) once it saturates
    (|q̇| of 0.5 rad/s or more here, MuJoCo's default solref/solimp); near rest its sign is that of the
    acceleration it resists, not of q̇: there it is not the Coulomb term minparam fits, which is why the
    torque comparison leaves it out."""
    chain, phi = chain_and_phi(robot, seed=3)
    text = mjcf(chain, phi)
    full, rigid = mujoco.MjModel.from_xml_string(text), mujoco.MjModel.from_xml_string(text)
    full.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_LIMIT  # random states may be beyond a joint's range
    rigid.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
    fd, rd, order = mujoco.MjData(full), mujoco.MjData(rigid), dof_order(full, chain)
    fc = regressor(chain, np.zeros((1, chain.n)), np.ones((1, chain.n)), np.zeros((1, chain.n)))[0] @ (
        phi - without(chain, phi, "Fc"))
    rng = np.random.default_rng(8)
    for _ in range(10):
        q, ddq = rng.uniform(-2, 2, chain.n), rng.uniform(-3, 3, chain.n)
        dq = rng.choice([-1.0, 1.0], chain.n) * rng.uniform(0.5, 2.0, chain.n)
        friction = inverse(full, fd, order, q, dq, ddq) - inverse(rigid, rd, order, q, dq, ddq)
        assert np.allclose(friction, fc * np.sign(dq), rtol=1e-8, atol=0)
    dq = np.full(chain.n, 1e-6)  # near rest: the force follows the acceleration the constraint resists, not q̇
    friction = inverse(full, fd, order, q, dq, ddq) - inverse(rigid, rd, order, q, dq, ddq)
    assert np.allclose(friction, fc * np.sign(ddq), rtol=1e-8, atol=0)
    assert not np.allclose(friction, fc * np.sign(dq), rtol=1e-3, atol=0)


def strip_for_mujoco(text: str, chain) -> str:
    """MuJoCo's URDF reader with minparam's frames: no fusing of fixed links, no visuals, no inertia balancing."""
    from lxml import etree

    root = etree.fromstring(text.encode())
    for el in root.findall(".//visual") + root.findall(".//collision"):
        el.getparent().remove(el)
    ext = etree.fromstring('<mujoco><compiler fusestatic="false" discardvisual="true" balanceinertia="false"/></mujoco>')
    root.insert(0, ext)
    return etree.tostring(root, encoding="unicode")


@pytest.mark.parametrize("robot", ROBOTS)
def test_mujoco_reads_the_exported_urdf_with_the_same_torques(robot):
    """The URDF (a table's new URDF, or a URDF robot's own file rewritten) through MuJoCo's URDF reader:
    rigid bodies + <dynamics damping> equal regressor · φ; gravity comes from the side file (a URDF has
    none), rotor inertia too (MuJoCo's armature, set from it)."""
    chain, phi = chain_and_phi(robot, seed=5)
    terms = export_extra.joint_terms(chain, phi)
    if robot.endswith(".urdf"):
        text = export_urdf.urdf_with_inertials((ROOT / "robots" / robot).read_bytes(), chain, phi, "test", terms)
    else:
        text = export_urdf.urdf_from_chain(chain, phi, "test", terms)
    side = export_extra.side_document("urdf", "x.urdf", robot, terms, chain.gravity, ("armature", "gear"))
    model = mujoco.MjModel.from_xml_string(strip_for_mujoco(text, chain))
    model.opt.gravity[:] = side["gravity"]
    order = dof_order(model, chain)
    for j, name in enumerate(chain.joint_names):
        model.dof_armature[order[j]] = side["joints"][name]["rotor_inertia"]
    assert np.allclose(model.dof_frictionloss[order], terms.friction, rtol=1e-15)
    assert_same_torques(model, chain, without(chain, phi, "Fc"), seed=2)


def test_limits_only_where_the_description_had_them():
    """puma560_mdh.yaml gives position limits and no effort or velocity limits; puma560.yaml none."""
    import xml.etree.ElementTree as ET

    for robot, limited in (("puma560_mdh.yaml", True), ("puma560.yaml", False)):
        chain, phi = chain_and_phi(robot)
        model = mujoco.MjModel.from_xml_string(mjcf(chain, phi))
        order = [model.joint(n).id for n in chain.joint_names]
        assert list(model.jnt_limited[order]) == [limited] * chain.n
        if limited:
            assert np.allclose(model.jnt_range[order], np.array(chain.limits), rtol=0, atol=0)
        root = ET.fromstring(export_urdf.urdf_from_chain(chain, phi))
        for j in root.findall("joint"):
            if j.get("type") == "fixed":
                continue
            limit = j.find("limit")
            assert j.get("type") == ("revolute" if limited else "continuous")
            assert (limit is not None) == limited
            if limit is not None:
                assert limit.get("effort") is None and limit.get("velocity") is None  # none invented
        assert "effort=\"0\"" not in export_urdf.urdf_from_chain(chain, phi)


def test_effort_and_velocity_limits_are_written_when_given(tmp_path):
    robot = tmp_path / "r.yaml"
    robot.write_text("name: r\nconvention: mdh\nunits: {length: m, angle: deg}\njoints:\n"
                     "  - {name: a, type: revolute, alpha: 0, a: 0, d: 0, theta: 0, limits: [-90, 90], effort: 40, velocity: 180}\n"
                     "  - {name: b, type: revolute, alpha: 90, a: 0.3, d: 0, theta: 0}\n")
    _, chain = load_chain(robot, DeriveOptions())
    phi = random_inertia(chain.n, 1.0, np.random.default_rng(0)).phi
    import xml.etree.ElementTree as ET

    root = ET.fromstring(export_urdf.urdf_from_chain(chain, phi))
    a, b = root.find("joint[@name='a']"), root.find("joint[@name='b']")
    assert a.get("type") == "revolute" and b.get("type") == "continuous" and b.find("limit") is None
    lim = a.find("limit")
    assert [float(lim.get(k)) for k in ("lower", "upper", "effort", "velocity")] == pytest.approx([-np.pi / 2, np.pi / 2, 40, np.pi])
    model = mujoco.MjModel.from_xml_string(mjcf(chain, phi))
    assert model.actuator_forcerange[0].tolist() == [-40, 40] and not model.actuator_forcelimited[1]


def test_the_export_needs_no_mujoco(tmp_path):
    """Writing the MJCF imports nothing of mujoco (only the tests and the benchmark load it)."""
    import subprocess
    import sys

    code = ("import sys; sys.modules['mujoco'] = None\n"
            "import numpy as np\n"
            "from minparam_cli.robot import DeriveOptions, load_chain\n"
            "from minparam_cli.dynamics.inertia import random_inertia\n"
            "from minparam_cli.model import export_extra, export_mjcf\n"
            f"_, c = load_chain({str(ROOT / 'robots' / 'panda.yaml')!r}, DeriveOptions())\n"
            "phi = random_inertia(c.n, 1.0, np.random.default_rng(0)).phi\n"
            "print(export_mjcf.mjcf_from_chain(c, phi, export_extra.joint_terms(c, phi))[:8])\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and r.stdout.startswith("<mujoco"), r.stderr


def test_quaternion_round_trip():
    from scipy.spatial.transform import Rotation

    for R in Rotation.random(50, random_state=3).as_matrix().tolist() + [np.diag([1.0, -1, -1]).tolist(), np.diag([-1.0, 1, -1]).tolist()]:
        R = np.array(R)
        w, x, y, z = export_mjcf.quaternion(R)
        back = Rotation.from_quat([x, y, z, w]).as_matrix()
        assert np.allclose(back, R, atol=1e-14)


def test_uncoupled_motor_terms_become_joint_terms_and_coupled_ones_go_to_the_side_file(tmp_path):
    """TX40 (a transmission; motor 6 turns joints 5 and 6), with motor-side columns on every motor: the
    motor-side inertia and viscous friction of motors 1-5 become armature r²·Iam and damping r²·Fvm of their
    joint, and MuJoCo reproduces them; motor 6's go to the side file (left out of the comparison)."""
    robot = tmp_path / "tx40_all_motors.yaml"
    text = (ROOT / "robots" / "tx40.yaml").read_text()
    assert "  motors: [6]\n" in text
    robot.write_text(text.replace("  motors: [6]\n", ""))
    _, chain = load_chain(robot, DeriveOptions())
    assert "Iam1" in chain.layout.names
    rng = np.random.default_rng(4)
    phi = np.zeros(chain.layout.size)
    phi[: chain.layout.n_inertial] = random_inertia(chain.n, chain.length_scale, rng).phi
    phi[chain.layout.n_inertial :] = rng.uniform(1e-4, 1e-3, chain.layout.size - chain.layout.n_inertial)
    gains = [0.5, 0.6, 0.7, 0.8, 0.9, 1.1]
    terms = export_extra.joint_terms(chain, phi, drive_gains=gains)
    N = np.asarray(chain.transmission.matrix, dtype=float)
    assert [m["motor"] for m in terms.motors if m["term"] != "drive_gain"] == [6, 6, 6]
    assert [m["motor"] for m in terms.motors if m["term"] == "drive_gain"] == [6]
    assert np.allclose(terms.gear[:5], np.diag(N)[:5] * gains[:5], rtol=1e-15)
    model = mujoco.MjModel.from_xml_string(export_mjcf.mjcf_from_chain(chain, phi, terms))
    compared = without(chain, phi, "Fc", "Fcm")
    compared[[i for i, name in enumerate(chain.layout.names) if name in ("Iam6", "Fvm6")]] = 0.0
    assert_same_torques(model, chain, compared)
    doc = export_extra.side_document("mjcf", "x.xml", "tx40.yaml", terms)
    assert "coupled-motor terms" in export_extra.side_summary(doc)


def test_a_diagnosed_gain_is_the_motor_gear():
    """The gain effect: measured torque (1 + G)·τ, so a control in measured-torque units is τ·(1 + G): gear 1/(1 + G)."""
    from minparam_cli.identify.passes.design import Term

    chain, phi = chain_and_phi("puma560_mdh.yaml")
    terms = export_extra.joint_terms(chain, phi, (Term("gain", (1, 3)), Term("spring", (2,))), [0.25, -0.2, 1.0, 2.0])
    assert terms.gear.tolist() == [1.0, 0.8, 1.0, 1.25, 1.0, 1.0] and terms.gear_source == "identified gain effect"
    assert terms.effects[0]["coefficients"] == {"Kq3": 1.0, "K03": 2.0}  # the spring K·(q − q₀): columns q and 1
    model = mujoco.MjModel.from_xml_string(export_mjcf.mjcf_from_chain(chain, phi, terms))
    assert np.allclose(model.actuator_gear[:, 0], terms.gear, rtol=1e-15)


def test_side_file_says_which_terms_lack_the_evidence_for_their_name():
    """A diagnosed term kept as model error (evidence ``named: False``, docs/methods/selection.md) is still
    written where the format has a field for it (damping here), so the export reproduces the identified
    torques, but the side file and its summary line name it; a term listed in the side file carries its
    evidence.  A named term is not listed."""
    from minparam_cli.identify.passes.design import Term

    chain, phi = chain_and_phi("puma560_mdh.yaml")
    terms = (Term("viscous", (0, 1)), Term("coulomb", (2,)), Term("spring", (3,)))
    coefficients = [0.5, 0.25, 0.1, 2.0, -0.3]  # Fv1, Fv2 | Fc3 | Kq4, K04
    evidence = ({"named": False, "delta_bic_eff": 3.0, "n_eff": 80.0}, {"named": True, "delta_bic_eff": -40.0},
                {"named": False, "delta_bic_eff": 1.0, "n_eff": 90.0})
    terms_out = export_extra.joint_terms(chain, phi, terms, coefficients, evidence=evidence)
    alone = export_extra.joint_terms(chain, phi)  # φ's own extras only
    assert np.allclose(terms_out.damping[:2] - alone.damping[:2], [0.5, 0.25], rtol=1e-14)
    assert np.isclose(terms_out.friction[2] - alone.friction[2], 0.1, rtol=1e-14)
    doc = export_extra.side_document("mjcf", "x.xml", "r.yaml", terms_out)
    names = chain.joint_names
    assert doc["unnamed_in_export"]["terms"] == [f"viscous ({names[0]}, {names[1]})"]
    (spring,) = doc["effects"]
    assert spring["named"] is False and spring["evidence"] == {"delta_bic_eff": 1.0, "n_eff": 90.0}
    line = export_extra.side_summary(doc)
    assert "lack the evidence" in line and f"viscous ({names[0]}, {names[1]})" in line and "coulomb" not in line
