"""One test per kind of broken input: a one-line message naming file and element, exit code 2."""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from minparam_cli.cli.app import app
from minparam_cli.describe import load_description
from minparam_cli.errors import DescriptionError, UnsupportedError

GOOD_JOINT = "  - {type: revolute, alpha: 0, a: 1, d: 0, theta: 0}\n"
URDF_HEAD = '<?xml version="1.0"?>\n<robot name="r">\n'
LINK = '<link name="{n}"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>\n'
JOINT = '<joint name="{n}" type="{t}"><parent link="{p}"/><child link="{c}"/><axis xyz="0 0 1"/></joint>\n'


def write(tmp_path, name, text):
    p = tmp_path / name
    p.write_text(text)
    return p


def run_cli(*args):
    return CliRunner().invoke(app, list(map(str, args)))


def assert_cli_rejects(path, *needles):
    r = run_cli("derive", path)
    assert r.exit_code == 2, r.output
    lines = [ln for ln in r.output.strip().splitlines() if ln.strip()]
    assert len(lines) == 1, r.output
    assert "Traceback" not in r.output
    assert str(path) in lines[0]
    for n in needles:
        assert n in lines[0]


def yaml_robot(body_joints=GOOD_JOINT, head="convention: dh\n"):
    return head + "joints:\n" + body_joints


def test_missing_field(tmp_path):
    p = write(tmp_path, "r.yaml", yaml_robot("  - {type: revolute, alpha: 0, a: 1, theta: 0}\n"))
    with pytest.raises(DescriptionError, match=r"joints\[1\].*missing required field 'd'"):
        load_description(p)
    assert_cli_rejects(p, "missing required field 'd'")


def test_missing_convention(tmp_path):
    p = write(tmp_path, "r.yaml", "joints:\n" + GOOD_JOINT)
    assert_cli_rejects(p, "convention")


def test_unknown_joint_type(tmp_path):
    p = write(tmp_path, "r.yaml", yaml_robot("  - {type: spherical, alpha: 0, a: 1, d: 0, theta: 0}\n"))
    assert_cli_rejects(p, "joints[1].type", "unknown joint type 'spherical'")


def test_non_numeric_value(tmp_path):
    p = write(tmp_path, "r.yaml", yaml_robot("  - {type: revolute, alpha: 0, a: one, d: 0, theta: 0}\n"))
    assert_cli_rejects(p, "joints[1].a", "expected a number")


def test_unknown_unit(tmp_path):
    p = write(tmp_path, "r.yaml", yaml_robot(head="convention: dh\nunits: {length: furlong}\n"))
    assert_cli_rejects(p, "units.length", "furlong")


def test_malformed_yaml(tmp_path):
    p = write(tmp_path, "r.yaml", "convention: dh\njoints: [\n  - {type: revolute\n")
    assert_cli_rejects(p, "malformed YAML")


def test_yaml_tag_constructing_python_objects_is_refused(tmp_path):
    marker = tmp_path / "pwned"
    p = write(tmp_path, "r.yaml", f"convention: !!python/object/apply:os.system ['touch {marker}']\njoints: []\n")
    assert_cli_rejects(p, "malformed YAML")
    assert not marker.exists()


def test_empty_file(tmp_path):
    p = write(tmp_path, "r.yaml", "")
    assert_cli_rejects(p, "empty")
    u = write(tmp_path, "r.urdf", "")
    assert_cli_rejects(u, "empty")


def test_folder_with_no_robots(tmp_path):
    (tmp_path / "notes.txt").write_text("nothing here")
    r = run_cli("derive", tmp_path)
    assert r.exit_code == 2
    assert "no robot files" in r.output


def test_missing_path(tmp_path):
    r = run_cli("derive", tmp_path / "nope.yaml")
    assert r.exit_code == 2 and "no such file" in r.output


def test_malformed_xml(tmp_path):
    p = write(tmp_path, "r.urdf", URDF_HEAD + '<link name="a">\n</robot>\n')
    assert_cli_rejects(p, "malformed XML")


def test_urdf_missing_parent(tmp_path):
    body = LINK.format(n="base") + LINK.format(n="l1") + JOINT.format(n="j1", t="revolute", p="ghost", c="l1")
    p = write(tmp_path, "r.urdf", URDF_HEAD + body + "</robot>\n")
    assert_cli_rejects(p, "joint[j1]", "parent link 'ghost' is not defined")


def test_urdf_loop(tmp_path):
    body = (
        LINK.format(n="a") + LINK.format(n="b") + LINK.format(n="c")
        + JOINT.format(n="j1", t="revolute", p="a", c="b")
        + JOINT.format(n="j2", t="revolute", p="b", c="c")
        + JOINT.format(n="j3", t="revolute", p="c", c="a")
    )
    p = write(tmp_path, "r.urdf", URDF_HEAD + body + "</robot>\n")
    assert_cli_rejects(p, "loop")
    body2 = (
        LINK.format(n="a") + LINK.format(n="b") + LINK.format(n="c")
        + JOINT.format(n="j1", t="revolute", p="a", c="b")
        + JOINT.format(n="j2", t="revolute", p="b", c="c")
        + JOINT.format(n="j3", t="revolute", p="a", c="c")
    )
    p2 = write(tmp_path, "r2.urdf", URDF_HEAD + body2 + "</robot>\n")
    assert_cli_rejects(p2, "loops are not supported")


@pytest.mark.parametrize("jtype", ["planar"])  # floating roots: tests/test_floating_base.py
def test_urdf_planar_joint(tmp_path, jtype):
    body = LINK.format(n="a") + LINK.format(n="b") + JOINT.format(n="free", t=jtype, p="a", c="b")
    p = write(tmp_path, "r.urdf", URDF_HEAD + body + "</robot>\n")
    with pytest.raises(UnsupportedError, match="not supported yet"):
        load_description(p)
    assert_cli_rejects(p, "joint[free]", "not supported yet")


def test_urdf_missing_inertia_value_is_not_defaulted(tmp_path):
    link = '<link name="b"><inertial><mass value="1"/><inertia ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>\n'
    body = LINK.format(n="a") + link + JOINT.format(n="j1", t="revolute", p="a", c="b")
    p = write(tmp_path, "r.urdf", URDF_HEAD + body + "</robot>\n")
    assert_cli_rejects(p, "link[b]/inertial/inertia", "missing required attribute 'ixx'")


def test_xml_entity_bomb(tmp_path):
    bomb = (
        '<?xml version="1.0"?>\n<!DOCTYPE lolz [\n <!ENTITY lol "lol">\n'
        + "".join(f' <!ENTITY lol{i} "{("&lol" + (str(i - 1) if i > 1 else "") + ";") * 10}">\n' for i in range(1, 10))
        + ']>\n<robot name="&lol9;">' + LINK.format(n="a") + "</robot>\n"
    )
    p = write(tmp_path, "bomb.urdf", bomb)
    assert_cli_rejects(p)
    r = run_cli("derive", p)
    assert "DOCTYPE" in r.output or "entit" in r.output


def test_external_entity_is_not_read(tmp_path):
    secret = write(tmp_path, "secret.txt", "TOPSECRET")
    doc = f'<?xml version="1.0"?>\n<!DOCTYPE r [<!ENTITY x SYSTEM "file://{secret}">]>\n<robot name="&x;"></robot>\n'
    p = write(tmp_path, "xxe.urdf", doc)
    r = run_cli("derive", p)
    assert r.exit_code == 2 and "TOPSECRET" not in r.output


def test_oversized_file_is_refused_without_reading_it(tmp_path):
    from minparam_cli import safety

    p = tmp_path / "huge.yaml"
    with open(p, "wb") as fh:
        fh.seek(safety.MAX_FILE_BYTES + 10)
        fh.write(b"\n")
    assert_cli_rejects(p, "limit")


def test_too_many_joints(tmp_path):
    p = write(tmp_path, "r.yaml", yaml_robot(GOOD_JOINT * 200))
    assert_cli_rejects(p, "exceed the limit")


def test_bad_cli_values():
    r = run_cli("derive", "robots/planar2r.yaml", "--friction", "sticky")
    assert r.exit_code == 2 and "sticky" in r.output
    r = run_cli("derive", "robots/planar2r.yaml", "--gravity", "0,1")
    assert r.exit_code == 2 and "3" in r.output
    r = run_cli("derive", "robots/planar2r.yaml", "--method", "magic")
    assert r.exit_code == 2 and "magic" in r.output


def test_failed_run_writes_no_output_file(tmp_path):
    bad = write(tmp_path, "bad.yaml", "convention: dh\njoints: 3\n")
    out = tmp_path / "out.json"
    r = run_cli("derive", bad, "--format", "json", "-o", out)
    assert r.exit_code == 2
    assert not out.exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".out.json")]


def test_a_yaml_key_that_is_a_list_or_a_mapping_is_one_line(tmp_path):
    """'? [1, 2]' makes a list key: hashing it raised TypeError (unhashable) inside the loader."""
    from typer.testing import CliRunner

    from minparam_cli.cli.app import app

    for key in ("? [1, 2]\n: 3\n", "? {a: 1}\n: 3\n"):
        p = tmp_path / "k.yaml"
        p.write_text("name: x\n" + key)
        r = CliRunner().invoke(app, ["derive", str(p)])
        assert r.exit_code == 2 and "a key must be a plain value" in r.output and len(r.output.strip().splitlines()) == 1


@pytest.mark.parametrize("prolog", ['<?xml version="0.0" ?>\n', '\n\n<?xml version="1.0"?>\n',
                                    '\ufeff <?xml version="1.0" encoding="not-a-codec"?>\n'],
                         ids=["version-0.0", "blank-lines-first", "bom-unknown-encoding"])
def test_xml_declarations_urdfdom_reads_are_read(tmp_path, prolog):
    """urdfdom (TinyXML2) reads these prologs (pybullet's minitaur and diff_ring files); so does minparam,
    and a malformed body still reports its own line number."""
    body = LINK.format(n="base") + LINK.format(n="l1") + JOINT.format(n="j1", t="revolute", p="base", c="l1")
    p = write(tmp_path, "r.urdf", prolog + URDF_HEAD.split("?>", 1)[1].lstrip("\n") + body + "</robot>\n")
    r = run_cli("derive", p)
    assert r.exit_code == 0, r.output
    bad = write(tmp_path, "bad.urdf", prolog + '<robot name="x">\n<link name="a">\n</robot>\n')
    r = run_cli("derive", bad)
    n_line = (prolog.count("\n") + 3)
    assert r.exit_code == 2 and "malformed XML" in r.output and f"line {n_line}" in r.output, r.output


def test_doctype_after_a_lenient_prolog_is_still_refused(tmp_path):
    p = write(tmp_path, "r.urdf", '\n<?xml version="0.0"?>\n<!DOCTYPE r [<!ENTITY a "b">]>\n<robot name="x"/>\n')
    assert_cli_rejects(p, "DOCTYPE")


def test_yaml_joint_name_used_twice(tmp_path):
    """URDF, MJCF and closed-chain files refuse it; a DH table took it, and an export then wrote joints a
    URDF reader refuses ("joint 'shoulder' is defined twice")."""
    p = write(tmp_path, "r.yaml", yaml_robot(GOOD_JOINT.replace("{type", "{name: shoulder, type") * 2))
    assert_cli_rejects(p, "joints[2].name", "joint name 'shoulder' is used twice")
    named_like_a_default = write(tmp_path, "d.yaml", yaml_robot(GOOD_JOINT.replace("{type", "{name: joint2, type") + GOOD_JOINT))
    assert_cli_rejects(named_like_a_default, "joints[2].name", "joint name 'joint2' is used twice (joint 2's default name)")
