"""Property tests (hypothesis) of the loaders: a mutated shipped file gives a valid description
or the project's own input error, never another exception (issue 14, point 4)."""

from __future__ import annotations

import copy
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings, strategies as st  # noqa: E402

from minparam_cli.chain import build_chain  # noqa: E402
from minparam_cli.describe import RobotDescription, load_description  # noqa: E402
from minparam_cli.dynamics.bodies import body_verdicts  # noqa: E402
from minparam_cli.describe.platform_yaml import PlatformDescription, load_platform  # noqa: E402
from minparam_cli.errors import InputError  # noqa: E402
from minparam_cli.measured.records import DataOptions  # noqa: E402
from minparam_cli.measured.reading import raw_chunks  # noqa: E402

ROBOTS = Path(__file__).resolve().parents[1] / "robots"
ROBOT_FILES = sorted(p for p in ROBOTS.glob("*.yaml") if (yaml.safe_load(p.read_text()) or {}).get("kind", "robot") == "robot")
URDF_FILES = sorted(ROBOTS.glob("*.urdf"))
PLATFORM_FILES = [ROBOTS / "dodekapod_dang2013.yaml", *sorted((ROBOTS / "platforms").glob("*.yaml"))]
SETTINGS = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])

# values a careless or hostile file might hold where a number, a name or a list is expected
scalars = st.one_of(
    st.none(), st.booleans(), st.integers(min_value=-(10**30), max_value=10**30),
    st.floats(allow_nan=True, allow_infinity=True), st.sampled_from([1e308, -1e308, 5e-324, 1e6, 1e7, 0.0, -0.0]),
    st.text(max_size=20), st.sampled_from(["pi/0", "pi/2", "-pi", "7*pi/6", ".5pi", "1e999", "nan", "revolute", "dh", "mm"]),
)
values = st.recursive(scalars, lambda inner: st.one_of(st.lists(inner, max_size=4), st.dictionaries(st.text(max_size=6), inner, max_size=3)),
                      max_leaves=8)


def _paths(doc, prefix=()):
    """Every (path) to a value inside a nested dict/list document."""
    yield prefix
    if isinstance(doc, dict):
        for k, v in doc.items():
            yield from _paths(v, prefix + (k,))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            yield from _paths(v, prefix + (i,))


def _mutate(doc, path, value, delete):
    doc = copy.deepcopy(doc)
    if not path:
        return value
    parent = doc
    for key in path[:-1]:
        parent = parent[key]
    if delete and isinstance(parent, dict):
        del parent[path[-1]]
    else:
        parent[path[-1]] = value
    return doc


def _robot_or_input_error(path) -> None:
    """The loader returns a robot the chain builder takes, or raises the project's input error."""
    try:
        desc = load_description(path)
    except InputError:
        return
    _assert_valid_robot(desc)


def _assert_valid_robot(desc: RobotDescription) -> None:
    """A returned description is usable: finite values within the bounds, and a chain builds from it."""
    assert isinstance(desc, RobotDescription) and 1 <= desc.dof <= 128
    assert all(math.isfinite(g) and abs(g) <= 1e6 for g in desc.gravity)
    for gv in desc.geometry().values():
        assert math.isfinite(gv.value)
    chain = build_chain(desc)
    assert np.all(np.isfinite(chain.pre)) and np.all(np.isfinite(chain.post))
    body_verdicts(desc)  # a verdict, never an exception


@pytest.mark.parametrize("robot", ROBOT_FILES, ids=lambda p: p.name)
@SETTINGS
@given(data=st.data(), value=values, delete=st.booleans())
def test_mutated_robot_yaml(tmp_path, robot, data, value, delete):
    doc = yaml.safe_load(robot.read_text())
    path = data.draw(st.sampled_from(list(_paths(doc))))
    bad = _mutate(doc, path, value, delete)
    p = tmp_path / "r.yaml"
    p.write_text(yaml.safe_dump(bad, sort_keys=False))
    _robot_or_input_error(p)


@pytest.mark.parametrize("robot", ROBOT_FILES[:4] + URDF_FILES, ids=lambda p: p.name)
@SETTINGS
@given(data=st.data())
def test_byte_level_mutations(tmp_path, robot, data):
    """Bytes flipped, cut, repeated or inserted anywhere in a robot file."""
    raw = bytearray(robot.read_bytes())
    for _ in range(data.draw(st.integers(1, 4))):
        pos = data.draw(st.integers(0, max(len(raw) - 1, 0)))
        kind = data.draw(st.sampled_from(["flip", "cut", "insert", "repeat", "truncate"]))
        if kind == "flip" and raw:
            raw[pos] = data.draw(st.integers(0, 255))
        elif kind == "cut":
            del raw[pos : pos + data.draw(st.integers(1, 40))]
        elif kind == "insert":
            raw[pos:pos] = data.draw(st.sampled_from([b"&a ", b"*a", b"[", b"{", b"nan", b"1e999", b"<", b"&amp;", b"\x00", b"\t", b"9" * 80, b"pi/0"]))
        elif kind == "repeat":
            raw[pos:pos] = raw[pos : pos + 50] * data.draw(st.integers(2, 20))
        else:
            del raw[pos:]
    p = tmp_path / robot.name
    p.write_bytes(bytes(raw))
    _robot_or_input_error(p)


@pytest.mark.parametrize("urdf", URDF_FILES, ids=lambda p: p.name)
@SETTINGS
@given(data=st.data(), value=st.one_of(st.sampled_from(["nan", "inf", "-1", "1e308", "1e-320", "0 0 0", "1 2", "", "x", "1" * 70, "1e6", "-1e6"]),
                                       st.floats().map(repr)))
def test_mutated_urdf_attributes(tmp_path, urdf, data, value):
    """One numeric attribute of a URDF replaced by a hostile value."""
    import re

    text = urdf.read_text()
    spots = [m.span(2) for m in re.finditer(r'(value|ixx|ixy|ixz|iyy|iyz|izz|xyz|rpy|lower|upper)="([^"]*)"', text)]
    a, b = data.draw(st.sampled_from(spots))
    p = tmp_path / urdf.name
    p.write_text(text[:a] + value + text[b:])
    _robot_or_input_error(p)


@pytest.mark.parametrize("platform", PLATFORM_FILES, ids=lambda p: p.name)
@SETTINGS
@given(data=st.data(), value=values, delete=st.booleans())
def test_mutated_platform_yaml(tmp_path, platform, data, value, delete):
    from minparam_cli.kinematics.parallel.platform import platform_model
    from minparam_cli.kinematics.parallel.platform_truss import truss_model

    doc = yaml.safe_load(platform.read_text())
    path = data.draw(st.sampled_from(list(_paths(doc))))
    p = tmp_path / "p.yaml"
    p.write_text(yaml.safe_dump(_mutate(doc, path, value, delete), sort_keys=False))
    try:
        desc = load_platform(p)
    except InputError:
        return
    assert isinstance(desc, PlatformDescription)
    for xyz in desc.base_coords + desc.platform_coords:
        assert all(math.isfinite(c) and abs(c) <= 1e6 for c in xyz)
    (truss_model if desc.structure == "truss" else platform_model)(desc)


@pytest.fixture(scope="module")
def good_csv(tmp_path_factory) -> str:
    from typer.testing import CliRunner

    from minparam_cli.cli.app import app

    out = tmp_path_factory.mktemp("data") / "good.csv"
    r = CliRunner().invoke(app, ["simulate", str(ROBOTS / "planar2r.yaml"), "--duration", "1", "--rate", "100", "-o", str(out), "-q"])
    assert r.exit_code == 0, r.output
    return out.read_text()


@SETTINGS
@given(data=st.data())
def test_mutated_csv_data(tmp_path, good_csv, data):
    """A data CSV with cells, bytes or lines changed: the reader yields tables or raises DataError."""
    lines = good_csv.splitlines()
    for _ in range(data.draw(st.integers(1, 3))):
        i = data.draw(st.integers(0, len(lines) - 1))
        kind = data.draw(st.sampled_from(["cell", "drop", "dup", "garbage", "header"]))
        if kind == "cell":
            cells = lines[i].split(",")
            j = data.draw(st.integers(0, len(cells) - 1))
            cells[j] = data.draw(st.sampled_from(["nan", "inf", "", "x", "1e999", "-1e308", "1" * 400, "0x10", " "]))
            lines[i] = ",".join(cells)
        elif kind == "drop":
            del lines[i]
        elif kind == "dup":
            lines.insert(i, lines[i])
        elif kind == "garbage":
            lines[i] = data.draw(st.text(max_size=30))
        else:
            lines[0] = data.draw(st.sampled_from(["", "t", "t,q1,q2", "t,q1,q2,tau1,tau2,tau3", "\ufefft,q1,q2,dq1,dq2,tau1,tau2"]))
    p = tmp_path / "d.csv"
    p.write_bytes("\n".join(lines).encode("utf-8", "surrogatepass"))
    try:
        for table, _layout in raw_chunks(p, 2, DataOptions()):
            assert table.ndim == 2
    except InputError:
        return
