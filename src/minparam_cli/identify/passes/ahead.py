"""A generator run one step ahead on a second thread: ``for x in ahead(gen)`` sees the items of
``gen`` in order while the next ones are being produced.

Used by ``identify``'s streaming pass, where reading and building the regressor rows (pyarrow's
parser, the compiled kernel, numpy: all release the GIL) overlap with folding the rows into the
triangular factors (BLAS, also without the GIL): on two cores the pass takes about the longer of
the two halves instead of their sum.  The items are the same objects in the same order, so every
result is the same as on one thread.

At most ``depth`` items wait in the queue (memory stays bounded).  An exception of the producer
(a DataError on a bad row, say) is raised here, in the consumer, at the point where the item would
have come; when the consumer stops early (an exception of its own, Ctrl-C, ``break``), the producer
is told to stop, its generator is closed in its own thread (files and helper processes released by
its ``finally`` clauses) and the thread is joined before this returns.
"""

from __future__ import annotations

import contextvars
import queue
import threading
from collections.abc import Generator, Iterator
from typing import TypeVar

T = TypeVar("T")

_END = object()
POLL_S = 0.1  # how often a producer blocked on a full queue looks whether the consumer has gone


def ahead(gen: Iterator[T], depth: int = 2) -> Generator[T, None, None]:
    """The items of ``gen``, produced on a daemon thread up to ``depth`` items ahead."""
    q: queue.Queue = queue.Queue(maxsize=depth)
    stop = threading.Event()

    def put(item) -> bool:
        while not stop.is_set():
            try:
                q.put(item, timeout=POLL_S)
                return True
            except queue.Full:
                continue
        return False

    def produce() -> None:
        try:
            for item in gen:
                if not put((True, item)):
                    return
            put((True, _END))
        except BaseException as e:  # noqa: BLE001 - handed to the consumer, which raises it
            put((False, e))
        finally:
            close = getattr(gen, "close", None)
            if close is not None:
                close()

    # the producer runs in a copy of the caller's context: context variables (the Python API's arrays
    # registered by name, measured.arrays) are seen by the reader on the other thread too
    context = contextvars.copy_context()
    worker = threading.Thread(target=context.run, args=(produce,), name="minparam-ahead", daemon=True)
    worker.start()
    try:
        while True:
            ok, item = q.get()
            if not ok:
                raise item
            if item is _END:
                return
            yield item
            item = None
    finally:
        stop.set()
        while worker.is_alive():  # unblock a producer waiting on a full queue, then wait for it
            try:
                q.get_nowait()
            except queue.Empty:
                pass
            worker.join(POLL_S)
