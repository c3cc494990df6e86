"""Start-up cost of ``import minparam`` (the Python API) against the CLI's own start-up.

Issue 22's goal: ``import minparam`` costs no more than today's CLI import.  Rows, each a whole
process run in turn with the others (``run_processes_alternating``: drift in the machine's speed hits
them alike), median wall time and peak RSS:

* ``python -c pass``: the interpreter alone (what every row pays);
* ``import minparam``: the API's import (re-exports; no numpy, sympy or typer until a call needs them);
* ``import minparam_cli.cli.app``: the CLI's import;
* ``minparam --version``: the CLI's whole start-up (import, building the app, parsing);
* a first ``derive`` of the planar 2R, through the API and through the CLI (numpy, the base set,
  the JSON): the import is not where the time goes.

Ratios are against the CLI's import.  Start-up hooks of this environment (.pth files that import
code, e.g. pinocchio's cmeel.pth) add the same time to every row and are named below the table.

Run: python benchmarks/bench_startup.py [--repeats N]
"""

from __future__ import annotations

import argparse
import os
import sys

from common import ROOT, run_processes_alternating, startup_hooks

ROWS = [
    ("python -c pass", ["-c", "pass"]),
    ("import minparam", ["-c", "import minparam"]),
    ("import minparam_cli.cli.app (CLI import)", ["-c", "import minparam_cli.cli.app"]),
    ("minparam --version (CLI start-up)", ["-m", "minparam_cli", "--version"]),
    ("API: minparam.derive(planar2r)", ["-c", "import minparam; minparam.derive('robots/planar2r.yaml')"]),
    ("CLI: minparam derive planar2r -f json", ["-m", "minparam_cli", "derive", "robots/planar2r.yaml", "-f", "json"]),
]
REFERENCE = 2  # the CLI's import


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=15, help="runs of each command (median reported)")
    args = ap.parse_args()
    os.environ["PYTHONPATH"] = str(ROOT / "src") + os.pathsep + os.environ.get("PYTHONPATH", "")
    results = run_processes_alternating([[sys.executable, *cmd] for _, cmd in ROWS], repeats=args.repeats)
    ref = results[REFERENCE][0]
    print(f"{'command':<42} {'wall ms':>9} {'peak MB':>9} {'/ CLI import':>13}")
    for (label, _), (t, mb) in zip(ROWS, results):
        print(f"{label:<42} {1000 * t:>9.1f} {mb:>9.1f} {t / ref:>13.2f}")
    print(f"\n{args.repeats} runs each, alternating; python {sys.version.split()[0]}; "
          f"start-up hooks: {', '.join(startup_hooks(sys.executable)) or 'none'}")


if __name__ == "__main__":
    main()
