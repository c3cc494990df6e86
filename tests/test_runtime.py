"""Process settings of the CLI: the allocator tuning removes the page faults of repeated blocks."""

from __future__ import annotations

import subprocess
import sys

import pytest
from conftest import ROOT

SCRIPT = """
import resource
from minparam_cli.base.qr import derive_qr
from minparam_cli.chain import build_chain
from minparam_cli.describe import load_description
from minparam_cli.runtime import tune_allocator

chain = build_chain(load_description("robots/panda.yaml"))

def faults():
    r0 = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    for _ in range(20):
        derive_qr(chain, samples=300)
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt - r0

faults()
before = faults()
applied = tune_allocator()
faults()  # the first passes after tuning grow the heap once
after = faults()
print(before, int(applied), after)
"""

@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc mallopt is Linux-only")
def test_tuned_allocator_reuses_freed_blocks():
    out = subprocess.run(
        [sys.executable, "-c", SCRIPT], capture_output=True, text=True, check=True, cwd=ROOT
    ).stdout.split()
    before, applied, after = map(int, out)
    if not applied:
        pytest.skip("not glibc: mallopt unavailable, tuning reported as not applied")
    assert before >= 20 * 50  # the regressor blocks are mapped and faulted in afresh on every call
    assert after <= before // 10


def test_await_preload_returns_once_the_preloaded_modules_are_imported(tmp_path, monkeypatch):
    """identify's pass imports scipy on a thread of its own (``runtime.preload``); every other scipy import of
    the pass waits for it (two threads importing scipy's submodules at once can meet one partly initialised)."""

    from minparam_cli import runtime

    (tmp_path / "minparam_slow_module.py").write_text("import time\ntime.sleep(0.3)\nDONE = True\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, "minparam_slow_module", raising=False)
    runtime.preload("minparam_slow_module", "minparam_no_such_module")  # a missing one is the caller's to report
    assert "minparam_slow_module" not in sys.modules or not hasattr(sys.modules["minparam_slow_module"], "DONE")
    runtime.await_preload()
    assert sys.modules["minparam_slow_module"].DONE and not runtime._IMPORTING.locked()
    monkeypatch.delitem(sys.modules, "minparam_slow_module")


def test_passes_that_start_at_once_preload_one_after_the_other(tmp_path, monkeypatch):
    """Two passes in one process (a Dask worker's threads, a user's pool): the second preload waits for the
    first, so their imports never run side by side, and await_preload waits for both."""
    import threading

    from minparam_cli import runtime

    (tmp_path / "minparam_slow_a.py").write_text("import time, minparam_log\nminparam_log.append('a0')\ntime.sleep(0.2)\nminparam_log.append('a1')\n")
    (tmp_path / "minparam_slow_b.py").write_text("import minparam_log\nminparam_log.append('b')\n")
    log: list = []
    monkeypatch.setitem(sys.modules, "minparam_log", log)
    monkeypatch.syspath_prepend(str(tmp_path))
    for m in ("minparam_slow_a", "minparam_slow_b"):
        monkeypatch.delitem(sys.modules, m, raising=False)
    runtime.preload("minparam_slow_a")
    other = threading.Thread(target=runtime.preload, args=("minparam_slow_b",))
    other.start()
    other.join()
    runtime.await_preload()
    assert log == ["a0", "a1", "b"]


def test_the_pass_waits_for_the_preload_before_its_own_scipy_imports(monkeypatch):
    """The factor update's LAPACK pointers and the filter's design import scipy only after the preload."""
    from minparam_cli.identify.estimate import nogil_lapack
    from minparam_cli.measured import filtering

    calls = []
    for mod in (nogil_lapack, filtering):
        monkeypatch.setattr(mod, "await_preload", lambda mod=mod: calls.append(mod.__name__))
    nogil_lapack._routine.cache_clear()
    try:
        nogil_lapack._routine("cython_blas", "dtrsm")
    finally:
        nogil_lapack._routine.cache_clear()
    import inspect

    assert calls == ["minparam_cli.identify.estimate.nogil_lapack"]
    src = inspect.getsource(filtering)  # every scipy import of the filter comes after a wait
    lines = src.splitlines()
    for i, line in enumerate(lines):
        if "from scipy" in line:
            assert "await_preload()" in lines[i - 1], line
