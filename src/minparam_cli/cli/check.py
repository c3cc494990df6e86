"""`minparam check`: validate robot descriptions without computing anything."""

from __future__ import annotations

import json
from pathlib import Path
from typing import List

import typer

from minparam_cli.cli.batch import run_batch
from minparam_cli.cli.common import error_line, guarded

HELP = "Validate robot description files (YAML DH/MDH, URDF, MJCF); exit 2 if any is invalid."
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
    from minparam_cli.api.common import expand_paths
    from minparam_cli.api.derivation import check_file
    from minparam_cli.api.options.check import CheckOptions

    opts = CheckOptions(recursive=recursive)
    files, _ = expand_paths(list(paths), opts.recursive)
    results = run_batch(check_file, files, (), 1)
    if as_json:
        lines = []
        for r in results:
            item = r["result"].to_dict() if r["ok"] else {"source": r["path"], "status": r["status"], "error": r["error"]}
            lines.append(json.dumps(item))
        print("\n".join(lines))
    elif not quiet:
        from minparam_cli.render.check_text import check_table

        print(check_table(results))
    failed = [r for r in results if not r["ok"] and r["status"] == "error"]
    for r in failed:  # on stderr, one line each, whatever the output format
        error_line(r["error"])
    if failed:
        raise typer.Exit(max(r["exit_code"] for r in failed))
