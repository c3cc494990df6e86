"""A library call leaves its host process as it found it (issue 30, point 4).

``warnings.catch_warnings`` saves and restores the process-wide ``warnings.filters``: two calls that
overlap on two threads restore each other's state, and the process may end up ignoring every warning
for good.  So no library call may touch the filters (numpy's own floating-point warnings are silenced
with ``np.errstate``, which is local to the thread).
"""

from __future__ import annotations

import threading
import warnings
from pathlib import Path

import pytest

import minparam

ROOT = Path(__file__).resolve().parents[1]
ROBOT = ROOT / "robots/planar2r.yaml"
WAIT_S = 120  # a bound on the waits below, so that a broken call fails the test instead of hanging it


@pytest.fixture(scope="module")
def arrays():
    data = minparam.simulate(ROBOT, effects="viscous", noise=0.02, duration=4, seed=3).arrays()
    # once first: what identify imports on first use is imported (scipy.special adds a filter of
    # its own for its own warnings when it is imported, as any import may)
    minparam.identify(ROBOT, data)
    return data


def test_two_overlapping_identify_calls_leave_the_warnings_filters_as_they_were(arrays):
    """The first call enters, then the second; the first returns while the second is still inside.
    (The order is the one in which a save-and-restore of the filters leaks the first call's state.)"""
    first_in, second_in, first_done = threading.Event(), threading.Event(), threading.Event()
    errors: list[BaseException] = []

    def first_progress(done, total):
        first_in.set()
        second_in.wait(WAIT_S)

    def second_progress(done, total):
        second_in.set()
        first_done.wait(WAIT_S)

    def call(progress, done_event):
        try:
            minparam.identify(ROBOT, arrays, progress=progress)
        except BaseException as e:  # reported by the main thread
            errors.append(e)
        finally:
            if done_event is not None:
                done_event.set()
            first_in.set()
            second_in.set()

    before = list(warnings.filters)
    one = threading.Thread(target=call, args=(first_progress, first_done))
    two = threading.Thread(target=call, args=(second_progress, None))
    one.start()
    assert first_in.wait(WAIT_S)
    two.start()
    one.join(WAIT_S)
    two.join(WAIT_S)
    assert not one.is_alive() and not two.is_alive()
    assert not errors, errors
    assert warnings.filters == before


class FilterChanges:
    """Counts the changes of the process-wide warnings filters while it is on (``warnings`` tells
    itself of each one: simplefilter, filterwarnings, catch_warnings' entry and exit)."""

    def __init__(self):
        self.count = 0
        self._real = warnings._filters_mutated

    def _mutated(self):
        self.count += 1
        self._real()

    def __enter__(self):
        warnings._filters_mutated = self._mutated
        return self

    def __exit__(self, *exc):
        warnings._filters_mutated = self._real


def test_identify_on_a_csv_file_never_touches_the_warnings_filters(arrays, tmp_path, monkeypatch):
    """Not even for a moment (another thread would see it): numpy's CSV reader, blank lines included."""
    import numpy as np

    n = arrays["q"].shape[1]
    path = tmp_path / "d.csv"
    with open(path, "w") as fh:
        fh.write(",".join(["t"] + [f"{k}{j}" for k in ("q", "dq", "ddq", "tau") for j in range(1, n + 1)]) + "\n\n")
        np.savetxt(fh, np.hstack([arrays["t"][:, None], arrays["q"], arrays["dq"], arrays["ddq"], arrays["tau"]]),
                   delimiter=",", fmt="%.17g")
    monkeypatch.setenv("MINPARAM_CSV_READER", "numpy")
    before = list(warnings.filters)
    with FilterChanges() as changes:
        minparam.identify(ROBOT, path)
    assert changes.count == 0 and warnings.filters == before


def test_the_chain_stays_frozen_and_its_derived_values_go_with_it():
    """Values computed from a chain (its exact geometry, the kernel's arrays) are kept beside it,
    never written into it, and are dropped with it."""
    import gc
    import weakref

    import numpy as np

    from minparam_cli.chain import _DERIVED, build_chain
    from minparam_cli.describe import load_description
    from minparam_cli.dynamics.regressor import regressor

    chain = build_chain(load_description(str(ROOT / "robots/puma560.yaml")))
    before = dict(vars(chain))
    q = np.random.default_rng(0).standard_normal((3, chain.dof))
    first = regressor(chain, q, q, q)
    assert chain.exact is not None and chain.exact is chain.exact
    assert np.array_equal(regressor(chain, q, q, q), first)
    assert vars(chain).keys() == before.keys() and all(vars(chain)[k] is v for k, v in before.items())
    assert {"exact", "local_terms"} <= _DERIVED[chain].keys()
    gone, kept = weakref.ref(chain), len(_DERIVED)
    del chain
    gc.collect()
    assert gone() is None and len(_DERIVED) == kept - 1


def test_library_calls_leave_the_process_settings_alone():
    """The allocator tuning, the BLAS thread variables and the collector's freeze are the CLI's
    (cli/app.py), never a library call's: a fresh process that only imports and calls minparam."""
    import os
    import subprocess
    import sys

    code = (
        "import gc, os, sys\n"
        "from minparam_cli import runtime\n"
        "called = []\n"
        "for name in ('single_thread_blas', 'tune_allocator', 'freeze_before_exit'):\n"
        "    setattr(runtime, name, lambda name=name: called.append(name))\n"
        "env = dict(os.environ)\n"
        "import minparam\n"
        "minparam.derive('robots/planar2r.yaml')\n"
        "s = minparam.simulate('robots/planar2r.yaml', effects='viscous', duration=3, seed=1)\n"
        "minparam.identify('robots/planar2r.yaml', s.arrays())\n"
        "print(called, gc.get_freeze_count(), dict(os.environ) == env, 'minparam_cli.cli.app' in sys.modules)\n"
    )
    env = {k: v for k, v in os.environ.items() if not k.endswith("_NUM_THREADS")}
    r = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=300,
                       env={**env, "PYTHONPATH": str(ROOT / "src")})
    assert r.returncode == 0, r.stderr
    assert r.stdout.split("\n")[-2] == "[] 0 True False"


@pytest.mark.parametrize("rows", [7, 10, 40])  # 40 rows of data: 10 and 40 end on an empty read
def test_the_numpy_csv_reader_warns_about_nothing_and_reads_what_loadtxt_reads(tmp_path, rows):
    """Blank and comment lines, and a file of exactly k chunks, made loadtxt warn (they were silenced
    by a process-wide filter); the reader now skips them itself: the same chunks, no warning."""
    import numpy as np

    from minparam_cli.measured import tables

    lines = ["t,q1,tau1"]
    for i in range(40):
        lines.append(f"{i / 10},{i * 0.5},{-i}")
        if i % 9 == 4:
            lines.append("" if i % 2 else "# a note")
    path = tmp_path / "d.csv"
    path.write_text("\n".join(lines) + "\n\n# the end\n")

    def loadtxt_chunks():  # numpy's own reading, its warnings silenced here
        out = []
        with open(path) as fh, warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fh.readline()
            while True:
                out.append(np.loadtxt(fh, delimiter=",", max_rows=rows, ndmin=2))
                if out[-1].size == 0 or len(out[-1]) < rows:
                    return out

    expected = loadtxt_chunks()
    with open(path) as fh, warnings.catch_warnings(record=True) as heard:
        warnings.simplefilter("always")
        fh.readline()
        with FilterChanges() as changes:
            got = list(tables._sequential(fh, rows))
    assert not heard and changes.count == 0, [str(w.message) for w in heard]
    assert len(got) == len(expected) and all(a.shape == b.shape and np.array_equal(a, b) for a, b in zip(got, expected, strict=True))
    assert sum(len(c) for c in got) == 40
