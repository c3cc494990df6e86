"""The fast tier (`python -m pytest -m "not slow"`) cannot rot silently: every entry of tests/slow_tests.txt
names collected tests, each names a fast sibling that is collected and not slow, every test file keeps a
fast test, and `-m` really leaves the listed tests out. Timing and coverage of the tier:
benchmarks/fast_tier.py (tests never fail on time)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import slow_list
from conftest import ROOT

TESTS = Path(__file__).resolve().parent


def _collect_everything(tmp_path: Path) -> list[tuple[str, bool]]:
    """(node id, slow) of every test, from a `--collect-only` run of the whole suite in a second process."""
    probe = tmp_path / "fast_tier_probe.py"
    probe.write_text(
        "import json, os, pytest, slow_list\n"
        "@pytest.hookimpl(trylast=True)\n"
        "def pytest_collection_finish(session):\n"
        "    with open(os.environ['FAST_TIER_PROBE_OUT'], 'w') as f:\n"
        "        json.dump(session.config.stash[slow_list.COLLECTED], f)\n"
    )
    out = tmp_path / "collected.json"
    env = {**os.environ, "FAST_TIER_PROBE_OUT": str(out),
           "PYTHONPATH": os.pathsep.join([str(tmp_path), str(TESTS), os.environ.get("PYTHONPATH", "")])}
    r = subprocess.run([sys.executable, "-m", "pytest", "--collect-only", "-q", "-p", "no:cacheprovider", "-p", "fast_tier_probe"],
                       cwd=ROOT, env=env, capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    return [(node, slow) for node, slow in json.loads(out.read_text())]


@pytest.fixture(scope="module")
def collected(request, tmp_path_factory) -> list[tuple[str, bool]]:
    """Every test of the suite with its `slow` mark: this session's collection when it took in the whole
    suite (a plain or `-m "not slow"` run), else one collection of the whole suite in a second process."""
    if slow_list.COLLECTED in request.config.stash:
        return request.config.stash[slow_list.COLLECTED]
    return _collect_everything(tmp_path_factory.mktemp("collect"))


def test_every_entry_names_collected_tests(collected):
    ids = {node for node, _ in collected}
    stale = [f"line {e.line}: {e.pattern}" for e in slow_list.read() if not any(e.matches(node) for node in ids)]
    assert not stale, stale


def test_every_sibling_is_a_collected_fast_test(collected):
    slow = dict(collected)
    bad = [f"line {e.line}: {e.sibling} ({'slow' if slow.get(e.sibling) else 'not collected'})"
           for e in slow_list.read() if slow.get(e.sibling, True)]
    assert not bad, bad


def test_the_marks_are_exactly_the_list(collected):
    """conftest marks what the list names and nothing else (no test is marked slow elsewhere)."""
    is_slow = slow_list.matcher(slow_list.read())
    assert [node for node, slow in collected if slow != is_slow(node)] == []
    assert any(slow for _, slow in collected) and not all(slow for _, slow in collected)


def test_every_test_file_keeps_a_fast_test(collected):
    files = {node.partition("::")[0] for node, _ in collected}
    fast = {node.partition("::")[0] for node, slow in collected if not slow}
    assert sorted(files - fast) == []


def test_minus_m_leaves_the_listed_cases_out(collected):
    """`-m "not slow"` on one file keeps exactly its tests the list leaves fast (the marks are set before
    pytest deselects)."""
    path = "tests/test_identify_scenarios.py"
    r = subprocess.run([sys.executable, "-m", "pytest", "--collect-only", "-q", "-p", "no:cacheprovider", "-m", "not slow", path],
                       cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    kept = {line for line in r.stdout.splitlines() if line.startswith(path + "::")}
    in_file = {node: slow for node, slow in collected if node.startswith(path + "::")}
    assert kept == {node for node, slow in in_file.items() if not slow}
    assert len(kept) < len(in_file)


def test_the_list_reader_refuses_a_line_without_a_sibling(tmp_path):
    p = tmp_path / "slow.txt"
    p.write_text("# comment\n\ntests/test_a.py::test_b[*] => tests/test_a.py::test_b[small]\ntests/test_a.py::test_c\n")
    with pytest.raises(ValueError, match="slow.txt:4: expected"):
        slow_list.read(p)


def test_a_pattern_marks_every_case_but_its_sibling(tmp_path):
    p = tmp_path / "slow.txt"
    p.write_text("tests/test_a.py::test_b[*] => tests/test_a.py::test_b[small]\n")
    is_slow = slow_list.matcher(slow_list.read(p))
    assert is_slow("tests/test_a.py::test_b[big]") and is_slow("tests/test_a.py::test_b[a*b c]")
    assert not is_slow("tests/test_a.py::test_b[small]") and not is_slow("tests/test_a.py::test_bb[big]")
