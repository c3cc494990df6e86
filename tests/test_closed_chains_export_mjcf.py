"""identify --export-mjcf on a closed chain (issue 35): the loops are written as site-to-site
``<connect>`` equalities (one per point pair of a cut), only the actuated joints get a motor, and the
bodies stand at the assembled reference (each joint's ``ref``: qpos0 is the assembled mechanism).  Checked with MuJoCo itself: its constraints hold at
minparam's states on the manifold, and its constrained inverse dynamics, projected on the tangent
space its own constraint Jacobian defines, gives minparam's actuated torques Gᵀ·Y_tree·φ; minparam's
MJCF reader gives the YAML's base set back."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import cli

mujoco = pytest.importorskip("mujoco")

from minparam_cli.api.options.derive import DeriveOptions  # noqa: E402
from minparam_cli.loops.derive import actuated_regressor  # noqa: E402
from minparam_cli.loops.sample import manifold_states  # noqa: E402
from minparam_cli.model.export_extra import joint_terms  # noqa: E402
from minparam_cli.model.export_mjcf import mjcf_from_chain  # noqa: E402
from minparam_cli.robot import load_chain  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
ROBOTS = ["parallelogram_arm.yaml", "fourbar_hybroblib.yaml", "delta.yaml", "planar_3rrr.yaml"]


def _export(path: Path, tmp_path: Path):
    from minparam_cli.loops.coupling import with_loops

    desc, tree = load_chain(path, DeriveOptions().stage(), loops=True)
    chain = with_loops(desc, tree)
    phi = np.zeros(chain.layout.size)  # the nominal bodies; friction columns (identify's own) zero
    phi[: len(chain.phi_nominal)] = chain.phi_nominal
    xml = tmp_path / (path.stem + ".xml")
    xml.write_text(mjcf_from_chain(chain, phi, joint_terms(chain, phi)))
    return desc, chain, xml


@pytest.mark.parametrize("name", ROBOTS)
def test_exported_loops_hold_mujocos_constrained_inverse_dynamics(name, tmp_path):
    desc, chain, xml = _export(ROOT / "robots" / name, tmp_path)
    model = chain.coupling.model
    q, qd, qdd, G = manifold_states(model, 8, 5)
    n_in = chain.layout.n_inertial
    tau = actuated_regressor(model, q, qd, qdd, G)[:, :, :n_in] @ chain.phi_nominal[:n_in]
    m = mujoco.MjModel.from_xml_path(str(xml))
    m.opt.jacobian = int(mujoco.mjtJacobian.mjJAC_DENSE)
    assert m.nu == len(model.actuated) and m.neq == len(model.cut_of_pair)
    d = mujoco.MjData(m)
    dof = [int(m.joint(j).dofadr[0]) for j in chain.joint_names]
    adr = [int(m.joint(j).qposadr[0]) for j in chain.joint_names]
    a = [dof[k] for k in model.actuated]
    p = [i for i in range(m.nv) if i not in a]
    # qpos0 is the assembled reference (the joints' ref): MuJoCo's residual vanishes there
    assert np.allclose(m.qpos0[adr], model.reference, atol=1e-12)
    mujoco.mj_forward(m, d)
    assert np.abs(d.efc_pos[d.efc_type == int(mujoco.mjtConstraint.mjCNSTR_EQUALITY)]).max() < 1e-9
    for s in range(len(q)):
        d.qpos[adr], d.qvel[dof] = q[s], qd[s]
        d.qacc[:] = 0.0
        d.qacc[dof] = qdd[s]
        mujoco.mj_forward(m, d)
        eq = d.efc_type == int(mujoco.mjtConstraint.mjCNSTR_EQUALITY)
        Jc = d.efc_J.reshape(d.nefc, m.nv)[eq]
        assert np.abs(d.efc_pos[eq]).max() < 1e-9 * chain.length_scale  # MuJoCo's loops close at minparam's state
        Gm = np.zeros((m.nv, len(a)))
        Gm[a] = np.eye(len(a))
        Gm[p] = -np.linalg.pinv(Jc[:, p], rcond=1e-9) @ Jc[:, a]  # MuJoCo's tangent map, from its own Jacobian
        d.qacc[:] = 0.0
        d.qacc[dof] = qdd[s]
        m.dof_damping[:] = 0.0  # the inertial part (friction is minparam's own column)
        m.dof_frictionloss[:] = 0.0
        mujoco.mj_inverse(m, d)
        got = Gm.T @ d.qfrc_inverse
        assert np.abs(got - tau[s]).max() < 1e-7 * np.abs(tau[s]).max(), (got, tau[s])


@pytest.mark.parametrize("name", ["parallelogram_arm.yaml", "fourbar_hybroblib.yaml"])
def test_exported_mjcf_reads_back_as_the_same_closed_chain(name, tmp_path):
    """minparam's MJCF reader on the exported file: the same actuated joints and base set (robots whose
    links all carry parameters: a massless link comes back as a token body with columns of its own)."""
    from minparam_cli.api.derivation import derive_file

    _, _, xml = _export(ROOT / "robots" / name, tmp_path)
    yaml_base, xml_base = derive_file(ROOT / "robots" / name, DeriveOptions()), derive_file(xml, DeriveOptions())
    assert xml_base.extra["closed_chain"]["actuated"] == yaml_base.extra["closed_chain"]["actuated"]
    assert xml_base.kept_names == yaml_base.kept_names
    assert np.allclose(xml_base.K, yaml_base.K, atol=1e-9)


def test_a_mimic_coupling_is_still_refused():
    from minparam_cli.chain import Coupling
    from minparam_cli.errors import InputError
    from minparam_cli.model.export_mjcf import check_mjcf_chain

    _, tree = load_chain(ROOT / "robots" / "planar2r.yaml", DeriveOptions().stage())
    from dataclasses import replace

    coupled = replace(tree, coupling=Coupling((0,), np.array([[1.0], [1.0]]), np.zeros(2)))
    with pytest.raises(InputError, match="mimic"):
        check_mjcf_chain(coupled)


def _run(*args):
    import subprocess
    import sys

    env = {"PYTHONPATH": str(ROOT / "src"), "PATH": "/usr/bin:/bin"}
    return subprocess.run([sys.executable, "-m", "minparam_cli", *map(str, args)], capture_output=True, text=True, env=env,
                          timeout=300)


@pytest.fixture(scope="module")
def arm_run(tmp_path_factory):
    d = tmp_path_factory.mktemp("arm_export")
    arm = ROOT / "robots" / "parallelogram_arm.yaml"
    data = d / "arm.csv"
    assert cli("simulate", arm, "-o", data, "--seed", 1, "--noise", 0.5, "--duration", 6, "-q").exit_code == 0
    return d, arm, data


def _one_line_exit_2(r, needle: str) -> None:
    assert r.exit_code == 2 and r.stderr.strip().count("\n") == 0 and needle in r.stderr and "Traceback" not in r.output, r.output


def test_export_urdf_of_a_closed_chain_is_one_line_exit_2(arm_run):
    d, arm, data = arm_run
    _one_line_exit_2(cli("identify", arm, data, "--physical", "--export-urdf", d / "x.urdf"), "URDF has no loop-closing joints")
    assert not (d / "x.urdf").exists()


def test_export_yaml_and_mjcf_of_a_closed_chain_read_back(arm_run):
    """--export-yaml keeps the closed_chain document (its 'identified' block read back as a record) and
    --export-mjcf the loops: both derive to the arm's 18 base parameters."""
    d, arm, data = arm_run

    def run(*args):
        r = _run(*args)
        return r.returncode, r.stdout, r.stderr

    _exports_read_back(run, arm, data, d, 18)


def _exports_read_back(run, robot, data, folder, n_base: int) -> None:
    """identify --physical --export-yaml --export-mjcf on ``data``, then both files derive to ``n_base``
    base parameters; ``run(*args)`` gives (exit code, stdout, stderr) of one minparam command."""
    code, _, err = run("identify", robot, data, "--physical", "--export-yaml", folder / "a.yaml", "--export-mjcf",
                       folder / "a.xml", "-q")
    assert code == 0, err
    for out in (folder / "a.yaml", folder / "a.xml"):
        code, text, err = run("derive", out, "-f", "json")
        assert code == 0, err
        assert json.loads(text)["n_base"] == n_base


def test_export_yaml_of_a_platform_file_is_one_line_exit_2(arm_run, tmp_path):
    d, _, data = arm_run
    hexapod = ROOT / "robots" / "platforms" / "hexapod_6_6.yaml"
    _one_line_exit_2(cli("identify", hexapod, data, "--physical", "--export-yaml", tmp_path / "h.yaml"), "platform file holds one body")


def test_massless_links_of_an_mjcf_tree_are_exported(tmp_path):
    """A tree whose MJCF bodies hold several joints (massless links between them, no columns): the MJCF
    export writes them as token bodies MuJoCo compiles, the URDF export as links without <inertial>
    (both used to index the bodies by joint and failed)."""
    from minparam_cli.model.export_urdf import urdf_from_chain

    _, chain = load_chain(ROOT / "tests" / "data" / "mjcf" / "gymnasium_pusher.xml", DeriveOptions().stage())
    assert chain.layout.massless
    phi = np.zeros(chain.layout.size)
    phi[: len(chain.phi_nominal)] = chain.phi_nominal
    terms = joint_terms(chain, phi)
    xml = tmp_path / "pusher.xml"
    xml.write_text(mjcf_from_chain(chain, phi, terms))
    m = mujoco.MjModel.from_xml_path(str(xml))
    assert m.njnt == chain.n
    urdf = urdf_from_chain(chain, phi, "", terms)
    assert urdf.count("<inertial>") == len(chain.layout.links_with_columns)


def test_export_yaml_and_mjcf_of_the_four_bar_read_back(tmp_path):
    """The route of the test above in this process, on the smallest closed chain (the fast tier's case):
    simulate, identify --physical --export-yaml --export-mjcf, and both files derive to the four-bar's 8
    base parameters."""
    bar, data = ROOT / "robots" / "fourbar_hybroblib.yaml", tmp_path / "bar.csv"
    assert cli("simulate", bar, "-o", data, "--seed", 1, "--noise", 0.05, "--duration", 6, "-q").exit_code == 0

    def run(*args):
        r = cli(*args)
        return r.exit_code, r.output, r.output

    _exports_read_back(run, bar, data, tmp_path, 8)
