"""`minparam derive`: base parameters of one robot or a folder of robots."""

from __future__ import annotations

from enum import Enum
from pathlib import Path
from typing import List, Optional

import typer

from minparam_cli.cli.batch import run_batch
from minparam_cli.cli.common import (
    Format,
    MimicMode,
    error_line,
    floating_base_option,
    guarded,
    mimic_option,
    option_errors,
    warning_line,
)
from minparam_cli.cli.executor import scheduler_option
from minparam_cli.output import Progress, write_output

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
    paths: List[Path] = typer.Argument(..., help="Robot files (YAML DH/MDH, URDF or MJCF .xml) or folders of them.", show_default=False),
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
    _derive(paths, method, fmt, friction, rotor_inertia, gravity, samples, seed, symbolic, symbolic_numbers, snap_angles, mimic,
            floating_base, output, recursive, jobs, scheduler, quiet)


@guarded
def _derive(paths, method, fmt, friction, rotor_inertia, gravity, samples, seed, symbolic, symbolic_numbers, snap_angles, mimic,
            floating_base, output, recursive, jobs, scheduler, quiet):
    from minparam_cli.api.common import expand_paths
    from minparam_cli.api.derivation import derive_file
    from minparam_cli.api.options.derive import DeriveOptions
    from minparam_cli.render.derive_text import render, render_batch

    with option_errors():
        opts = DeriveOptions(method=method, friction=friction, rotor_inertia=rotor_inertia, gravity=gravity, samples=samples,
                             seed=seed, symbolic=bool(symbolic), symbolic_numbers=symbolic_numbers, snap_angles=snap_angles,
                             mimic=mimic, floating_base=floating_base)
    files, any_folder = expand_paths(list(paths), recursive)
    fmt = Format(fmt).value

    if len(files) == 1 and not any_folder:
        bar = Progress(1, f"{opts.method} {files[0].name}", quiet)
        try:
            base = derive_file(files[0], opts, progress=bar)
        finally:
            bar.close()
        write_output(render(base, fmt), output)
        if not quiet:
            for w in base.warnings:
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
            for w in (r["result"].warnings if r["ok"] else ()):
                warning_line(w)
        for r in failed:
            error_line(r["error"])
    if failed:
        raise typer.Exit(max(r["exit_code"] for r in failed))
