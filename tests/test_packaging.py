"""Packaging: an install without a C compiler says so, the version lives in one place, the licence
file is the one pyproject names, and the sdist carries what the tests read."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
KERNEL = ROOT / "src/minparam_cli/dynamics"


@pytest.mark.skipif(os.name != "posix", reason="CC names the compiler on POSIX systems only")
def test_building_without_a_compiler_warns_and_succeeds(tmp_path):
    """setup.py's build_ext with a compiler that does not exist: exit 0, a WARNING block, no kernel."""
    shutil.copy(ROOT / "setup.py", tmp_path)
    (tmp_path / "src/minparam_cli/dynamics").mkdir(parents=True)
    for name in ("_rnea.c", "_rnea_lanes.h"):
        shutil.copy(KERNEL / name, tmp_path / "src/minparam_cli/dynamics" / name)
    env = {**os.environ, "CC": str(tmp_path / "no-such-compiler")}
    r = subprocess.run([sys.executable, "setup.py", "-q", "build_ext", "-b", "lib", "-t", "tmp"], cwd=tmp_path, env=env,
                       capture_output=True, text=True, timeout=120, start_new_session=True)  # no terminal: stderr only
    assert r.returncode == 0, r.stderr
    assert "WARNING: minparam's compiled regressor kernel (minparam_cli.dynamics._rnea) was not built" in r.stderr
    assert "no-such-compiler" in r.stderr and "numpy regressor" in r.stderr and "C compiler" in r.stderr
    assert not list((tmp_path / "lib").rglob("_rnea*"))


def test_the_version_is_written_once():
    import minparam
    from minparam_cli import __version__

    pyproject = (ROOT / "pyproject.toml").read_text()
    assert re.search(r'^dynamic = \["version"\]', pyproject, re.M)
    assert not re.search(r"^version\s*=\s*\"", pyproject, re.M)  # no static version in [project]
    assert 'version = {attr = "minparam_cli.__version__"}' in pyproject
    assert re.fullmatch(r"\d+\.\d+\.\d+", __version__) and minparam.__version__ == __version__


def test_the_licence_file_is_the_one_pyproject_names():
    pyproject = (ROOT / "pyproject.toml").read_text()
    assert 'license = "BSD-3-Clause"' in pyproject and 'license-files = ["LICENSE"]' in pyproject
    text = (ROOT / "LICENSE").read_text()
    assert text.startswith("BSD 3-Clause License") and "the minparam authors" in text
    assert "Neither the name of the copyright holder" in text  # the third clause


def test_the_sdist_carries_what_the_tests_read():
    """Every top-level folder of the repository that the tests open is grafted into the sdist."""
    manifest = (ROOT / "MANIFEST.in").read_text().split("\n")
    grafted = {line.split()[1] for line in manifest if line.startswith("graft ")}
    assert {"tests", "robots", "examples", "docs", "benchmarks"} <= grafted
    read = set()
    for test in (ROOT / "tests").glob("*.py"):
        read |= set(re.findall(r"\"(robots|examples|docs|benchmarks)/", test.read_text()))
    assert read <= grafted
    included = {word for line in manifest if line.startswith("include ") for word in line.split()[1:]}
    assert {"LICENSE", "README.md"} <= included
