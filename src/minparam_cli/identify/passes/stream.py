"""identify's one pass over the data: the per-joint factors of every part (fit, selection, tests),
the block Gram matrices of σ, the thinned diagnosis samples and the motion, with memory bounded by
the chunk size, not the file (see docs/methods/streaming.md)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from minparam_cli.errors import DataError
from minparam_cli.identify.estimate.accumulate import NonFiniteRows
from minparam_cli.measured.blocks import iter_blocks
from minparam_cli.identify.passes.design import Design
from minparam_cli.dynamics.effects import source_columns
from minparam_cli.identify.estimate.fit import Accumulator
from minparam_cli.identify.passes.kept import Motion, _Thinned
from minparam_cli.identify.passes.roles import FIT, SELECTION, Source, parts
from minparam_cli.identify.passes.slots import block_rows
from minparam_cli.measured.records import Block, DataOptions, DataReport
from minparam_cli.runtime import READ_AHEAD, REGRESSOR_ROWS, ROWS_AHEAD, await_preload, preload


EARLY = object()  # the rows' marker: every fit and selection sample comes before it
OWN_THREAD = True  # False: the pass runs on the caller's thread, before Pass() returns (benchmarks/profile_identify.py)


def stream(design: Design, sources: list[Source], n: int, data: DataOptions, diagnosis_cap: int, keep: bool, slots=(),
           grams=None):
    """One pass over the data: per-joint factors of [design columns | slot columns | τ] for every part
    (fit, selection, test1, ...), the thinned diagnosis samples (fit and selection), the motion of
    the fit part, the data reports, and the design with its drift origin set (``Pass.result``)."""
    running = Pass(design, sources, n, data, diagnosis_cap, keep, slots, grams)
    try:
        return running.result()
    finally:
        running.close()


class Pass:
    """``stream`` on a thread of its own, so that the caller can go on as soon as the fit and selection
    data are in (``early``) while the test data are still being read (``result``): identify's
    diagnosis never sees the test data, and runs beside their reading.

    Three threads (``identify.ahead``): one reads and filters the file, one builds the rows of the
    regressor and the slot columns, and one folds them into the factors; the parser, the kernel,
    numpy's ufuncs and BLAS release the GIL, so the three overlap on two cores.  The rows reach the
    factors in the same order as on one thread, so every number is the same."""

    def __init__(self, design: Design, sources: list[Source], n: int, data: DataOptions, diagnosis_cap: int, keep: bool,
                 slots=(), grams=None):
        import contextvars
        import threading

        width = source_columns(slots, design.p)[1]
        self.acc = {k: Accumulator(n, width) for k in parts(sources)}
        self.thin = {FIT: _Thinned(diagnosis_cap), SELECTION: _Thinned(diagnosis_cap // 2)}
        self.motion = Motion(n)
        self.reports: list[DataReport] = []
        self._state = {"design": design}
        self._early, self._done, self._stop = threading.Event(), threading.Event(), threading.Event()
        self._error: BaseException | None = None
        self._late = False
        args = (sources, n, data, keep, slots, grams)
        # in a copy of the caller's context: the Python API's arrays registered by name (measured.arrays)
        self._thread = threading.Thread(target=contextvars.copy_context().run, args=(self._run, *args),
                                        name="minparam-pass", daemon=True)
        if OWN_THREAD:
            self._thread.start()
        else:
            self._run(*args)

    def _run(self, sources, n, data, keep, slots, grams) -> None:
        try:
            from minparam_cli.identify.passes.ahead import ahead

            spare = _Spare()
            # the factor update's first call needs scipy.linalg (about 0.12 s to import), the diagnosis
            # scipy.special: imported beside the readers' start, while this thread would only wait for the
            # first rows (every other scipy import of the pass waits for them: runtime.preload)
            preload("scipy.linalg.blas", "scipy.linalg.cython_blas", "scipy.linalg.cython_lapack", "scipy.special")
            rows = ahead(_rows(self._state, sources, n, data, slots, self.reports, spare), depth=ROWS_AHEAD)
            try:  # numpy's floating-point warnings off on this thread, as on identify's (stage.identify)
                with np.errstate(all="ignore"):
                    _fold(rows, self.acc, grams, self.thin, self.motion, data, keep, spare, self._early.set, self._stop)
            finally:
                rows.close()
        except BaseException as e:  # noqa: BLE001 - raised in the caller's thread by early() or result()
            self._late = self._early.is_set()  # after the fit and selection data: result() raises it, not early()
            self._error = e
        finally:
            await_preload()  # (a pass that folded no rows, or failed) the caller may import scipy next
            self._done.set()
            self._early.set()

    def early(self) -> tuple[dict, dict, Motion, Design]:
        """(the fit and selection accumulators, the thinned samples, the motion, the design) once every
        fit and selection sample is folded in; the test parts go on being read.  Raises the pass's
        error if it failed before that point (a later one comes from ``result``, whatever the timing)."""
        _wait(self._early)
        if self._error is not None and not self._late:
            raise self._error
        return {k: self.acc[k] for k in (FIT, SELECTION) if k in self.acc}, self.thin, self.motion, self._state["design"]

    def result(self):
        """(accumulators of every part, thinned samples, motion, data reports, design) once the pass has ended."""
        _wait(self._done)
        self._join()
        if self._error is not None:
            raise self._error
        return self.acc, self.thin, self.motion, self.reports, self._state["design"]

    def outcome(self, error: BaseException) -> BaseException:
        """What the caller should raise when it failed with ``error`` between ``early`` and ``result``:
        the pass's own error if it has one (a bad row in a test file, reported first, as when the
        whole pass ran before anything else; the caller raises it from ``error``), else ``error``.
        Waits for the pass to end, unless ``error`` is an interrupt."""
        if isinstance(error, (KeyboardInterrupt, SystemExit)) or error is self._error:
            return error
        try:
            self.result()
        except Exception as mine:  # noqa: BLE001 - the pass's error, handed back to be raised
            return mine
        return error

    def close(self) -> None:
        """Stop the pass (when the caller gave up early) and wait for its threads."""
        self._stop.set()
        self._join()

    def _join(self) -> None:
        if self._thread.ident is not None:  # started (not with OWN_THREAD off)
            self._thread.join()


def _wait(event) -> None:
    """``event.wait()`` in steps, so that Ctrl-C interrupts it on every platform."""
    while not event.wait(0.1):
        pass


def _fold(items, acc, grams, thin, motion, data, keep, spare, on_early, stop) -> None:
    """``stream``'s consuming half: the rows into the factors, the samples into the motion and the thinned set."""
    for piece, sub, rows in items:
        if stop.is_set():
            return
        if piece is EARLY:
            on_early()
        elif rows is not None:  # sub: (the times of the rows' samples, the file)
            t, path = sub
            try:
                if grams is not None and piece.part == FIT:  # per time block, for σ with correlated residuals
                    segments = grams.segments(t)  # the update multiplies the rows once for both
                    joint_grams = acc[FIT].add_columns(rows, [(s, e) for _, s, e in segments])
                    grams.add_parts(segments, joint_grams, rows.shape[1])
                else:
                    acc[piece.part].add_columns(rows)
            except NonFiniteRows:
                _refuse_non_finite(rows, t, path)
            spare.give(rows)  # folded in: nothing keeps a reference to it
        else:  # a piece's samples, before its rows
            if piece.role == FIT:
                motion.add(sub)
            motion.count_still(piece.part, sub, data.still_speed)
            if keep and piece.part in thin:
                thin[piece.part].add(sub)
        sub = rows = t = None  # not alive while the next rows are folded in


class _Spare:
    """Row buffers handed back by the folding thread, for the rows thread to fill again: the
    1 M-sample Panda run allocated and dropped 250 buffers of 14 MB, and the heap grew with them.
    Never waits: with no buffer free, the rows thread makes a new one (the queue between the
    threads bounds how many are in flight)."""

    def __init__(self):
        import queue

        self._free: queue.SimpleQueue = queue.SimpleQueue()

    def take(self, shape: tuple[int, ...]) -> np.ndarray:
        import queue

        try:
            buf = self._free.get_nowait()
        except queue.Empty:
            return np.empty(shape)
        return buf if buf.shape == shape else np.empty(shape)

    def give(self, buf: np.ndarray) -> None:
        if buf.flags.owndata and buf.shape[2] == REGRESSOR_ROWS:  # full-size buffers only
            self._free.put(buf)


def _rows(state: dict, sources: list[Source], n: int, data: DataOptions, slots, reports: list, spare: _Spare):
    """The producing half of ``stream``: per piece of each block, (piece, its samples, None), then
    (piece, (the samples' times, path), rows) for its sub-blocks of REGRESSOR_ROWS samples (the full
    regressor is n·10n numbers a sample), slot columns included.  The blocks are read, cleaned
    and filtered one block ahead on a thread of their own.  Sets state["design"]'s drift origin
    at the first sample."""
    from minparam_cli.identify.passes.ahead import ahead

    b: Block | None
    sub_block: Block | None
    sub: Block | None
    last = max(((i, k) for i, src in enumerate(sources) for k, p in enumerate(src.pieces) if p.role in (FIT, SELECTION)),
               default=(-1, -1))  # the last fit or selection piece
    early = False
    for i, src in enumerate(sources):
        rep = DataReport(str(src.path))
        cuts = src.cuts()
        for b in ahead(iter_blocks(src.path, n, data, rep), depth=READ_AHEAD):
            if not len(b):
                continue
            if state["design"].t0 is None:  # drift is measured from the first sample, in every block and every part
                state["design"] = replace(state["design"], t0=float(b.t[0]))
            design = state["design"]
            edges = [0] + [int(np.searchsorted(b.t, c)) for c in cuts] + [len(b)]  # times increase
            for k, (piece, k0, k1) in enumerate(zip(src.pieces, edges[:-1], edges[1:], strict=True)):
                if k1 <= k0:
                    continue
                if not early and (i, k) > last:
                    early = True
                    yield EARLY, None, None
                sub_block = b.take(slice(k0, k1))
                yield piece, sub_block, None
                for s0 in range(0, len(sub_block), REGRESSOR_ROWS):
                    sub = sub_block.take(slice(s0, s0 + REGRESSOR_ROWS))
                    shape = (n, source_columns(slots, design.p)[1] + 1, len(sub))
                    with np.errstate(over="ignore", invalid="ignore"):
                        rows = block_rows(design, slots, sub, out=spare.take(shape))
                    # the times copied (all the fold needs of the samples): a view would keep the whole chunk
                    # alive while the rows wait
                    yield piece, (np.array(sub.t), src.path), rows
            b = sub_block = sub = None  # not alive while the next block is read
        reports.append(rep)
        if not early and i >= last[0]:
            early = True
            yield EARLY, None, None


def _refuse_non_finite(rows: np.ndarray, t: np.ndarray, path: Path) -> None:
    """The DataError for rows that made a factor non-finite, with the time of the first sample whose
    row is not finite: a finite but huge value (a corrupt dq of 1e200, say) overflows in the row."""
    with np.errstate(over="ignore", invalid="ignore"):
        ok = np.isfinite(rows).all(axis=(0, 1))
    i = int(np.argmin(ok)) if not ok.all() else None
    if i is None:  # every entry finite, but their squares overflow
        big = np.abs(rows).max(axis=(0, 1))
        i = int(np.argmax(big))
    raise DataError(
        f"{path}: the sample at t = {t[i]:.6g} s gives a non-finite regressor row "
        "(a value of q, dq, ddq or tau there is too large to use)"
    )
