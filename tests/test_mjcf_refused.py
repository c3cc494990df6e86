"""MJCF input that is refused (issue 33 point 2): one line, exit 2, naming the construct and the
element; one test per kind of refused construct and per kind of broken file."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("mujoco")

from minparam_cli.errors import DescriptionError, NotARobotError, UnsupportedError  # noqa: E402
from minparam_cli.robot import DeriveOptions, load_chain  # noqa: E402

SRC = Path(__file__).resolve().parents[1] / "src"
ARM = '<body name="a" pos="0 0 0.1"><joint name="ja" axis="0 0 1"/><geom size="0.05" mass="1"/>{inner}</body>'


def _model(tmp_path: Path, body: str, extra: str = "", name: str = "m.xml") -> Path:
    p = tmp_path / name
    p.write_text(f'<mujoco model="t"><worldbody>{body}</worldbody>{extra}</mujoco>')
    return p


def _two_links(inner2: str = "") -> str:
    return ARM.format(inner='<body name="b" pos="0.2 0 0"><joint name="jb" axis="0 1 0"/><geom size="0.04" mass="0.5"/>' + inner2 + "</body>")


def _load(p: Path):
    return load_chain(p, DeriveOptions())


def test_ball_joint(tmp_path):
    p = _model(tmp_path, ARM.format(inner='<body name="b"><joint name="ball1" type="ball"/><geom size="0.04"/></body>'))
    with pytest.raises(UnsupportedError, match=r"joint\[ball1\]: ball joints are not supported yet \(body 'b'\)"):
        _load(p)


def test_free_joint_not_at_the_root(tmp_path):
    p = _model(tmp_path, ARM.format(inner='<body name="b"><freejoint name="f"/><geom size="0.04"/></body>'))
    with pytest.raises(Exception, match=r"free joint|MuJoCo cannot compile"):  # MuJoCo itself may refuse it
        _load(p)


def test_free_objects_beside_the_robot_are_left_out(tmp_path):
    """Not refused: a second free body, or a free body beside a fixed-base arm with more joints, is a
    separate object (a ball, a cube): left out with a warning."""
    from minparam_cli.errors import MinparamWarning

    cube = '<body name="cube" pos="1 0 0"><freejoint name="fc"/><geom type="box" size=".02 .02 .02"/></body>'
    with pytest.warns(MinparamWarning, match="free bodies 'cube' left out"):
        desc, chain = _load(_model(tmp_path, _two_links() + cube, name="arm_cube.xml"))
    assert not chain.floating_base and [j.name for j in desc.joints] == ["ja", "jb"]
    robot = '<body name="torso"><freejoint name="f1"/><geom size="0.1"/><body name="leg"><joint name="k"/><geom size="0.05"/></body></body>'
    ball = '<body name="ball"><freejoint name="f2"/><geom size="0.1"/></body>'
    with pytest.warns(MinparamWarning, match="free bodies 'ball' left out"):
        desc, chain = _load(_model(tmp_path, ball + robot, name="two_free.xml"))
    assert chain.floating_base and chain.n == 7 and desc.joints[5].link_name == "torso"


@pytest.mark.parametrize("kind, eq, match", [
    ("polynomial", '<joint name="poly" joint1="jb" joint2="ja" polycoef="0 1 0.5 0 0"/>', r"equality\[poly\]: a polynomial joint coupling"),
    ("tendon", '<tendon name="te" tendon1="t1"/>', r"equality\[te\]: a tendon equality \(a tendon coupling\)"),
])
def test_refused_equalities(tmp_path, kind, eq, match):
    tendon = '<tendon><fixed name="t1"><joint joint="ja" coef="1"/><joint joint="jb" coef="1"/></fixed></tendon>'
    p = _model(tmp_path, _two_links(), tendon + f"<equality>{eq}</equality>", name=f"{kind}.xml")
    with pytest.raises(UnsupportedError, match=match):
        _load(p)


def test_inactive_equality_is_ignored(tmp_path):
    p = _model(tmp_path, _two_links(), '<equality><connect body1="b" body2="world" anchor="0 0 0" active="false"/></equality>')
    _, chain = _load(p)
    assert chain.dof == 2


def test_fixed_tendon_actuator_camera_and_sites_are_ignored(tmp_path):
    extra = ('<tendon><fixed name="t1"><joint joint="ja" coef="1"/><joint joint="jb" coef="-1"/></fixed></tendon>'
             '<actuator><motor tendon="t1"/><position joint="ja" kp="10"/></actuator>')
    p = _model(tmp_path, _two_links('<site name="s"/><camera name="c"/>'), extra)
    _, chain = _load(p)
    assert chain.dof == 2


def test_locked_joint_is_welded(tmp_path):
    p = _model(tmp_path, _two_links(), '<equality><joint joint1="jb" polycoef="0.3 0 0 0 0"/></equality>')
    desc, chain = _load(p)
    assert chain.dof == 1 and [j.name for j in desc.joints] == ["ja"]


def test_doctype_is_refused_before_mujoco(tmp_path):
    p = tmp_path / "dt.xml"
    p.write_text('<?xml version="1.0"?>\n<!DOCTYPE mujoco [<!ENTITY x "0.1">]>\n<mujoco><worldbody>' + _two_links() + "</worldbody></mujoco>")
    with pytest.raises(DescriptionError, match="DOCTYPE and entity declarations are not allowed in an MJCF file"):
        _load(p)


def test_malformed_xml_gives_mujocos_message(tmp_path):
    p = tmp_path / "bad.xml"
    p.write_text('<mujoco><worldbody><body><joint type="hinge"</worldbody></mujoco>')
    with pytest.raises(DescriptionError, match=r"MuJoCo cannot compile the file: XML parse error") as e:
        _load(p)
    assert "\n" not in str(e.value)


def test_compile_error_names_the_element(tmp_path):
    p = _model(tmp_path, ARM.format(inner='<body><joint name="jx" type="hinge" range="1 0" limited="true"/><geom size=".1" class="nope"/></body>'))
    with pytest.raises(DescriptionError, match=r"MuJoCo cannot compile the file: .*") as e:
        _load(p)
    assert "\n" not in str(e.value)


def test_missing_mesh_file(tmp_path):
    p = _model(tmp_path, ARM.format(inner='<body><joint/><geom type="mesh" mesh="part"/></body>'),
               '<asset><mesh name="part" file="missing_part.stl"/></asset>')
    with pytest.raises(DescriptionError, match=r"MuJoCo cannot compile the file: .*missing_part\.stl"):
        _load(p)


def test_other_xml_is_not_a_robot(tmp_path):
    p = tmp_path / "launch.xml"
    p.write_text('<launch><node pkg="x"/></launch>')
    with pytest.raises(NotARobotError, match=r"root element is <launch>, expected <mujoco>"):
        _load(p)


def test_scene_without_joints_is_not_a_robot(tmp_path):
    with pytest.raises(NotARobotError, match="no hinge, slide or free joint"):
        _load(_model(tmp_path, '<geom type="plane" size="1 1 0.1"/>'))


def test_too_large_file(tmp_path, monkeypatch):
    p = _model(tmp_path, _two_links())
    monkeypatch.setenv("MINPARAM_MAX_FILE_MB", "0.0001")
    with pytest.raises(DescriptionError, match="larger than the"):
        _load(p)


def test_floating_base_flag_without_free_joint(tmp_path):
    with pytest.raises(DescriptionError, match="--floating-base: an MJCF file declares its floating base itself"):
        load_chain(_model(tmp_path, _two_links()), DeriveOptions(floating_base=True))


def _cli(*args, cwd=None):
    env = {"PYTHONPATH": str(SRC), "PATH": "/usr/bin:/bin"}
    return subprocess.run([sys.executable, "-m", "minparam_cli", *args], capture_output=True, text=True, env=env, cwd=cwd, timeout=120)


def test_cli_one_line_exit_2_and_no_log_file(tmp_path):
    p = _model(tmp_path, ARM.format(inner='<body name="b"><joint name="ball1" type="ball"/><geom size="0.04"/></body>'))
    r = _cli("derive", str(p), cwd=tmp_path)
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr.strip().count("\n") == 0 and "ball joints are not supported yet" in r.stderr
    warn = tmp_path / "warn.xml"  # a deprecated attribute: MuJoCo warns; one line, no MUJOCO_LOG.TXT
    warn.write_text('<mujoco><compiler settotalmass="3"/><worldbody>' + _two_links() + "</worldbody></mujoco>")
    r = _cli("derive", str(warn), cwd=tmp_path)
    assert r.returncode == 0 and "minparam: warning:" in r.stderr and not (tmp_path / "MUJOCO_LOG.TXT").exists()


def test_folder_mode_skips_xml_that_is_not_mjcf(tmp_path):
    _model(tmp_path, _two_links(), name="arm.xml")
    (tmp_path / "launch.xml").write_text("<launch/>")
    r = _cli("derive", str(tmp_path), "--format", "jsonl")
    assert r.returncode == 0, r.stderr
    assert '"skipped"' in r.stdout and "arm.xml" in r.stdout


def test_missing_mujoco_names_the_extra(tmp_path, monkeypatch):
    from minparam_cli.errors import InputError

    monkeypatch.setitem(sys.modules, "mujoco", None)  # import mujoco raises ImportError
    with pytest.raises(InputError, match=r"reading MJCF \(\.xml\) robot files needs the mujoco library: pip install 'minparam\[mujoco\]'"):
        _load(_model(tmp_path, _two_links()))


def test_export_urdf_of_massless_frames_refused_before_the_data(tmp_path):
    data = tmp_path / "empty.csv"
    data.write_text("t,q1,q2,q3,q4,q5,tau1,tau2,tau3,tau4,tau5\n")
    arm = Path(__file__).parent / "data" / "mjcf" / "arm_coupled.xml"
    r = _cli("identify", str(arm), str(data), "--physical", "--export-urdf", str(tmp_path / "x.urdf"))
    assert r.returncode == 2 and r.stderr.strip().count("\n") == 0
    assert "--export-urdf:" in r.stderr and "massless frames the URDF export does not write yet" in r.stderr


def test_included_or_asset_file_that_is_not_a_regular_file(tmp_path):
    """MuJoCo opens what <include> and <mesh> name itself: a FIFO made it wait forever, /dev/zero read without end."""
    import os

    os.mkfifo(tmp_path / "parts.xml")
    p = _model(tmp_path, _two_links(), '<include file="parts.xml"/>', name="fifo.xml")
    with pytest.raises(DescriptionError, match=r'<include file="parts.xml">: .*parts.xml is a named pipe \(FIFO\), expected a regular file'):
        _load(p)
    mesh = _model(tmp_path, ARM.format(inner='<body><joint/><geom type="mesh" mesh="m"/></body>'),
                  '<asset><mesh name="m" file="/dev/zero"/></asset>', name="zero.xml")
    with pytest.raises(DescriptionError, match=r'<mesh file="/dev/zero">: /dev/zero is a character device'):
        _load(mesh)


def test_asset_files_too_large_together(tmp_path):
    """MuJoCo reads a mesh whole: assets over MAX_ASSET_BYTES together are refused before it runs (a
    sparse file: no disk space used)."""
    from minparam_cli.describe.mjcf_files import MAX_ASSET_BYTES

    with open(tmp_path / "big.stl", "wb") as f:
        f.truncate(MAX_ASSET_BYTES + 1)
    p = _model(tmp_path, ARM.format(inner='<body><joint/><geom type="mesh" mesh="m"/></body>'),
               '<asset><mesh name="m" file="big.stl"/></asset>', name="big.xml")
    with pytest.raises(DescriptionError, match=r'<mesh file="big.stl">: the model\'s asset files add up to more than 1024 MiB'):
        _load(p)


def test_an_attached_model_s_assets_are_checked_too(tmp_path):
    """<model file> names XML MuJoCo reads as well: a FIFO mesh inside the attached model hung the compiler."""
    import os

    (tmp_path / "parts").mkdir()
    os.mkfifo(tmp_path / "parts" / "pipe.stl")
    (tmp_path / "parts" / "sub.xml").write_text(
        '<mujoco model="sub"><asset><mesh name="m" file="pipe.stl"/></asset><worldbody><body name="b"><joint name="j"/>'
        '<geom type="mesh" mesh="m"/></body></worldbody></mujoco>')
    p = _model(tmp_path, ARM.format(inner='<attach model="sub" body="b" prefix="s_"/>'), '<asset><model name="sub" file="parts/sub.xml"/></asset>')
    with pytest.raises(DescriptionError, match=r'<mesh file="pipe.stl">: .*parts/pipe.stl is a named pipe \(FIFO\)'):
        _load(p)


def test_sibling_replicates_after_a_comment_with_dashes_are_not_multiplied(tmp_path):
    """lxml refuses "--" inside a comment, MuJoCo does not: the pattern fallback took three sibling counts of
    30 as nested (27,000 copies) and refused a legal file."""
    reps = "".join(f'<replicate count="30" offset="0.05 0 0"><geom size="0.01" pos="1 {i} 0"/></replicate>' for i in range(3))
    p = tmp_path / "reps.xml"
    p.write_text(f'<!-- ---------- section ---------- -->\n<mujoco model="t"><worldbody>{_two_links()}{reps}</worldbody></mujoco>')
    _, chain = _load(p)
    assert chain.dof == 2


def test_replication_bomb_is_refused_before_compiling(tmp_path):
    """Nested <replicate> counts multiply: 1000 x 1000 bodies kept MuJoCo's compiler busy for minutes."""
    bomb = ('<replicate count="1000" offset="0 0 0.01"><replicate count="1000" offset="0.01 0 0">'
            '<body><joint/><geom size=".01"/></body></replicate></replicate>')
    with pytest.raises(DescriptionError, match=r"replication makes 1000000 copies \(nested counts multiply\), more than the limit"):
        _load(_model(tmp_path, _two_links() + bomb))
    _, chain = _load(_model(tmp_path, _two_links() + '<replicate count="3" offset="1 0 0"><geom size=".01"/></replicate>', name="ok.xml"))
    assert chain.dof == 2


@pytest.mark.parametrize("change, match", [
    (('pos="0.2 0 0"', 'pos="nan 0 0"'), r"body\[b\]: body_pos is not finite after compiling"),
    (('pos="0.2 0 0"', 'pos="1e308 0 0"'), r"body\[b\]: body_pos is out of range after compiling"),
    (('mass="1"', 'mass="1e308"'), r"body\[a\]: body_mass is out of range after compiling"),
], ids=["nan-pos", "huge-pos", "huge-mass"])
def test_non_finite_or_huge_compiled_numbers(tmp_path, change, match):
    """MuJoCo compiles NaN (with a warning), inf and 1e308; they ended in an internal error (Fraction('nan'),
    OverflowError) or numpy's RuntimeWarnings on stderr."""
    p = _model(tmp_path, _two_links().replace(*change))
    with pytest.raises(DescriptionError, match=match):
        _load(p)


def test_mujoco_warning_is_one_line(tmp_path):
    """MuJoCo's warnings carry a second line ("Element name 'f', id 0"): shown as one."""
    import warnings

    from minparam_cli.errors import MinparamWarning

    p = _model(tmp_path, '<flexcomp name="f" type="grid" count="4 4 1" spacing=".1 .1 .1" dim="2"/>' + _two_links())
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        _load(p)
    notes = [str(w.message) for w in caught if issubclass(w.category, MinparamWarning)]
    assert notes and all("\n" not in n for n in notes) and "Element name 'f'" in notes[0]


def test_more_loop_equalities_than_joints(tmp_path):
    """Each active connect equality is a loop cut: 200 of them on a two-joint arm is refused before the loop analysis."""
    eqs = "".join(f'<connect name="c{i}" body1="b" body2="world" anchor="0 0 0"/>' for i in range(200))
    with pytest.raises(DescriptionError, match=r"equality\[c0\]: 200 active connect/weld equalities for 2 joints: at most one per joint"):
        _load(_model(tmp_path, _two_links(), f"<equality>{eqs}</equality>"))
