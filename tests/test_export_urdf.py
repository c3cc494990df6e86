"""identify --export-urdf / --export-mjcf / --export-yaml from the command line: the side file of what a
format cannot express, the report line naming it, the YAML's identified block, and one test per kind of
bad export path (refused in one line, exit 2, before the fit, nothing written)."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET

import numpy as np
import pytest
import yaml
from conftest import ROOT
from typer.testing import CliRunner

from minparam_cli.cli.app import app

ROBOT = ROOT / "robots" / "puma560.yaml"


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    """Simulated PUMA (standard DH) data with friction, rotor inertia, an offset on joint 2 and cogging on joint 3."""
    path = tmp_path_factory.mktemp("d") / "d.csv"
    r = CliRunner().invoke(app, ["simulate", str(ROBOT), "--random-inertia", "--effects",
                                 "coulomb,viscous,rotor_inertia,offset@2,cogging@3:k=12", "--noise", "0.01", "--seed", "4",
                                 "-o", str(path), "-q"])
    assert r.exit_code == 0, r.output
    return path


def identify(data, *extra):
    """puma560.yaml has no inertials: a mass bound with the DH ellipsoids fixes every link (else the export is refused)."""
    return CliRunner().invoke(app, ["identify", str(ROBOT), str(data), "--friction", "coulomb,viscous", "--rotor-inertia",
                                    "--physical", "--mass-bounds", "0,100", "-q", *map(str, extra)])


def test_exports_carry_the_identified_terms_and_name_their_side_files(data, tmp_path):
    pytest.importorskip("cvxpy")
    model, urdf, mjcf, yml = (tmp_path / x for x in ("m.json", "p.urdf", "p.xml", "p.yaml"))
    r = identify(data, "--save-model", model, "--export-urdf", urdf, "--export-mjcf", mjcf, "--export-yaml", yml)
    assert r.exit_code == 0, r.output
    saved = json.loads(model.read_text())
    phi = dict(zip(saved["physical"]["phi_names"], saved["physical"]["phi"], strict=True))
    # the report names each side file and what went there, in one line each
    lines = [line for line in r.output.splitlines() if ".extra.yaml" in line]
    assert len(lines) == 2
    assert "p.urdf.extra.yaml" in lines[0] and "gravity" in lines[0] and "rotor inertia" in lines[0]
    assert "p.xml.extra.yaml" in lines[1] and "gravity" not in lines[1]
    # URDF: <dynamics> from Fv, Fc; gravity in the side file; rotor inertia there too
    root = ET.parse(urdf).getroot()
    for k in range(1, 7):
        dyn = root.find(f"joint[@name='j{k}']/dynamics")
        assert float(dyn.get("damping")) == phi[f"Fv{k}"] and float(dyn.get("friction")) == phi[f"Fc{k}"]
    side = yaml.safe_load((tmp_path / "p.urdf.extra.yaml").read_text())
    assert side["gravity"] == [0.0, 0.0, -9.81]
    assert [side["joints"][f"j{k}"]["rotor_inertia"] for k in range(1, 7)] == [phi[f"Ia{k}"] for k in range(1, 7)]
    # MJCF: armature, damping, frictionloss; the diagnosed effects (if any) in its side file with their coefficients
    mroot = ET.parse(mjcf).getroot()
    for k in range(1, 7):
        j = mroot.find(f".//joint[@name='j{k}']")
        assert [float(j.get(a)) for a in ("armature", "damping", "frictionloss")] == [phi[f"Ia{k}"], phi[f"Fv{k}"], phi[f"Fc{k}"]]
    mside = yaml.safe_load((tmp_path / "p.xml.extra.yaml").read_text())
    effects = {t["effect"] for t in saved["design"]["terms"]}
    assert {e["effect"] for e in mside.get("effects", [])} == effects - {"coulomb", "viscous", "rotor_inertia", "offset", "gain"}
    # YAML: everything, in the identified block
    doc = yaml.safe_load(yml.read_text())
    assert doc["identified"]["joints"]["j3"]["rotor_inertia"] == phi["Ia3"]


def test_the_exported_yaml_loads_back(data, tmp_path):
    pytest.importorskip("cvxpy")
    from minparam_cli.robot import DeriveOptions, load_chain

    yml = tmp_path / "p.yaml"
    r = identify(data, "--export-yaml", yml)
    assert r.exit_code == 0, r.output
    _, chain = load_chain(yml, DeriveOptions())
    assert chain.phi_nominal is not None and np.all(chain.phi_nominal[9::10] > 0)


def refused(args, needle):
    r = CliRunner().invoke(app, args)
    assert r.exit_code == 2, r.output
    assert needle in r.output and "Traceback" not in r.output
    assert len([line for line in r.output.splitlines() if line.strip()]) == 1, r.output


def test_export_path_a_folder_is_refused(data, tmp_path):
    refused(["identify", str(ROBOT), str(data), "--physical", "--export-mjcf", str(tmp_path)], "is a folder")


def test_export_path_in_a_missing_folder_is_refused(data, tmp_path):
    refused(["identify", str(ROBOT), str(data), "--physical", "--export-mjcf", str(tmp_path / "no" / "x.xml")], "does not exist")


def test_export_to_stdout_is_refused(data):
    refused(["identify", str(ROBOT), str(data), "--physical", "--export-mjcf", "-"], "an export is a file")


def test_export_mjcf_needs_physical(data, tmp_path):
    refused(["identify", str(ROBOT), str(data), "--export-mjcf", str(tmp_path / "x.xml")], "--export-mjcf needs --physical")


def test_two_outputs_naming_one_file_are_refused(data, tmp_path):
    same = tmp_path / "x.xml"
    refused(["identify", str(ROBOT), str(data), "--physical", "--export-mjcf", str(same), "--export-urdf", str(same)],
            "the same file")
    refused(["identify", str(ROBOT), str(data), "--physical", "--export-mjcf", str(same), "--save-model", str(same)],
            "the same file")


def test_the_report_may_not_overwrite_an_export(data, tmp_path):
    out = tmp_path / "x.xml"
    refused(["identify", str(ROBOT), str(data), "--physical", "--export-mjcf", str(out), "-o", str(out)], "give the report another name")
    assert not out.exists()


def test_a_side_file_name_that_is_a_folder_is_refused(data, tmp_path):
    (tmp_path / "x.xml.extra.yaml").mkdir()
    refused(["identify", str(ROBOT), str(data), "--physical", "--export-mjcf", str(tmp_path / "x.xml")], "is a folder")
    assert not (tmp_path / "x.xml").exists()


def test_a_batch_refuses_export_mjcf(tmp_path, data):
    folder = tmp_path / "runs"
    folder.mkdir()
    (folder / "a.csv").write_bytes(data.read_bytes())
    refused(["identify", str(ROBOT), str(folder), "--physical", "--export-mjcf", str(tmp_path / "x.xml"), "-o", str(tmp_path / "o")],
            "--export-mjcf applies to one recording")


def test_export_mjcf_refuses_coupled_mimic_joints_before_the_fit(tmp_path):
    """A gripper whose right finger mimics the left (--mimic coupled): MJCF would need an equality
    constraint, which the writer does not write; refused in one line before any data is read."""
    from test_mimic import gripper_arm

    robot = gripper_arm(tmp_path)
    data = tmp_path / "none.csv"
    data.write_text("t,q1\n")
    out = tmp_path / "g.xml"
    refused(["identify", str(robot), str(data), "--physical", "--export-mjcf", str(out)], "coupled mimic joints")
    assert not out.exists()


def test_a_side_file_is_always_rewritten(tmp_path):
    """An export with nothing left out still rewrites its side file (header only), so a stale one from an
    earlier run cannot be read as this export's, and the report names no side file for it."""
    from minparam_cli.api.model_file import _write_with_side
    from minparam_cli.model.export_extra import SIDE_FORMAT, joint_terms
    from minparam_cli.robot import DeriveOptions, load_chain

    _, chain = load_chain(ROBOT, DeriveOptions())
    terms = joint_terms(chain, np.ones(chain.layout.size))
    out = tmp_path / "x.xml"
    (tmp_path / "x.xml.extra.yaml").write_text("stale: true\n")
    assert _write_with_side("<mujoco/>", out, "mjcf", "r.yaml", terms, None, ()) == ""
    doc = yaml.safe_load((tmp_path / "x.xml.extra.yaml").read_text())
    assert doc["format"] == SIDE_FORMAT and "stale" not in doc and "joints" not in doc
