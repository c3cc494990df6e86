"""`minparam check`: validate robot descriptions without computing anything."""

from __future__ import annotations

import json
from pathlib import Path
from typing import List

import typer

from minparam_cli.cli.batch import expand_paths, run_batch
from minparam_cli.cli.common import error_line, guarded

HELP = "Validate robot description files (YAML DH/MDH, URDF); exit 2 if any is invalid."
EPILOG = """\b
Examples:
  minparam check robots/puma560.yaml
  minparam check robots/ --recursive --json
"""


def check(
    paths: List[Path] = typer.Argument(..., help="Robot files or folders.", show_default=False),
    recursive: bool = typer.Option(False, "--recursive", "-r", help="Also search sub-folders."),
    as_json: bool = typer.Option(False, "--json", help="One JSON object per file (JSONL)."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="Print only errors."),
):
    _check(paths, recursive, as_json, quiet)


@guarded
def _check(paths, recursive, as_json, quiet):
    from tabulate import tabulate

    from minparam_cli.pipeline import check_file

    files, _ = expand_paths(list(paths), recursive)
    results = run_batch(check_file, files, (), 1)
    if as_json:
        lines = []
        for r in results:
            item = r["result"] if r["ok"] else {"source": r["path"], "status": r["status"], "error": r["error"]}
            if r["ok"]:
                item = {**item, "status": "ok"}
            lines.append(json.dumps(item))
        print("\n".join(lines))
    elif not quiet:
        rows = []
        for r in results:
            if r["ok"]:
                c = r["result"]
                bodies = f"{len(c['bodies'])} real" if c["bodies"] else "no data"
                rows.append((r["path"], c["robot"], c["dof"], c["types"], c["convention"], "yes" if c["exact"] else "no", bodies, "ok"))
            else:
                # an error's line goes to stderr below; a skipped file says why here
                rows.append((r["path"], "", "", "", "", "", "", r["status"] if r["status"] == "error" else f"{r['status']}: {r['error']}"))
        print(tabulate(rows, headers=["file", "robot", "dof", "joints", "convention", "exact", "bodies", "status"], tablefmt="simple"))
    failed = [r for r in results if not r["ok"] and r["status"] == "error"]
    for r in failed:  # on stderr, one line each, whatever the output format
        error_line(r["error"])
    if failed:
        raise typer.Exit(max(r["exit_code"] for r in failed))
