"""`minparam identify ROBOT DATA_DIR/` and `minparam identify ROBOT fleet.csv`: one identification per
recording of a fleet, on local processes (--jobs) or a Dask cluster (--scheduler).

What a batch is and the task run on every recording: api/identify_batch.py.  Every recording gets its
report (``NAME.report.json``) and its model for ``minparam evaluate`` (``NAME.model.json``) in the
``--output`` folder, and the summary table (``summary.csv`` there, and on stdout: per recording the
selection error before and after the diagnosis, the test error, the effects found) shows the drift
over the fleet.  One bad recording is a row with its error, never the end of the batch.
"""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path
from typing import Any

from minparam_cli.api.identify_batch import Recording, batch_recordings, check_batch, identify_recording
from minparam_cli.errors import InputError

SUMMARY_COLUMNS = ("recording", "robot", "status", "samples", "before_selection", "after_selection", "test_rigid",
                   "test_final", "effects", "flags", "error")


def run_identify_batch(recordings: list[Recording], opts, output: Path, as_json: bool, jobs: int, scheduler: str | None,
                       quiet: bool) -> None:
    """Identify every recording, write the outputs, print the summary; exit code as derive's batch."""
    import typer

    from minparam_cli.cli.batch import absolute, run_batch
    from minparam_cli.cli.common import error_line
    from minparam_cli.output import Progress, output_folder, write_output

    folder = output_folder(output, "--output")
    bar = Progress(len(recordings), "identify", quiet)
    try:
        results = run_batch(identify_recording, [r.data for r in recordings], None, jobs, progress=bar, scheduler=scheduler,
                            per_item=[(absolute(r.robot) if scheduler else r.robot, opts) for r in recordings])
    finally:
        bar.close()
    rows = []
    for rec, res in zip(recordings, results, strict=True):
        if res["ok"]:
            write_output(json.dumps(res["result"]["result"].to_dict(), indent=2, ensure_ascii=False), folder / f"{rec.name}.report.json")
            write_output(res["result"]["model"], folder / f"{rec.name}.model.json")
        rows.append(summary_row(rec, res))
    write_output(_csv(rows), folder / "summary.csv")
    write_output(json.dumps(rows, indent=2, ensure_ascii=False) if as_json else render_summary(rows), None)
    failed = [r for r in results if not r["ok"] and r["status"] == "error"]
    if not quiet or failed:
        for r in failed:
            error_line(r["error"])
    if failed:
        raise typer.Exit(max(r["exit_code"] for r in failed))


def _rel(e) -> float | None:
    return None if e is None else e.relative_error


def summary_row(rec: Recording, res: dict) -> dict:
    """One row of the fleet table: the errors are relative RMS torque errors (``relative_error``)."""
    row: dict[str, Any] = {k: None for k in SUMMARY_COLUMNS}
    row.update(recording=str(rec.data), robot=str(rec.robot))
    if not res["ok"]:
        row.update(status=res["status"], error=res["error"])
        return row
    r = res["result"]["result"]  # identify.result.IdentifyResult
    effects = [f"{e['effect']}@{'+'.join(str(j) for j in e.get('joints') or [])}" if e.get("joints") else e["effect"]
               for e in r.effects]
    row.update(status="ok", samples=r.samples_used, before_selection=_rel(r.before), after_selection=_rel(r.after),
               test_rigid=_rel(r.test.rigid), test_final=_rel(r.test.final), effects=" ".join(effects), flags=len(r.flags))
    return row


def _fmt(v) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def _csv(rows: list[dict]) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(SUMMARY_COLUMNS)
    for r in rows:
        w.writerow(["" if r[k] is None else r[k] for k in SUMMARY_COLUMNS])
    return buf.getvalue().rstrip("\n")


def render_summary(rows: list[dict]) -> str:
    from tabulate import tabulate

    headers = ["recording", "robot", "samples", "rel. error before", "after", "test rigid", "test final", "effects found", "status"]
    table = [(r["recording"], r["robot"], _fmt(r["samples"]), _fmt(r["before_selection"]), _fmt(r["after_selection"]),
              _fmt(r["test_rigid"]), _fmt(r["test_final"]), r["effects"] or "", "ok" if r["status"] == "ok" else f"{r['status']}: {r['error']}")
             for r in rows]
    ok = sum(r["status"] == "ok" for r in rows)
    return (tabulate(table, headers=headers, tablefmt="simple", disable_numparse=True)
            + f"\n\n{ok} of {len(rows)} recordings identified; relative RMS torque errors (before/after: selection data; test: test data)")


def maybe_batch(opts, data: Path, single_run: dict, fmt_json: bool, output, jobs: int, scheduler: str | None,
                quiet: bool) -> bool:
    """Run the batch when DATA is a folder or a manifest of recordings (True), else do nothing (False).
    ``single_run``: the options of one recording, by flag, which a batch refuses."""
    recordings = batch_recordings(opts.robot, data)
    if recordings is None:
        if scheduler:
            raise InputError("--scheduler runs a batch: give a folder or a manifest of recordings as DATA")
        return False
    check_batch(opts, single_run, output)
    run_identify_batch(recordings, opts, output, fmt_json, jobs, scheduler, quiet)
    return True
