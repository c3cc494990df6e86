"""`minparam identify ROBOT DATA_DIR/` and `minparam identify ROBOT fleet.csv`: one identification per
recording of a fleet, on local processes (--jobs) or a Dask cluster (--scheduler).

DATA is a batch when it is a folder that is not a rosbag2 bag (every recording in it: .csv, .npz,
.parquet, .mcap, .db3, .bag, rosbag2 folders), or a manifest: a CSV file whose header is
``recording,robot`` (or ``recording`` alone), one recording a row, paths relative to the manifest's
folder, an empty robot cell meaning ROBOT.  Every recording gets its report
(``NAME.report.json``) and its model for ``minparam evaluate`` (``NAME.model.json``) in the
``--output`` folder, and the summary table (``summary.csv`` there, and on stdout: per recording the
selection error before and after the diagnosis, the test error, the effects found) shows the drift
over the fleet.  One bad recording is a row with its error, never the end of the batch.
"""

from __future__ import annotations

import csv
import io
import json
from dataclasses import dataclass, replace
from pathlib import Path

from minparam_cli.errors import InputError

RECORDING_SUFFIXES = (".csv", ".npz", ".parquet", ".mcap", ".db3", ".bag")
MANIFEST_MAX_BYTES = 16 * 2**20
SUMMARY_COLUMNS = ("recording", "robot", "status", "samples", "before_selection", "after_selection", "test_rigid",
                   "test_final", "effects", "flags", "error")


@dataclass(frozen=True)
class Recording:
    data: Path
    robot: Path
    name: str  # the stem of its output files, unique in the batch


def _is_manifest(path: Path) -> bool:
    """A CSV file whose first line is ``recording,robot`` or ``recording`` (never a data file: those
    have a time column)."""
    if path.suffix.lower() != ".csv" or not path.is_file():
        return False
    try:
        with open(path, "rb") as fh:
            first = fh.readline(4096)
    except OSError:
        return False
    names = [x.strip().lower() for x in first.decode("utf-8", "replace").lstrip("\ufeff").strip().split(",")]
    return names in (["recording", "robot"], ["recording"])


def batch_recordings(robot: Path, data: Path) -> list[Recording] | None:
    """The recordings of a batch, in a fixed order, or None when DATA is one recording."""
    from minparam_cli.measured.rosbag import is_bag

    data = Path(data)
    if data.is_dir() and not is_bag(data):
        found = sorted(p for p in data.iterdir() if (p.is_file() and p.suffix.lower() in RECORDING_SUFFIXES) or (p.is_dir() and is_bag(p)))
        if not found:
            raise InputError(f"{data}: no recordings ({', '.join('*' + s for s in RECORDING_SUFFIXES)} or rosbag2 folders) in this folder")
        return _named([(p, Path(robot)) for p in found], data)
    if _is_manifest(data):
        return _named(_manifest_rows(data, Path(robot)), data.parent)
    return None


def _manifest_rows(path: Path, robot: Path) -> list[tuple[Path, Path]]:
    from minparam_cli.safety import read_bounded

    try:
        text = read_bounded(path, MANIFEST_MAX_BYTES).decode("utf-8")
    except UnicodeDecodeError:
        raise InputError(f"{path}: the manifest is not UTF-8 text") from None
    rows = list(csv.reader(io.StringIO(text.lstrip("\ufeff"))))
    width = len(rows[0])
    out = []
    for no, row in enumerate(rows[1:], 2):
        if not row or not any(c.strip() for c in row):
            continue
        if len(row) != width:
            raise InputError(f"{path}: line {no} has {len(row)} fields, the header ({','.join(rows[0])}) has {width}")
        rec = row[0].strip()
        if not rec:
            raise InputError(f"{path}: line {no} names no recording")
        bot = row[1].strip() if width > 1 else ""
        out.append((path.parent / rec, path.parent / bot if bot else robot))
    if not out:
        raise InputError(f"{path}: the manifest lists no recordings")
    return out


def _named(pairs: list[tuple[Path, Path]], root: Path) -> list[Recording]:
    """Output names: the recording's path under ``root`` with '/' as '__' (its own name when outside)."""
    out, seen = [], set()
    for data, robot in pairs:
        try:
            rel = data.relative_to(root).as_posix()
        except ValueError:
            rel = data.name
        name = rel.replace("/", "__") or data.name
        base, k = name, 2
        while name in seen:
            name, k = f"{base}-{k}", k + 1
        seen.add(name)
        out.append(Recording(data, robot, name))
    return out


def identify_recording(data: Path, robot: Path, load, opts, nominal_prior: bool) -> dict:
    """The worker's task: one recording identified against its robot file; the report and the saved
    model's text (written by the client, so workers on other machines write nothing)."""
    from minparam_cli.cli.model_files import read_robot_bytes
    from minparam_cli.model.file import dumps, saved_model
    from minparam_cli.identify.stage import identify as run
    from minparam_cli.measured.rosbag import coordinate_names
    from minparam_cli.robot import load_chain, require_fixed_base

    _, chain = load_chain(robot, load.derive_options(opts.seed))
    require_fixed_base(chain, "identify")
    if nominal_prior:
        from minparam_cli.dynamics.bodies import nominal_problems, nominal_problems_text

        if nominal_problems(chain):
            raise InputError("--prior nominal: " + nominal_problems_text(str(robot), nominal_problems(chain)))
    chain = chain.with_coulomb_smoothing(load.coulomb_smoothing)
    opts = replace(opts, data=replace(opts.data, joint_names=coordinate_names(chain)))
    report, art = run(chain, Path(data), opts)
    model = dumps(saved_model(str(robot), read_robot_bytes(robot), load, opts.data, opts.seed, art, report))
    return {"report": report, "model": model}


def refuse_single_run_options(validate, test, plot, save_model, export_urdf, export_yaml, output) -> None:
    """Options of one recording that a batch cannot take, refused in one line before any work."""
    for flag, value in (("--validate", validate), ("--test", test), ("--plot", plot), ("--save-model", save_model),
                        ("--export-urdf", export_urdf), ("--export-yaml", export_yaml)):
        if value:
            raise InputError(f"{flag} applies to one recording; a batch (a folder or a manifest of recordings) takes "
                             "the fit, selection and test shares of each recording from --split")
    if output is None or str(output) == "-":
        raise InputError("a batch writes a report and a model per recording: give the folder for them with -o FOLDER")


def run_identify_batch(recordings: list[Recording], load, opts, nominal_prior: bool, output: Path, as_json: bool,
                       jobs: int, scheduler: str | None, quiet: bool) -> None:
    """Identify every recording, write the outputs, print the summary; exit code as derive's batch."""
    import typer

    from minparam_cli.cli.batch import absolute, run_batch
    from minparam_cli.cli.common import error_line
    from minparam_cli.output import Progress, output_folder, write_output

    folder = output_folder(output, "--output")
    bar = Progress(len(recordings), "identify", quiet)
    try:
        results = run_batch(identify_recording, [r.data for r in recordings], None, jobs, progress=bar, scheduler=scheduler,
                            per_item=[(absolute(r.robot) if scheduler else r.robot, load, opts, nominal_prior) for r in recordings])
    finally:
        bar.close()
    rows = []
    for rec, res in zip(recordings, results):
        if res["ok"]:
            write_output(json.dumps(res["result"]["report"], indent=2, ensure_ascii=False), folder / f"{rec.name}.report.json")
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


def _rel(block: dict | None) -> float | None:
    return None if not block else block.get("relative_error")


def summary_row(rec: Recording, res: dict) -> dict:
    """One row of the fleet table: the errors are relative RMS torque errors (``relative_error``)."""
    row = {k: None for k in SUMMARY_COLUMNS}
    row.update(recording=str(rec.data), robot=str(rec.robot))
    if not res["ok"]:
        row.update(status=res["status"], error=res["error"])
        return row
    rep = res["result"]["report"]
    test = rep.get("test") or {}
    effects = [f"{e['effect']}@{'+'.join(str(j) for j in e.get('joints') or [])}" if e.get("joints") else e["effect"]
               for e in rep.get("effects") or []]
    row.update(status="ok", samples=rep.get("samples_used"), before_selection=_rel(rep.get("before")),
               after_selection=_rel(rep.get("after")), test_rigid=_rel(test.get("rigid")), test_final=_rel(test.get("final")),
               effects=" ".join(effects), flags=len(rep.get("flags") or []))
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


def maybe_batch(robot: Path, data: Path, opts, load, nominal_prior: bool, single_run: dict, fmt_json: bool, output,
                jobs: int, scheduler: str | None, quiet: bool) -> bool:
    """Run the batch when DATA is a folder or a manifest of recordings (True), else do nothing (False).
    ``single_run``: the options of one recording, by flag, which a batch refuses."""
    recordings = batch_recordings(robot, data)
    if recordings is None:
        if scheduler:
            raise InputError("--scheduler runs a batch: give a folder or a manifest of recordings as DATA")
        return False
    refuse_single_run_options(*single_run.values(), output)
    run_identify_batch(recordings, load, opts, nominal_prior, output, fmt_json, jobs, scheduler, quiet)
    return True
