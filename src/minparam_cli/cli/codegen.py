"""`minparam codegen`: the base regressor (and an identified model's inverse dynamics) as code.

A shell over ``api.generation.generate`` (what ``minparam.codegen`` calls): parse, refuse C on
stdout, generate, write, print the notes and the operation counts."""

from __future__ import annotations

import sys
import time
from enum import Enum
from pathlib import Path
from typing import Optional

import typer

from minparam_cli.cli.common import MimicMode, floating_base_option, guarded, mimic_option, option_errors, warning_line
from minparam_cli.output import is_stdout

HELP = ("Write the base regressor Y_b(q, qd, qdd) of a robot, and with --model the identified inverse dynamics, "
        "as self-contained C99, NumPy or CasADi code.")
EPILOG = """\b
Examples:
  minparam codegen robots/panda.yaml --lang c -o panda.c          (writes panda.c and panda.h)
  minparam codegen robots/puma560.yaml --lang python -o puma.py --friction coulomb,viscous
  minparam codegen robots/puma560_mdh.yaml --model model.json --lang casadi -o puma_ca.py
  minparam codegen robots/ur5.urdf --lang c -o ur5.c --full       (also the full regressor and K)

\b
Columns and names are derive's base set (same --method, --seed, --samples, extras).  With
--model the robot file must be the one the model was made for (same SHA-256) and the
model's extras, gravity and seed are used.  Operation counts go to stderr.
Exit codes: 0 success, 1 failed computation, 2 bad input.
"""


class Lang(str, Enum):
    c = "c"
    python = "python"
    casadi = "casadi"


class Method(str, Enum):
    qr = "qr"
    projection = "projection"


class Which(str, Enum):
    physical = "physical"
    fit = "fit"


def codegen(
    robot: Path = typer.Argument(..., help="Robot file (YAML DH/MDH, URDF or MJCF .xml).", show_default=False),
    lang: Lang = typer.Option(..., "--lang", "-l", help="c (one .h + one .c, C99, libm only), python (NumPy) or casadi."),
    output: Optional[Path] = typer.Option(None, "--output", "-o", help="Output file (C: FILE.c, and FILE.h beside it; python/casadi: default stdout)."),
    model: Optional[Path] = typer.Option(None, "--model", help="Model file of 'identify --save-model': also generate inverse_dynamics with its parameters."),
    which: Optional[Which] = typer.Option(None, "--parameters", help="With --model: the physical fit (default when the model has one) or the unconstrained fit."),
    full: bool = typer.Option(False, "--full", help="Also generate the full regressor Y and the matrix K (beta_b = K phi)."),
    name: Optional[str] = typer.Option(None, "--name", help="Prefix of the C identifiers (default: the output file's name)."),
    method: Method = typer.Option(Method.qr, "--method", "-m", help="Base set as derive computes it: qr (random samples + QR) or projection."),
    friction: str = typer.Option("", "--friction", help="Add friction columns to every joint: any of coulomb,viscous,offset."),
    rotor_inertia: bool = typer.Option(False, "--rotor-inertia", help="Add a rotor inertia column Ia per joint."),
    gravity: Optional[str] = typer.Option(None, "--gravity", help="Gravity vector X,Y,Z in m/s² (overrides the file)."),
    samples: int = typer.Option(100, "--samples", help="Random states of the QR method."),
    seed: int = typer.Option(0, "--seed", help="Seed of the random states of the QR method."),
    mimic: MimicMode = mimic_option(),
    floating_base: bool = floating_base_option(),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No operation counts on stderr."),
):
    _codegen(robot, lang, output, model, which, full, name, method, friction, rotor_inertia, gravity, samples, seed, mimic,
             floating_base, quiet)


@guarded
def _codegen(robot, lang, output, model, which, full, name, method, friction, rotor_inertia, gravity, samples, seed, mimic,
             floating_base, quiet):
    from minparam_cli.api.generation import generate
    from minparam_cli.api.options.codegen import CodegenOptions
    from minparam_cli.errors import InputError
    from minparam_cli.output import write_code_files
    from minparam_cli.render.codegen_text import summary_text

    t0 = time.perf_counter()
    lang = Lang(lang).value
    if lang == "c" and (output is None or is_stdout(output)):
        raise InputError("C output is two files (.c and .h): give -o FILE.c")
    with option_errors():
        opts = CodegenOptions(lang=lang, output=output, model=model, parameters=which, full=full, name=name, method=method,
                              friction=friction, rotor_inertia=rotor_inertia, gravity=gravity, samples=samples, seed=seed,
                              mimic=mimic, floating_base=floating_base)
        gen, _ = generate(robot, opts)
    write_code_files(gen.files, lang, output)
    if not quiet:
        for note in gen.notes:
            warning_line(note)
        sys.stderr.write(summary_text(gen, lang, output, time.perf_counter() - t0))


def register(app: typer.Typer) -> None:
    app.command(name="codegen", help=HELP, epilog=EPILOG)(codegen)
