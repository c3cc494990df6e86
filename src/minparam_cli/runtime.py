"""Process-wide settings for minparam's own processes (the CLI and the benchmarks), the
number of worker threads a pool may use (``workers``, the one place that asks the machine), and
the chunk and block sizes of identify's streaming pass (constants only: the one place to tune them).

``single_thread_blas``, ``tune_allocator`` and ``freeze_before_exit`` change the
whole process: only the CLI's entry point (``cli/app.py``: ``main`` and
``entry``), the benchmarks and the test suite's conftest (``single_thread_blas``,
so that the tests run the CLI's arithmetic) call them; importing minparam as a library or
calling ``minparam.<command>()`` never does (a library must not change its
host process).  ``workers`` only reads.

``tune_allocator``: glibc hands every freed block above 128 KiB straight back
to the kernel (``M_MMAP_THRESHOLD``), so a loop that builds a regressor block
of a few hundred KiB to a few MiB, uses it and drops it pays the kernel's
page faults again on every pass.  On the 2-core VM of the benchmarks that was
about half the time of the 100-sample base-set computation (354 faults per
regressor call, 0 after tuning).  Raising the thresholds keeps freed blocks in
the heap for reuse; peak memory is unchanged, the process just keeps it until
exit.  Linux with glibc only; elsewhere it does nothing and says so.

It also keeps every thread on the main heap (``M_ARENA_MAX`` = 1): glibc gives a
second thread an arena of its own, made of 64 MiB heaps that are mapped, given
back and mapped again as blocks of 10-20 MiB come and go.  ``identify``'s
streaming pass builds its regressor rows on a second thread (identify.ahead):
with a second arena the 1 M-sample Panda run took 550 000-840 000 page faults
and 1.7-2.6 s of system time, with one arena 38 000 faults and 0.3-0.5 s.  The
threads allocate a few hundred blocks a second, so sharing the arena's lock
costs nothing measurable.

``freeze_before_exit``: when the interpreter shuts down it clears every
module and runs full garbage collections over everything still alive: the
tens of thousands of objects numpy, click, typer and PyYAML create at import.
That took about 20 ms of a 270 ms ``minparam derive`` on the benchmark VM.
``gc.freeze()`` moves the live objects to the collector's permanent
generation, which those collections skip; the memory goes back to the system
with the process, as it would anyway.  atexit handlers, flushes and the
finalizers of objects freed by reference counting still run; objects held
only by reference cycles at that point are not collected, so their
``__del__`` does not run (Python does not promise it at exit either).  The
console script calls it right before the process exits, never ``main()``
itself: a long-lived caller would keep those cycles for good.

The streaming pass's sizes (chunk rows, pyarrow's block, regressor blocks, queue depths) are here
too, each with the measurement that chose it (1 M-sample Panda CSV, 351 MB,
``benchmarks/bench_identify.py``, the 2-core development machine; docs/methods/streaming.md).  None
of them changes what is computed, only how it is cut up: other chunk and block edges sum the same
rows in another order, so results agree to rounding (``tests/test_identify_tuning.py`` holds
identify's report equal to 1e-10 relative with every one of them changed).  The numerical
thresholds that decide a result (the fast factor update's FLOOR and LIMIT, the diagnosis's sample
cap) stay with their methods.
"""

from __future__ import annotations

import gc
import os
import sys
import threading

M_TRIM_THRESHOLD = -1
M_MMAP_THRESHOLD = -3
M_ARENA_MAX = -8
MMAP_THRESHOLD_BYTES = 32 * 1024 * 1024  # glibc's ceiling for this setting on 64-bit systems
TRIM_THRESHOLD_BYTES = 256 * 1024 * 1024

BLAS_THREAD_VARS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")

# rows read at a time: 5.8 MB for 29 columns; with identify's reading thread a chunk ahead, 1 M-sample
# Panda runs peaked at 260-272 MB (290-295 MB with 50,000, same speed)
CHUNK_ROWS = 25_000

# pyarrow's streaming block, parsed on the reading thread (with use_threads its read-ahead held 40
# blocks: 40 MB at 1 MB, 160 MB at 4 MB, and on the 2-core machine one thread parsed no slower while
# identify's other threads need the cores). 512 KB: half the Python calls per MB of the 256 KB used
# before (29 column copies a block); the 1 M-sample run 0.2 s faster, peak 271-281 MB; 1 MB was
# faster still but peaked at 291-301 MB
CSV_BLOCK_BYTES = 2**19

# numpy's reader (no pyarrow): a CSV file larger than this is parsed by a second process one chunk
# ahead (measured.tables), the parse then overlaps with the rest of the pass
BACKGROUND_BYTES = 64 * 2**20

# samples a block of regressor rows: n x (p + slots + 1) x 4096 numbers, 14 MB for the Panda. 8192
# peaked 20-30 MB higher and was no faster; 2048 was no faster either (300 k-sample runs, load 7-10)
REGRESSOR_ROWS = 4096

# items queued between identify's threads (identify.passes.ahead): filtered chunks between the
# reading thread and the rows thread, row blocks between the rows thread and the factor updates. A
# deeper queue was slower on two cores and holds one more chunk or block of memory per step
READ_AHEAD = 1
ROWS_AHEAD = 2

# samples of the thinned diagnosis sample factored at a time (its catalogue is ~180 columns a joint:
# 1024 x 180 x 7 joints is 10 MB of rows, and as much again for the columns before they are joined). The
# diagnosis runs while the test data are still being read (identify.passes.stream.Pass): with 2048 the
# 1 M-sample Panda run peaked at 333 MB beside the pass's buffers, with 1024 at 268-283 MB
DIAGNOSIS_QR_ROWS = 1024


def single_thread_blas() -> None:
    """One BLAS thread unless the user chose otherwise: the matrices here are small, and batch
    runs parallelise over robots (--jobs).  Must run before numpy is imported."""
    for var in BLAS_THREAD_VARS:
        os.environ.setdefault(var, "1")


def tune_allocator() -> bool:
    """Keep freed blocks up to 32 MiB in the heap, and every thread on it (glibc); True when applied."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        import ctypes

        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):  # not glibc (e.g. musl without mallopt)
        return False
    ok = mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES) == 1
    ok = mallopt(M_TRIM_THRESHOLD, TRIM_THRESHOLD_BYTES) == 1 and ok
    ok = mallopt(M_ARENA_MAX, 1) == 1 and ok
    return ok


def freeze_before_exit() -> None:
    """Spare the interpreter's shutdown a full collection over every object alive now."""
    gc.freeze()


# scipy's modules identify's pass needs, imported on a thread of their own while the pass reads its
# first rows (``preload``); every other import of scipy in the pass waits for that thread first
# (``await_preload``): two threads importing scipy's submodules at once can meet one partly initialised
# (scipy's package imports itself in a circle; seen once in six runs of examples/identify_arrays.py:
# "cannot import name 'PytestTester' from partially initialized module 'scipy._lib._testutils'").
# One lock, taken by ``preload`` before its thread starts and given back by that thread when its imports
# are done: passes that run at once in one process (threads of a Dask worker, a user's pool) preload one
# after the other, and ``await_preload`` returns only when no preload is under way.
_IMPORTING = threading.Lock()


def preload(*modules: str) -> None:
    """Import ``modules`` on a daemon thread (see ``await_preload``)."""
    import importlib

    def run() -> None:
        try:
            for m in modules:
                try:
                    importlib.import_module(m)
                except ImportError:  # the caller's own import says what is missing
                    pass
        finally:
            _IMPORTING.release()

    _IMPORTING.acquire()
    try:
        threading.Thread(target=run, name="minparam-import", daemon=True).start()
    except BaseException:
        _IMPORTING.release()
        raise


def await_preload() -> None:
    """Wait until no ``preload`` is importing; call before importing scipy on any thread while a pass may run."""
    with _IMPORTING:
        pass


def workers(cap: int) -> int:
    """Threads for a pool of ``cap`` tasks at most: the CPUs this process may run on (``os.cpu_count()``
    where the platform cannot say), at least 1.  No result depends on it: every pool combines its
    tasks' results in task order."""
    try:
        cpus = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # not Linux
        cpus = os.cpu_count() or 1
    return max(1, min(cap, cpus))
