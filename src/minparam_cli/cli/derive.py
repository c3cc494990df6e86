"""`minparam derive`: base parameters of one robot or a folder of robots."""

from __future__ import annotations

from enum import Enum
from pathlib import Path
from typing import List, Optional

import typer

from minparam_cli.cli.batch import expand_paths, run_batch
from minparam_cli.cli.common import (
    Format,
    MimicMode,
    error_line,
    floating_base_option,
    guarded,
    mimic_option,
    parse_floats,
    warning_line,
)
from minparam_cli.output import Progress, write_output
from minparam_cli.cli.executor import scheduler_option
from minparam_cli.params import FRICTION_KINDS

HELP = "Base (minimal) inertial parameters of a robot: which are identifiable and how the others regroup."
EPILOG = """\b
Examples:
  minparam derive robots/puma560.yaml
  minparam derive robots/puma560_mdh.yaml --friction coulomb,viscous --rotor-inertia --format json
  minparam derive robots/panda.yaml --method projection --format latex -o panda.tex
  minparam derive robots/ --format jsonl --jobs 2
  minparam derive robots/ --format json --scheduler tcp://head-node:8786    (needs the [cluster] extra)
  minparam derive so100.urdf --snap-angles 1e-4
  minparam derive panda.urdf --mimic fixed
  minparam derive solo12.urdf --floating-base

Exit codes: 0 success, 1 failed computation, 2 bad input (any robot of a batch).
"""


class Method(str, Enum):
    qr = "qr"
    projection = "projection"


def derive(
    paths: List[Path] = typer.Argument(..., help="Robot files (YAML DH/MDH or URDF) or folders of them.", show_default=False),
    method: Method = typer.Option(Method.qr, "--method", "-m", help="qr (random samples + QR) or projection (Krutikov, exact)."),
    fmt: Format = typer.Option(Format.table, "--format", "-f", help="Output format."),
    friction: str = typer.Option("", "--friction", help="Add friction columns to every joint: any of coulomb,viscous,offset."),
    rotor_inertia: bool = typer.Option(False, "--rotor-inertia", help="Add a rotor inertia column Ia per joint."),
    gravity: Optional[str] = typer.Option(None, "--gravity", help="Gravity vector X,Y,Z in m/s² (overrides the file; URDF default 0,0,-9.81)."),
    samples: int = typer.Option(100, "--samples", help="Random states for the QR method."),
    seed: int = typer.Option(0, "--seed", help="Seed of the random states (reported in the output)."),
    symbolic: Optional[bool] = typer.Option(None, "--symbolic/--numeric", help="Print regrouping coefficients as expressions in the geometry symbols."),
    symbolic_numbers: bool = typer.Option(
        False, "--symbolic-numbers", help="--symbolic with lengths (and axes with rational components) as the file's exact numbers; only other angles and g stay symbols."
    ),
    snap_angles: Optional[float] = typer.Option(
        None, "--snap-angles", metavar="TOL", help="Round joint angles within TOL rad of a multiple of 15° (pi/12) before deriving; every change is printed."
    ),
    mimic: MimicMode = mimic_option(),
    floating_base: bool = floating_base_option(),
    output: Optional[Path] = typer.Option(None, "--output", "-o", help="Write to this file (atomically) instead of stdout."),
    recursive: bool = typer.Option(False, "--recursive", "-r", help="Also search sub-folders."),
    jobs: int = typer.Option(1, "--jobs", "-j", min=1, help="Parallel worker processes for many robots."),
    scheduler: Optional[str] = scheduler_option(),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress bar or notes on stderr."),
):
    _derive(paths, method, fmt, friction, rotor_inertia, gravity, samples, seed, symbolic, snap_angles, output, recursive, jobs, quiet, mimic, floating_base, scheduler,
            symbolic_numbers=symbolic_numbers)


@guarded
def _derive(paths, method, fmt, friction, rotor_inertia, gravity, samples, seed, symbolic, snap_angles, output, recursive, jobs, quiet,
            mimic=MimicMode.coupled, floating_base=False, scheduler=None, symbolic_numbers=False):
    from minparam_cli.pipeline import derive_file
    from minparam_cli.robot import DeriveOptions

    method = Method(method).value
    kinds = tuple(k.strip() for k in friction.split(",") if k.strip())
    for k in kinds:
        if k not in FRICTION_KINDS:
            raise typer.BadParameter(f"unknown friction kind {k!r}; expected any of {','.join(FRICTION_KINDS)}", param_hint="--friction")
    if samples < 1:
        raise typer.BadParameter("must be positive", param_hint="--samples")
    g = parse_floats(gravity, 3, "--gravity") if gravity is not None else None
    if snap_angles is not None:
        from minparam_cli.describe.snap import MAX_TOLERANCE

        if not 0.0 < snap_angles < MAX_TOLERANCE:
            raise typer.BadParameter(f"must be a tolerance in radians in (0, {MAX_TOLERANCE:.4g}) (half of 15°), got {snap_angles:g}", param_hint="--snap-angles")
    opts = DeriveOptions(method, kinds, rotor_inertia, g, samples, seed, symbolic, snap_angles, mimic=MimicMode(mimic).value,
                         floating_base=floating_base, symbolic_numbers=symbolic_numbers)
    files, any_folder = expand_paths(list(paths), recursive)

    if len(files) == 1 and not any_folder:
        bar = Progress(1, f"{method} {files[0].name}", quiet)
        try:
            report = derive_file(files[0], opts, progress=bar)
        finally:
            bar.close()
        write_output(render(report, fmt), output)
        if not quiet:
            for w in report.get("warnings", []):
                warning_line(w)
        return

    bar = Progress(len(files), "derive", quiet)
    try:
        results = run_batch(derive_file, files, (opts,), jobs, progress=bar, scheduler=scheduler)
    finally:
        bar.close()
    write_output(render_batch(results, fmt, reports=not any_folder), output)
    failed = [r for r in results if not r["ok"] and r["status"] == "error"]
    if not quiet:
        for r in results:
            for w in (r["result"].get("warnings", []) if r["ok"] else []):
                warning_line(w)
        for r in failed:
            error_line(r["error"])
    if failed:
        raise typer.Exit(max(r["exit_code"] for r in failed))


def render(report: dict, fmt: Format) -> str:
    if fmt in (Format.json, Format.jsonl):
        import json  # imported here: the default table output does not need it

        return json.dumps(report, indent=2 if fmt == Format.json else None, ensure_ascii=False)
    from minparam_cli.render import text

    if fmt == Format.markdown:
        return text.render_markdown(report)
    if fmt == Format.latex:
        return text.render_latex(report)
    return text.render_table(report)


def _summary_rows(results: list[dict]) -> list[tuple]:
    rows = []
    for r in results:
        if r["ok"]:
            rep = r["result"]
            rows.append((rep["robot"], r["path"], rep["dof"], rep["n_standard"], rep["n_base"], f"{r['elapsed_s']:.3f}", "ok"))
        else:
            rows.append(("", r["path"], "", "", "", f"{r['elapsed_s']:.3f}", f"{r['status']}: {r['error']}"))
    return rows


def render_batch(results: list[dict], fmt: Format, reports: bool = True) -> str:
    """Several robots: JSON items, or each robot's report followed by the summary table.

    In table format the reports are left out when ``reports`` is False (a folder was given: the
    summary is what one reads of a folder of robots); robots named one by one get theirs."""
    import json

    from tabulate import tabulate

    if fmt in (Format.json, Format.jsonl):
        items = []
        for r in results:
            if r["ok"]:
                items.append(r["result"])
            else:
                items.append({"source": r["path"], "status": r["status"], "error": r["error"]})
        if fmt == Format.jsonl:
            return "\n".join(json.dumps(i, ensure_ascii=False) for i in items)
        return json.dumps(items, indent=2, ensure_ascii=False)
    headers = ["robot", "file", "dof", "standard", "base", "time s", "status"]
    if fmt == Format.table:
        summary = tabulate(_summary_rows(results), headers=headers, tablefmt="simple")
        if not reports:
            return summary
        return "\n\n".join([render(r["result"], fmt) for r in results if r["ok"]] + [summary])
    parts = [render(r["result"], fmt) for r in results if r["ok"]]
    if fmt == Format.markdown:
        parts.append(tabulate(_summary_rows(results), headers=headers, tablefmt="github"))
    return "\n".join(parts)
