"""Run one API function over many robot files: parallel jobs (or a Dask cluster), one result per file."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Callable

from minparam_cli.errors import MinparamError


def _run_one(fn: Callable, path: Path, args: tuple) -> dict:
    t0 = time.perf_counter()
    try:
        result = fn(path, *args)
        return {"path": str(path), "ok": True, "result": result, "elapsed_s": time.perf_counter() - t0}
    except MinparamError as e:
        status = "skipped" if getattr(e, "skippable", False) else "error"
        return {"path": str(path), "ok": False, "status": status, "error": " ".join(str(e).split()), "exit_code": e.exit_code, "elapsed_s": time.perf_counter() - t0}
    except MemoryError:
        return {"path": str(path), "ok": False, "status": "error", "error": f"{path}: out of memory", "exit_code": 1, "elapsed_s": time.perf_counter() - t0}
    except Exception as e:  # noqa: BLE001 - one bad robot must not stop the batch
        return {"path": str(path), "ok": False, "status": "error", "error": f"{path}: internal error: {type(e).__name__}: {e}", "exit_code": 1, "elapsed_s": time.perf_counter() - t0}


def absolute(path) -> Path:
    """``path`` from this process's working folder, as a cluster's workers must be given it."""
    import os

    return Path(os.path.abspath(path))


def _lost(item: tuple, err: BaseException) -> dict:
    """The result of an item whose task never came back from the cluster (its workers kept dying)."""
    _, path, _ = item
    text = " ".join(str(err).split())[:200] or type(err).__name__
    return {"path": str(path), "ok": False, "status": "error", "error": f"{path}: the cluster lost this task ({type(err).__name__}: {text})",
            "exit_code": 1, "elapsed_s": 0.0}


def run_batch(fn: Callable, files: list, args: tuple | None, jobs: int = 1, progress=None, scheduler: str | None = None,
              per_item: list[tuple] | None = None) -> list[dict]:
    """Apply fn(path, *args) to every file (fn(files[i], *per_item[i]) when given); results in input
    order; never raises for one file.

    ``jobs`` worker processes on this machine, or, with ``scheduler``, the workers of the Dask
    cluster at that address (``executor.DaskExecutor``), given the files as absolute paths; the
    results are the same either way for files named by absolute paths."""
    from minparam_cli.cli.executor import DaskExecutor, make_executor

    if scheduler:  # workers on other machines know nothing of this process's working folder
        files = [absolute(f) for f in files]
    items = [(fn, f, per_item[i] if per_item is not None else args) for i, f in enumerate(files)]
    executor = make_executor(jobs if len(files) > 1 else 1, scheduler)
    if isinstance(executor, DaskExecutor):
        return executor.map(_run_one, items, progress, on_lost=_lost)
    return executor.map(_run_one, items, progress)
