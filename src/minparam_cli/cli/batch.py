"""Run one stage over many robot files: folder expansion, parallel jobs, summary."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Callable

from minparam_cli.describe import ROBOT_SUFFIXES
from minparam_cli.errors import InputError, MinparamError


def expand_paths(paths: list[Path], recursive: bool) -> tuple[list[Path], bool]:
    """Files named directly, plus robot files found in folders.  Returns (files, any_folder)."""
    files: list[Path] = []
    any_folder = False
    for p in paths:
        if p.is_dir():
            any_folder = True
            pattern = "**/*" if recursive else "*"
            found = sorted(f for f in p.glob(pattern) if f.is_file() and f.suffix.lower() in ROBOT_SUFFIXES)
            if not found:
                raise InputError(f"{p}: no robot files (*.yaml, *.yml, *.urdf) in this folder")
            files.extend(found)
        elif p.exists():
            files.append(p)
        else:
            raise InputError(f"{p}: no such file or folder")
    return files, any_folder


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


def run_batch(fn: Callable, files: list[Path], args: tuple, jobs: int, progress=None) -> list[dict]:
    """Apply fn(path, *args) to every file; results in input order; never raises for one file."""
    results: list[dict] = []
    if jobs <= 1 or len(files) <= 1:
        for i, f in enumerate(files):
            results.append(_run_one(fn, f, args))
            if progress:
                progress(i + 1, len(files))
        return results
    from concurrent.futures import ProcessPoolExecutor

    with ProcessPoolExecutor(max_workers=jobs) as pool:
        futures = [pool.submit(_run_one, fn, f, args) for f in files]
        for i, fut in enumerate(futures):
            results.append(fut.result())
            if progress:
                progress(i + 1, len(files))
    return results
