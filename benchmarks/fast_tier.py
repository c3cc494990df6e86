"""The fast test tier, re-measured: wall time of `python -m pytest -m "not slow"` and the source modules it
leaves thin.

Two whole runs of the fast tier, one after the other, in this repository:

1. timed, as a developer runs it: wall time, CPU time and peak RSS (GNU time), the tests passed/deselected,
   and the machine's load (1-minute average, os.getloadavg) before and after beside the number of cores:
   on a shared machine the wall time is as much the other jobs' as the tests';
2. under `coverage run` (slower; not timed): line coverage of every module of src/minparam_cli, and the
   modules below ``--min-percent`` and the ``--lowest`` N least covered, least covered first. With
   ``--full DATA`` (a coverage data file of the whole suite, e.g. from `coverage run --data-file=DATA -m
   pytest`), the full suite's figure beside each module and the modules that lost more than ``--max-loss``
   points.

The tiers: tests/slow_tests.txt (why and how: docs/architecture.md, "Fast tier"). Tests never fail on time;
this script reports it.

Run: python benchmarks/fast_tier.py [--min-percent 50] [--lowest 5] [--full DATA] [--max-loss 30] [--no-coverage] [--all]
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from common import ROOT

SRC = ROOT / "src" / "minparam_cli"
PYTEST = [sys.executable, "-m", "pytest", "-m", "not slow", "-q", "-p", "no:cacheprovider"]


def timed_run() -> dict[str, object]:
    """One timed run of the fast tier: wall, cpu, peak, summary line, load before/after."""
    load0 = os.getloadavg()[0]
    gnu_time = os.path.exists("/usr/bin/time")
    with tempfile.NamedTemporaryFile("r") as out:
        cmd = ["/usr/bin/time", "-f", "%U %S %M", "-o", out.name, *PYTEST] if gnu_time else PYTEST
        t0 = time.perf_counter()
        p = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
        wall = time.perf_counter() - t0
        rusage = out.read().split() if gnu_time else []
    summary = next((line.strip("= ") for line in reversed(p.stdout.splitlines()) if re.search(r"\d+ (passed|failed)", line)), "?")
    cpu, peak = (float(rusage[-3]) + float(rusage[-2]), float(rusage[-1]) / 1024) if len(rusage) >= 3 else (float("nan"),) * 2
    return {"rc": p.returncode, "wall": wall, "cpu": cpu, "peak": peak, "summary": summary,
            "load": (load0, os.getloadavg()[0]), "tail": p.stdout[-3000:] + p.stderr[-2000:]}


def coverage_run(data: Path) -> int:
    """The fast tier under coverage, its data written to ``data``; pytest's exit status."""
    cmd = [sys.executable, "-m", "coverage", "run", f"--source={SRC}", f"--data-file={data}", *PYTEST[1:]]
    return subprocess.run(cmd, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL).returncode


def percent_by_module(data: Path) -> dict[str, tuple[int, float]]:
    """Statements and line coverage (%) of every module under src/minparam_cli, imported or not."""
    import coverage

    cov = coverage.Coverage(data_file=str(data))
    cov.load()
    out = {}
    for path in sorted(SRC.rglob("*.py")):
        _, statements, _, missing, _ = cov.analysis2(str(path))
        n = len(statements)
        out[path.relative_to(SRC.parent).as_posix()] = (n, 100.0 * (n - len(missing)) / n if n else 100.0)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--min-percent", type=float, default=50.0, help="list modules whose fast-tier line coverage is below this (default 50)")
    ap.add_argument("--lowest", type=int, default=5, help="also list the N modules the fast tier covers least (default 5)")
    ap.add_argument("--full", type=Path, help="coverage data file of the whole suite, to compare module by module")
    ap.add_argument("--max-loss", type=float, default=30.0, help="with --full: list modules that lost more than this many points (default 30)")
    ap.add_argument("--no-coverage", action="store_true", help="time the tier only")
    ap.add_argument("--all", action="store_true", help="print every module, not only the flagged ones")
    args = ap.parse_args()

    r = timed_run()
    bytecode = "off (PYTHONDONTWRITEBYTECODE: every run compiles and rewrites all modules afresh)" if os.environ.get("PYTHONDONTWRITEBYTECODE") else "cached (__pycache__)"
    print(f"fast tier    {' '.join(PYTEST[2:])}  (python -m pytest ...)")
    print(f"tests        {r['summary']}")
    print(f"wall         {r['wall']:.1f} s   cpu {r['cpu']:.1f} s   peak RSS {r['peak']:.0f} MB")
    print(f"load         1-min average {r['load'][0]:.2f} before, {r['load'][1]:.2f} after, on {os.cpu_count()} cores")
    print(f"bytecode     {bytecode}")
    if r["rc"] != 0:
        print(r["tail"])
        raise SystemExit(f"the fast tier failed (pytest exit {r['rc']})")
    if args.no_coverage:
        return

    with tempfile.TemporaryDirectory() as tmp:
        data = Path(tmp) / "fast.coverage"
        if coverage_run(data) != 0:
            raise SystemExit("the fast tier failed under coverage")
        fast = percent_by_module(data)
    full = percent_by_module(args.full) if args.full else {}
    lowest = set(sorted(fast, key=lambda m: (fast[m][1], m))[:max(args.lowest, 0)])
    rows = []
    for module, (n, pct) in sorted(fast.items(), key=lambda item: (item[1][1], item[0])):
        loss = full[module][1] - pct if module in full else 0.0
        flags = (["below min"] if pct < args.min_percent else []) + ([f"lost {loss:.0f} points"] if loss > args.max_loss else [])
        if flags or args.all or module in lowest:
            rows.append((module, n, pct, full.get(module, (0, float("nan")))[1], ", ".join(flags)))
    total = sum(n for n, _ in fast.values())
    covered = sum(n * p / 100 for n, p in fast.values())
    print(f"\nline coverage of src/minparam_cli in the fast tier: {100 * covered / total:.1f} % of {total} statements, {len(fast)} modules")
    if full:
        ftotal = sum(n * p / 100 for n, p in full.values())
        print(f"whole suite ({args.full}): {100 * ftotal / total:.1f} %")
    print(f"modules below {args.min_percent:g} %" + (f" or losing more than {args.max_loss:g} points" if full else "") + f": {sum(1 for r in rows if r[4])}"
          + (f"; the {args.lowest} least covered listed too, least first" if args.lowest > 0 and not args.all else ""))
    if rows:
        width = max(len(r[0]) for r in rows)
        print(f"\n{'module':<{width}}  {'stmts':>5}  {'fast %':>6}  {'full %':>6}  flag")
        for module, n, pct, fpct, flag in rows:
            print(f"{module:<{width}}  {n:>5}  {pct:>6.1f}  {fpct:>6.1f}  {flag}")


if __name__ == "__main__":
    main()
