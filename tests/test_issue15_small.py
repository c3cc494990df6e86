"""Small fixes of issue 15: derive of several files, URDF joint names behind j, pi under deg,
singular -q, where workspace --plot wrote, identify --plot creates its folder, no machine paths in docs."""

from __future__ import annotations

import json
import re

import pytest
from conftest import ROOT
from typer.testing import CliRunner

runner = CliRunner()
PLANAR = "robots/planar2r.yaml"
SCARA = "robots/scara.yaml"
UR5 = "robots/ur5.urdf"


@pytest.fixture(scope="module")
def app():
    from minparam_cli.cli.app import app as real_app

    return real_app


def one_line_exit_2(r, needle: str) -> None:
    lines = r.stderr.strip().splitlines()
    assert r.exit_code == 2 and len(lines) == 1 and "Traceback" not in r.output, r.output
    assert needle in lines[0], lines[0]


def test_derive_of_two_files_prints_both_reports_then_the_summary(app):
    r = runner.invoke(app, ["derive", PLANAR, SCARA, "-q"])
    assert r.exit_code == 0, r.output
    out = r.stdout
    assert out.index("robot        planar 2R") < out.index("robot        SCARA") < out.index("time s  status")
    assert "ZZ1 - M1 - M2" in out and "M3 + M4" in out


def test_derive_of_a_folder_prints_the_summary_alone(app, tmp_path):
    for name in (PLANAR, SCARA):
        (tmp_path / name.split("/")[-1]).write_bytes((ROOT / name).read_bytes())
    r = runner.invoke(app, ["derive", str(tmp_path), "-q"])
    assert r.exit_code == 0, r.output
    assert "time s  status" in r.stdout and "base parameter" not in r.stdout


def test_a_urdf_table_names_the_joint_and_link_behind_each_index(app):
    r = runner.invoke(app, ["derive", UR5, "-q"])
    assert r.exit_code == 0
    rows = [ln.split() for ln in r.stdout.splitlines() if re.match(r"^\d\s+\w+_joint\s", ln)]
    assert rows[0] == ["1", "shoulder_pan_joint", "shoulder_link", "revolute", "0"]
    assert [row[1] for row in rows] == ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
                                        "wrist_1_joint", "wrist_2_joint", "wrist_3_joint"]
    md = runner.invoke(app, ["derive", UR5, "-q", "--format", "markdown"]).stdout
    assert "| 3 | `elbow_joint` | `forearm_link` | revolute | 2 |" in md
    fb = runner.invoke(app, ["derive", UR5, "-q", "--floating-base"]).stdout
    assert re.search(r"^0\s+\(floating base\)\s+world\s+6-DOF$", fb, re.M)
    yaml_out = runner.invoke(app, ["derive", PLANAR, "-q"]).stdout
    assert "shoulder" not in yaml_out  # a YAML arm numbers its own rows


def _arm(tmp_path, unit: str, alpha: str):
    p = tmp_path / "arm.yaml"
    p.write_text(f"name: t\nconvention: dh\nunits: {{angle: {unit}}}\njoints:\n"
                 f"  - {{type: revolute, alpha: {alpha}, a: 0.5, d: 0, theta: 0}}\n"
                 f"  - {{type: revolute, alpha: 0, a: 0.4, d: 0, theta: 0}}\n")
    return str(p)


def test_pi_under_angle_deg_is_refused(app, tmp_path):
    r = runner.invoke(app, ["derive", _arm(tmp_path, "deg", "pi/2")])
    one_line_exit_2(r, "joints[1].alpha: 'pi/2' is in radians, but units.angle is 'deg'; write 90 or set units: {angle: rad}")
    r = runner.invoke(app, ["check", _arm(tmp_path, "deg", "-2*pi/3")])
    assert r.exit_code == 2 and "write -120" in r.output


def test_pi_under_angle_rad_and_90_under_deg_give_the_same_robot(app, tmp_path):
    a = json.loads(runner.invoke(app, ["derive", _arm(tmp_path, "rad", "pi/2"), "-f", "json", "-q"]).stdout)
    b = json.loads(runner.invoke(app, ["derive", _arm(tmp_path, "deg", "90"), "-f", "json", "-q"]).stdout)
    assert [x["expression"] for x in a["base_parameters"]] == [x["expression"] for x in b["base_parameters"]]


def test_singular_takes_q_as_quiet(app):
    r = runner.invoke(app, ["singular", "robots/puma560.yaml", "--q", "10,-30,40,20,30,15", "-q"])
    assert r.exit_code == 0, r.output
    r = runner.invoke(app, ["singular", "robots/puma560.yaml", "--q", "10,-30,40,20,30,15", "--quiet"])
    assert r.exit_code == 0, r.output


def test_workspace_plot_says_where_it_wrote(app, tmp_path):
    png = tmp_path / "ws.png"
    base = ["platform", "workspace", "robots/dodekapod_dang2013.yaml", "--samples", "2000", "-q", "--plot", str(png)]
    r = runner.invoke(app, base)
    assert r.exit_code == 0, r.output
    assert r.stdout.rstrip().endswith(f"plot of the reachable positions written to {png}")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    r = runner.invoke(app, base + ["-f", "json"])
    assert json.loads(r.stdout)["plot"] == {"file": str(png)}
    r = runner.invoke(app, base[:-1] + [str(tmp_path / "no" / "ws.png")])
    one_line_exit_2(r, "output folder")


@pytest.fixture(scope="module")
def sim_csv(tmp_path_factory):
    from minparam_cli.cli.app import app as real_app

    path = tmp_path_factory.mktemp("sim") / "sim.csv"
    r = runner.invoke(real_app, ["simulate", str(ROOT / PLANAR), "--duration", "3", "-o", str(path), "-q"])
    assert r.exit_code == 0, r.output
    return path


def test_identify_plot_creates_its_folder(app, tmp_path, sim_csv):
    figs = tmp_path / "figs" / "run1"
    r = runner.invoke(app, ["identify", PLANAR, str(sim_csv), "--plot", str(figs), "-q"])
    assert r.exit_code == 0, r.output
    assert (figs / "measured_vs_predicted.png").is_file()


def test_identify_plot_naming_a_file_is_refused(app, sim_csv):
    r = runner.invoke(app, ["identify", PLANAR, str(sim_csv), "--plot", str(sim_csv), "-q"])
    one_line_exit_2(r, "exists and is not a folder")


def test_docs_name_no_absolute_path_of_one_machine():
    pages = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
    bad = []
    for page in pages:
        for k, line in enumerate(page.read_text(encoding="utf-8").splitlines(), 1):
            if re.search(r"(?<![\w.])/(work|tmp|home)/", line):
                bad.append(f"{page.relative_to(ROOT)}:{k}: {line.strip()}")
    assert bad == []
