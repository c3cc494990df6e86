"""Where a batch's items run: a local process pool (``--jobs N``) or a Dask distributed cluster
(``--scheduler ADDRESS``).

Both take the same task function (``batch._run_one``, which turns every per-item failure into a
result dict, so one bad file never stops a batch) and return the results in input order, whatever
order the items finish in; the progress bar counts items as they complete.  The cluster is
reached only through the ``distributed`` library (optional extra ``minparam[cluster]``): its
scheduler places the tasks, moves arguments and results, and re-runs the tasks of a worker that
dies; nothing here schedules or transports anything itself.
"""

from __future__ import annotations

import uuid
from collections.abc import Callable

from minparam_cli.errors import InputError

CONNECT_TIMEOUT_S = 10


class LocalExecutor:
    """``jobs`` worker processes on this machine (1: in this process, in order)."""

    def __init__(self, jobs: int = 1):
        self.jobs = max(int(jobs), 1)

    def map(self, task: Callable, items: list[tuple], progress=None) -> list:
        n = len(items)
        if self.jobs <= 1 or n <= 1:
            out = []
            for i, item in enumerate(items):
                out.append(task(*item))
                if progress:
                    progress(i + 1, n)
            return out
        from concurrent.futures import ProcessPoolExecutor, as_completed

        with ProcessPoolExecutor(max_workers=min(self.jobs, n)) as pool:
            futures = [pool.submit(task, *item) for item in items]
            for done, _ in enumerate(as_completed(futures), 1):
                if progress:
                    progress(done, n)
            return [f.result() for f in futures]


class DaskExecutor:
    """The workers of a running Dask distributed cluster, through its scheduler at ``address``
    (``tcp://host:8786``, or a ``distributed`` Client / LocalCluster's address)."""

    def __init__(self, address: str):
        self.address = address

    def client(self):
        distributed = import_distributed()
        try:
            return distributed.Client(self.address, timeout=f"{CONNECT_TIMEOUT_S}s")
        except (OSError, TimeoutError, ValueError) as e:
            text = " ".join(str(e).split())[:200] or type(e).__name__
            raise InputError(f"--scheduler {self.address}: cannot reach a Dask scheduler there ({text})") from None

    def map(self, task: Callable, items: list[tuple], progress=None, on_lost: Callable | None = None) -> list:
        """task(*item) for every item on the cluster, results in input order.  A task whose
        workers kept dying (``distributed``'s allowed-failures, then KilledWorker) gives
        ``on_lost(item, exception)`` as its result instead of stopping the batch."""
        distributed = import_distributed()
        n = len(items)
        token = uuid.uuid4().hex[:12]  # unique keys: two batches on one cluster never share results
        with self.client() as client:
            futures = [client.submit(task, *item, key=f"minparam-{token}-{i}", pure=False) for i, item in enumerate(items)]
            for done, _ in enumerate(distributed.as_completed(futures), 1):
                if progress:
                    progress(done, n)
            out = []
            for item, fut in zip(items, futures, strict=True):
                # result(), not the status: a result lost with its worker after the task finished is
                # computed again by the scheduler, and result() waits for it
                try:
                    out.append(fut.result())
                except Exception as err:
                    if on_lost is None:
                        raise
                    out.append(on_lost(item, err))
            for fut in futures:
                fut.release()
        return out


def import_distributed():
    from minparam_cli.optional import import_optional

    return import_optional("distributed", "cluster", "--scheduler (a Dask cluster)")


def make_executor(jobs: int = 1, scheduler: str | None = None):
    """The executor a batch command's --jobs / --scheduler options ask for."""
    if scheduler:
        return DaskExecutor(scheduler)
    return LocalExecutor(jobs)


def scheduler_option():
    """The --scheduler option of the batch commands."""
    import typer

    return typer.Option(
        None, "--scheduler", metavar="ADDRESS",
        help="Run a batch on the Dask distributed cluster whose scheduler is at ADDRESS (tcp://host:8786) instead of "
             "local processes; the files must be readable at the same paths on its workers (needs the [cluster] extra).",
    )
