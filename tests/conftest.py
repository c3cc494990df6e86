"""Shared fixtures: the robot files shipped in robots/."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest
import yaml

from minparam_cli import runtime

# One BLAS thread, as the CLI runs (cli/app.py calls this before numpy is imported; here it runs before any
# test module imports numpy). OpenBLAS's default, a thread per core, made the tests run other arithmetic than
# the CLI and, on the 2-core machine with another job on the second core, spin: a 1,500-sample Panda identify
# took 30 s of wall and 31 s of CPU instead of 3.8 s and 3.4 s (tests/test_identify_tuning.py, load 2.7).
runtime.single_thread_blas()
ROOT = Path(__file__).resolve().parents[1]
ROBOTS = ROOT / "robots"
SHARED = ROOT.parent / "shared"
sys.path.insert(0, str(Path(__file__).resolve().parent))


# robots/*.xml (MJCF) need the [mujoco] extra (looked up, not imported: every test run would pay for it)
_HAS_MUJOCO = importlib.util.find_spec("mujoco") is not None


def robot_files() -> list[Path]:
    """Every robot description in robots/ (platform descriptions excluded)."""
    out = []
    for p in sorted(ROBOTS.iterdir()):
        if p.suffix in (".yaml", ".yml"):
            doc = yaml.safe_load(p.read_text())
            if isinstance(doc, dict) and doc.get("kind", "robot") != "robot":
                continue
            out.append(p)
        elif p.suffix == ".urdf" or (p.suffix == ".xml" and _HAS_MUJOCO):
            out.append(p)
    return out


ROBOT_FILES = robot_files()
# closed chains in robots/ (kind: closed_chain, or a platform with dynamics): derive reads them too
CLOSED_FILES = [p for p in sorted(ROBOTS.glob("*.yaml"))
                if (d := yaml.safe_load(p.read_text())) and (d.get("kind") == "closed_chain" or "dynamics" in d)]
ROBOT_IDS = [p.name for p in ROBOT_FILES]


@pytest.fixture(params=ROBOT_FILES, ids=ROBOT_IDS)
def robot_path(request) -> Path:
    return request.param


@pytest.fixture(autouse=True)
def _run_from_repository_root(monkeypatch):
    """Tests name robot files relative to the repository root."""
    monkeypatch.chdir(ROOT)


# A two-link arm whose joints take extra YAML keys (limits): tests/test_motion_limits.py, tests/test_excite.py
ARM = """name: limited 2R
convention: dh
units: {{length: m, angle: deg}}
gravity: [0, -9.81, 0]
joints:
  - {{name: shoulder, type: revolute, alpha: 0, a: 1.0, d: 0, theta: 0, limits: [-90, 90], {j1}
     inertial: {{mass: 2.0, com: [-0.5, 0, 0], inertia: [0.01, 0, 0, 0.17, 0, 0.17]}}}}
  - {{name: elbow, type: revolute, alpha: 0, a: 0.8, d: 0, theta: 0, limits: [-120, 120], {j2}
     inertial: {{mass: 1.5, com: [-0.4, 0, 0], inertia: [0.01, 0, 0, 0.08, 0, 0.08]}}}}
"""


def arm(tmp_path, j1: str = "", j2: str = "", name: str = "arm.yaml") -> str:
    p = tmp_path / name
    p.write_text(ARM.format(j1=j1, j2=j2))
    return str(p)


def cli(*args):
    """The real entry point (``minparam ARGS``) in this process; arguments may be paths or numbers."""
    from typer.testing import CliRunner

    from minparam_cli.cli.app import app

    return CliRunner().invoke(app, [str(a) for a in args])


def refused(*args, needle: str) -> str:
    """``cli`` that must refuse: exit 2 with one line (no usage text, no traceback) containing ``needle``."""
    r = cli(*args)
    lines = [ln for ln in r.output.strip().splitlines() if ln.strip()]
    assert r.exit_code == 2 and len(lines) == 1 and "Traceback" not in r.output, r.output
    assert needle in lines[0], lines[0]
    return lines[0]


def cli_ok(*args):
    """``cli`` that must succeed (exit 0), its output shown otherwise."""
    r = cli(*args)
    assert r.exit_code == 0, r.output
    return r


@pytest.hookimpl(tryfirst=True)  # before pytest's own hook deselects by `-m`
def pytest_collection_modifyitems(config, items):
    """Mark `slow` the tests tests/slow_tests.txt names (why a list file: tests/slow_list.py)."""
    import slow_list

    is_slow = slow_list.matcher(slow_list.read())
    seen = []
    for item in items:
        slow = is_slow(node_id(item))
        if slow:
            item.add_marker(pytest.mark.slow)
        seen.append((node_id(item), slow))
    if _whole_suite(config):  # tests/test_fast_tier.py checks the list against it
        config.stash[slow_list.COLLECTED] = seen


def _whole_suite(config) -> bool:
    """This session collects every test file: started on tests/ or the repository (or on testpaths), nothing ignored."""
    here = config.invocation_params.dir
    named = {(here / arg.partition("::")[0]).resolve() for arg in config.args}
    ignored = config.getoption("ignore", None) or config.getoption("ignore_glob", None)
    return bool(named & {ROOT, ROOT / "tests"}) and not ignored


def node_id(item) -> str:
    """The test's node id relative to the repository root, whichever folder pytest was started from."""
    return item.path.relative_to(ROOT).as_posix() + item.nodeid[item.nodeid.index("::"):]
