"""Helpers for the benchmark scripts: whole-process timing with peak RSS, in-process timing."""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # as the CLI does (cli/app.py)
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def run_process(cmd: list[str], repeats: int = 7) -> tuple[float, float]:
    """Median wall time (s) and max peak RSS (MB) of a whole process, over ``repeats`` runs.

    Peak RSS comes from GNU time when present: os.wait4's ru_maxrss would include
    the memory of this (forked) benchmark process itself.
    """
    gnu_time = shutil.which("time") if os.path.exists("/usr/bin/time") else None
    times, peaks = [], []
    for _ in range(repeats):
        with tempfile.NamedTemporaryFile("r") as rss:
            full = ["/usr/bin/time", "-f", "%M", "-o", rss.name, *cmd] if gnu_time else cmd
            t0 = time.perf_counter()
            p = subprocess.run(full, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=ROOT)
            times.append(time.perf_counter() - t0)
            if p.returncode != 0:
                raise SystemExit(f"command failed: {' '.join(cmd)}")
            text = rss.read().strip().splitlines()
            peaks.append(float(text[-1]) / 1024 if gnu_time and text else float("nan"))
    return statistics.median(times), max(peaks)


def run_processes_alternating(cmds: list[list[str]], repeats: int = 21) -> list[tuple[float, float]]:
    """Like run_process for several commands, run in turn (a, b, a, b, ...) so that drift in the
    machine's speed hits them alike; median wall time (s) and max peak RSS (MB) of each."""
    times: list[list[float]] = [[] for _ in cmds]
    peaks: list[list[float]] = [[] for _ in cmds]
    for _ in range(repeats):
        for i, cmd in enumerate(cmds):
            t, m = run_process(cmd, repeats=1)
            times[i].append(t)
            peaks[i].append(m)
    return [(statistics.median(t), max(m)) for t, m in zip(times, peaks)]


def run_measured(cmd: list[str]) -> tuple[float, float, float]:
    """Wall time (s), CPU time (user + system s, all threads) and peak RSS (MB) of one run of a
    whole process, the CPU and peak from GNU time (nan without it)."""
    gnu_time = os.path.exists("/usr/bin/time")
    with tempfile.NamedTemporaryFile("r") as out:
        full = ["/usr/bin/time", "-f", "%U %S %M", "-o", out.name, *cmd] if gnu_time else cmd
        t0 = time.perf_counter()
        p = subprocess.run(full, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=ROOT)
        wall = time.perf_counter() - t0
        if p.returncode != 0:
            raise SystemExit(f"command failed: {' '.join(cmd)}")
        text = out.read().strip().splitlines()
    if not (gnu_time and text):
        return wall, float("nan"), float("nan")
    user, system, peak = text[-1].split()
    return wall, float(user) + float(system), float(peak) / 1024


def run_scheduled(cmd: list[str], poll_s: float = 0.05) -> dict[str, float]:
    """One run of a whole process, with where its wall time went (Linux): ``wall``, ``cpu`` (user +
    system s, all threads), ``runqueue`` (s its threads were ready to run but waited for a core
    held by another process: /proc/PID/task/*/schedstat, read every ``poll_s`` while it runs, so
    the last ``poll_s`` are missed), ``own_wait`` (wall - cpu - runqueue for one thread: sleeping,
    I/O, locks; a negative value is the CPU of threads that ran side by side), ``voluntary`` and
    ``involuntary`` context switches, and ``peak`` RSS (MB: the largest VmHWM read from
    /proc/PID/status, which counts the program alone; os.wait4's ru_maxrss, used where /proc is
    missing, also counts this benchmark's memory at the fork).  On a shared machine the run-queue
    wait is the load of the other jobs, not the program's."""
    import glob

    t0 = time.perf_counter()
    p = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=ROOT)
    waits: dict[str, float] = {}
    hwm = 0.0
    while True:
        for f in glob.glob(f"/proc/{p.pid}/task/*/schedstat"):
            try:
                waits[f] = int(open(f).read().split()[1]) / 1e9
            except (OSError, IndexError, ValueError):
                pass  # the thread ended between the listing and the read
        try:
            with open(f"/proc/{p.pid}/status") as st:
                hwm = max([hwm] + [int(line.split()[1]) / 1024 for line in st if line.startswith("VmHWM:")])
        except (OSError, IndexError, ValueError):
            pass  # the process ended
        pid, status, usage = os.wait4(p.pid, os.WNOHANG)
        if pid:
            break
        time.sleep(poll_s)
    wall = time.perf_counter() - t0
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit(f"command failed: {' '.join(cmd)}")
    cpu = usage.ru_utime + usage.ru_stime
    runqueue = sum(waits.values())
    return {"wall": wall, "cpu": cpu, "runqueue": runqueue, "own_wait": wall - cpu - runqueue,
            "voluntary": usage.ru_nvcsw, "involuntary": usage.ru_nivcsw, "peak": hwm or usage.ru_maxrss / 1024}


def load_average() -> str:
    """The machine's 1-minute load average and its cores, to print beside a timing."""
    return f"load {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores"


def best_of(fn, repeats: int = 7) -> float:
    """Median in-process time (s) of fn()."""
    out = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t0)
    return statistics.median(out)


def peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def minparam_cmd(python: str | None = None) -> list[str]:
    """The ``minparam`` console script beside ``python`` (default: this interpreter)."""
    python = python or sys.executable
    exe = Path(python).with_name("minparam")
    return [str(exe)] if exe.exists() else [python, "-m", "minparam_cli"]


def startup_hooks(python: str) -> list[str]:
    """The .pth files of ``python``'s site-packages that run code at every start-up (``import``
    lines), other than setuptools' own: a peer installed beside minparam (pinocchio's cmeel.pth
    is one) adds the same time to every process, which flatters a ratio of start-up times."""
    code = "import site, sys; print('\\n'.join(site.getsitepackages()))"
    dirs = subprocess.run([python, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    hooks = []
    for d in dirs:
        for pth in sorted(Path(d).glob("*.pth")):
            if pth.name == "distutils-precedence.pth":
                continue
            if any(line.startswith("import") for line in pth.read_text(errors="replace").splitlines()):
                hooks.append(pth.name)
    return hooks
