"""Where `minparam identify` spends its CPU time, stage by stage (issue 34: the profile table of
docs/methods/streaming.md, "Where the time goes").

One run of the real command in this process, with its streaming pass folded onto one thread
(``identify.passes.ahead.ahead`` replaced by the plain generator: the same rows in the same order, so
the same numbers), under cProfile with ``time.process_time`` as its clock: the attribution is CPU time,
so it moves little with the machine's load, and the total is the profiler's (about 1.3x a normal run's
CPU time).

Each function's own time goes to the stage of the module it is in (the table below); the time of a
function outside those modules (numpy, BLAS, pyarrow, the interpreter) goes to the stages of its
callers, shared in proportion to the time spent in it from each caller, up the call graph until a
stage is found. The attribution is therefore exact for our own code and proportional for shared
library calls.

Run: python benchmarks/profile_identify.py FILE.csv [--robot robots/panda.yaml] [--reader pyarrow|numpy]
     [-- IDENTIFY OPTIONS...]   (e.g. the 1 M-sample file bench_identify.py --data-dir /tmp keeps)
"""

from __future__ import annotations

import argparse
import cProfile
import os
import pstats
import sys
import tempfile
import time
from pathlib import Path

from common import ROOT, load_average  # sets one BLAS thread, as the CLI does (before numpy loads)
from tabulate import tabulate

sys.path.insert(0, str(ROOT / "src"))

# (stage, what it is, path fragments of its modules): the first match of a function's file wins
STAGES = (
    ("factor updates", "the per-joint triangular factors: fast update, Householder QR, column bookkeeping",
     ("identify/estimate/accumulate.py",)),
    ("σ time blocks and HAC", "the time blocks' Grams and the Newey-West σ", ("identify/assess/uncertainty.py",)),
    ("slot columns", "the effects' columns carried through the pass (asymmetric Coulomb, viscous, offset)",
     ("identify/passes/slots.py", "dynamics/effects.py")),
    ("base regressor", "the base columns (compiled kernel and its wrapper)", ("dynamics/regressor.py", "dynamics/_rnea",
                                                                             "identify/passes/design.py")),
    ("parsing", "the CSV reader (pyarrow or numpy) and the copies into row-major chunks",
     ("measured/arrow_csv.py", "measured/reading.py", "measured/csv_", "/pyarrow/")),
    ("cleaning and filtering", "time order, repeats, NaN, velocity check, standstill, filters",
     ("minparam_cli/measured/", "identify/consistency.py")),
    ("diagnosis", "the candidate effects on the thinned samples", ("identify/diagnosis/",)),
    ("rest of the pass", "thinning, motion, sample copies", ("identify/passes/",)),
    ("fits and report", "the estimates, the roles' errors, the report", ("minparam_cli/identify/", "minparam_cli/render/",
                                                                         "minparam_cli/api/")),
)
OTHER = "imports, start-up, the rest"


# minparam's own wrappers of library calls (BLAS and LAPACK without the GIL): their time goes to their callers,
# as a library's does
LIBRARY = ("identify/estimate/nogil_lapack.py",)


def stage_of_file(filename: str) -> str | None:
    f = filename.replace("\\", "/")
    if any(frag in f for frag in LIBRARY):
        return None
    for stage, _, frags in STAGES:
        if any(frag in f for frag in frags):
            return stage
    if "/minparam_cli/" in f:
        return OTHER
    return None


def attribute(stats: pstats.Stats) -> dict[str, float]:
    """CPU seconds per stage (module docstring)."""
    table = stats.stats  # type: ignore[attr-defined]  # pstats keeps its table there
    memo: dict = {}

    def dist(func, seen=frozenset()) -> dict[str, float]:
        if func in memo:
            return memo[func]
        own = stage_of_file(func[0])
        if own is None and func[2] in ("inertial_regressor",):  # the compiled kernel (a built-in method)
            own = "base regressor"
        if own is not None:
            out = {own: 1.0}
        else:
            callers = table[func][4] if func in table else {}
            weights = {c: edge[3] for c, edge in callers.items() if c not in seen and c != func}
            total = sum(weights.values())
            if total <= 0:
                out = {OTHER: 1.0}
            else:
                out = {}
                for c, w in weights.items():
                    for s, f in dist(c, seen | {func}).items():
                        out[s] = out.get(s, 0.0) + f * w / total
        if not seen:
            memo[func] = out
        return out

    times: dict[str, float] = {}
    for func, (_, _, tottime, _, _) in table.items():
        for s, f in dist(func).items():
            times[s] = times.get(s, 0.0) + tottime * f
    return times


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("data", help="a CSV recording (q, dq, ddq, tau columns, as bench_identify.py writes)")
    ap.add_argument("--robot", default="robots/panda.yaml")
    ap.add_argument("--reader", default="pyarrow", choices=("pyarrow", "numpy"))
    ap.add_argument("extra", nargs="*", help="more identify options (after --)")
    args = ap.parse_args()
    os.environ["MINPARAM_CSV_READER"] = args.reader

    import minparam_cli.identify.passes.ahead as ahead_module
    import minparam_cli.identify.passes.stream as stream_module
    from minparam_cli.cli.app import entry

    ahead_module.ahead = lambda gen, depth=2: gen  # the pass on one thread: same items, same order
    stream_module.OWN_THREAD = False  # and that thread the caller's
    load0 = load_average()
    with tempfile.TemporaryDirectory() as tmp:
        sys.argv = ["minparam", "identify", str(ROOT / args.robot), args.data, "--format", "json", "-q", "-o",
                    str(Path(tmp) / "report.json"), *args.extra]
        prof = cProfile.Profile(time.process_time)
        c0 = time.process_time()
        prof.enable()
        try:
            entry()
        except SystemExit as e:
            if e.code not in (0, None):
                raise
        finally:
            prof.disable()
        cpu = time.process_time() - c0
    stats = pstats.Stats(prof)
    times = attribute(stats)
    total = sum(times.values())
    what = {s: w for s, w, _ in STAGES} | {OTHER: "Python start-up is not in this process's profile"}
    rows = [[s, what[s], f"{t:.2f}", f"{100 * t / total:.0f} %"] for s, t in sorted(times.items(), key=lambda x: -x[1])]
    rows.append(["total (profiler's clock)", "", f"{total:.2f}", ""])
    print(f"minparam identify {args.robot} {Path(args.data).name} ({os.path.getsize(args.data) / 1e6:.0f} MB), reader "
          f"{args.reader}, the pass on one thread, under cProfile (CPU time); {cpu:.1f} s of CPU in all; "
          f"{load0} before, {load_average()} after")
    print(tabulate(rows, headers=["stage", "what", "CPU s", "share"], tablefmt="github"))


if __name__ == "__main__":
    main()
