"""The recordings of an identify batch (a folder of recordings or a manifest CSV ``recording,robot``)
and the task run on each (``identify_recording``); cli/identify_batch.py runs the tasks, writes the
outputs and prints the summary.

DATA is a batch when it is a folder that is not a rosbag2 bag (every recording in it: .csv, .npz,
.parquet, .mcap, .db3, .bag, rosbag2 folders), or a manifest: a CSV file whose header is
``recording,robot`` (or ``recording`` alone), one recording a row, paths relative to the manifest's
folder, an empty robot cell meaning ROBOT.
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from minparam_cli.api.options.identify import IdentifyOptions
from minparam_cli.errors import InputError

RECORDING_SUFFIXES = (".csv", ".npz", ".parquet", ".mcap", ".db3", ".bag")
MANIFEST_MAX_BYTES = 16 * 2**20


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


def identify_recording(data: Path, robot: Path, opts: IdentifyOptions) -> dict[str, Any]:
    """The worker's task: one recording identified against its robot file; the result and the saved
    model's text (written by the client, so workers on other machines write nothing)."""
    from minparam_cli.api.identification import run_identify
    from minparam_cli.model.file import dumps

    ident = run_identify(opts, Path(data), robot=Path(robot))
    return {"result": ident.result, "model": dumps(ident.model.saved)}


def check_batch(opts: IdentifyOptions, single_run: dict[str, Any], output) -> None:
    """Before any work: the robot of DATA's command line loads (as one recording's run would check), and
    the options of one recording (by flag) that a batch cannot take are refused in one line."""
    from minparam_cli.api.identification import load_identify_chain
    from minparam_cli.dynamics.transmission import motor_side_spec

    chain = load_identify_chain(opts)
    motor_side_spec(chain, opts.side, opts.current, opts.drive_gains)
    refuse_single_run_options(**single_run, output=output)


def refuse_single_run_options(validate, test, plot, save_model, export_urdf, export_yaml, output, export_mjcf=None) -> None:
    """Options of one recording that a batch cannot take, refused in one line before any work."""
    for flag, value in (("--validate", validate), ("--test", test), ("--plot", plot), ("--save-model", save_model),
                        ("--export-urdf", export_urdf), ("--export-yaml", export_yaml),
                        ("--export-mjcf", export_mjcf)):
        if value:
            raise InputError(f"{flag} applies to one recording; a batch (a folder or a manifest of recordings) takes "
                             "the fit, selection and test shares of each recording from --split")
    if output is None or str(output) == "-":
        raise InputError("a batch writes a report and a model per recording: give the folder for them with -o FOLDER")
