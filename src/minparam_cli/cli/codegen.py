"""`minparam codegen`: the base regressor (and an identified model's inverse dynamics) as code."""

from __future__ import annotations

import time
from enum import Enum
from pathlib import Path
from typing import Optional

import typer

from minparam_cli.cli.common import MimicMode, floating_base_option, guarded, is_stdout, mimic_option, parse_floats, warning_line, write_output
from minparam_cli.params import FRICTION_KINDS

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
    robot: Path = typer.Argument(..., help="Robot file (YAML DH/MDH or URDF).", show_default=False),
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


def _command(robot, lang, output, model, which, full, name, method, friction, rotor_inertia, gravity, samples, seed, mimic, floating_base) -> str:
    """The command line as the comment block shows it (the options that were given)."""
    parts = ["minparam codegen", str(robot), "--lang", Lang(lang).value]
    if output is not None:
        parts += ["-o", str(output)]
    for flag, value, default in (("--model", model, None), ("--parameters", which and Which(which).value, None),
                                 ("--name", name, None), ("--method", method, "qr"), ("--friction", friction, ""),
                                 ("--gravity", gravity, None), ("--samples", samples, 100), ("--seed", seed, 0),
                                 ("--mimic", MimicMode(mimic).value, "coupled")):
        if value != default:
            parts += [flag, str(value)]
    parts += [flag for flag, on in (("--rotor-inertia", rotor_inertia), ("--full", full), ("--floating-base", floating_base)) if on]
    return " ".join(parts)


@guarded
def _codegen(robot, lang, output, model, which, full, name, method, friction, rotor_inertia, gravity, samples, seed, mimic,
             floating_base, quiet):
    from minparam_cli import __version__
    from minparam_cli.cli.model_files import read_robot_bytes
    from minparam_cli.codegen.functions import Meta, generate_code, identifier
    from minparam_cli.errors import InputError
    from minparam_cli.identify.model import sha256_hex
    from minparam_cli.pipeline import DeriveOptions, load_chain

    t0 = time.perf_counter()
    lang = Lang(lang).value
    if lang == "c" and (output is None or is_stdout(output)):
        raise InputError("C output is two files (.c and .h): give -o FILE.c")
    method = Method(method).value
    kinds = tuple(k.strip() for k in friction.split(",") if k.strip())
    for k in kinds:
        if k not in FRICTION_KINDS:
            raise typer.BadParameter(f"unknown friction kind {k!r}; expected any of {','.join(FRICTION_KINDS)}", param_hint="--friction")
    if samples < 1:
        raise typer.BadParameter("must be positive", param_hint="--samples")
    g = parse_floats(gravity, 3, "--gravity") if gravity is not None else None
    if not robot.is_file():
        raise InputError(f"{robot}: robot file not found")
    robot_bytes = read_robot_bytes(robot)
    command = _command(robot, lang, output, model, which, full, name, method, friction, rotor_inertia, gravity, samples, seed, mimic, floating_base)
    params = None
    if model is None:
        if which is not None:
            raise InputError("--parameters needs --model")
        opts = DeriveOptions(method, kinds, rotor_inertia, g, samples, seed, mimic=MimicMode(mimic).value, floating_base=floating_base)
        _, chain = load_chain(robot, opts)
        if method == "projection":
            from minparam_cli.base.projection import derive_projection

            base = derive_projection(chain)
        else:
            from minparam_cli.base.qr import derive_qr

            base = derive_qr(chain, samples=samples, seed=seed)
    else:
        given = [flag for flag, on in (("--friction", kinds), ("--rotor-inertia", rotor_inertia), ("--gravity", g),
                                       ("--method projection", method != "qr"), ("--floating-base", floating_base)) if on]
        if given:
            raise InputError(f"{' and '.join(given)}: with --model the model's own settings apply")
        chain, base, params = _model_chain(model, robot, robot_bytes, which)
    stem = output.stem if lang == "c" else (output.stem if output is not None and not is_stdout(output) else chain.name)
    prefix = identifier(name if name is not None else stem)
    if name is not None and prefix != name:
        raise typer.BadParameter(f"must be a C identifier (letters, digits, _), e.g. {prefix}", param_hint="--name")
    meta = Meta(str(robot), sha256_hex(robot_bytes), command, __version__)
    gen = generate_code(chain, base, lang, prefix, meta, params, full, stem=stem)
    if lang == "c":
        write_output(gen.files[".h"], output.with_suffix(".h"))
        write_output(gen.files[".c"], output.with_suffix(".c") if output.suffix != ".c" else output)
    else:
        write_output(gen.files[".py"], output)
    if not quiet:
        for note in gen.notes:
            warning_line(note)
        _summary(gen, lang, output, time.perf_counter() - t0)


def _model_chain(model: Path, robot: Path, robot_bytes: bytes, which):
    """Chain, base set and parameters of a saved model, refused when made for another robot file."""
    from minparam_cli.base.qr import derive_qr
    from minparam_cli.codegen.functions import ModelParameters
    from minparam_cli.describe.safety import read_bounded
    from minparam_cli.errors import DescriptionError
    from minparam_cli.identify.model import ModelError, check_robot, model_design, parse_model
    from minparam_cli.pipeline import load_chain, require_fixed_base

    try:
        text = read_bounded(model).decode("utf-8")
    except DescriptionError as e:
        raise ModelError(f"cannot read the model file: {e}") from None
    except UnicodeDecodeError as e:
        raise ModelError(f"{model}: cannot read the model file (not UTF-8 text: {e.reason})") from None
    m = parse_model(text, str(model))
    check_robot(m, str(model), str(robot), robot_bytes)
    _, chain = load_chain(robot, m.load.derive_options(m.seed))
    require_fixed_base(chain, "codegen --model")
    chain = chain.with_coulomb_smoothing(m.load.coulomb_smoothing)
    design = model_design(m, chain, str(model))
    kind = which.value if which is not None else ("physical" if m.physical is not None else "fit")
    base = derive_qr(chain, seed=m.seed)
    params = ModelParameters(str(model), kind, m.fit_theta(kind), design.names, tuple(m.terms), m.theta_model)
    return chain, base, params


def _summary(gen, lang: str, output, elapsed: float) -> None:
    """Operation counts and time on stderr (what the papers compare: multiplications, additions)."""
    import sys

    where = "stdout" if output is None or is_stdout(output) else (
        f"{output.with_suffix('.c')} + {output.with_suffix('.h')}" if lang == "c" else str(output))
    lines = [f"codegen: {where}, {len(gen.base_names)} base parameters, generated in {elapsed:.2f} s"]
    for fn, c in gen.counts.items():
        calls = ", ".join(f"{v} {k}" for k, v in c.items() if k not in ("mul", "add", "neg") and v)
        lines.append(f"  {fn}: {c['mul']} multiplications, {c['add']} additions" + (f", {calls}" if calls else ""))
    sys.stderr.write("\n".join(lines) + "\n")


def register(app: typer.Typer) -> None:
    app.command(name="codegen", help=HELP, epilog=EPILOG)(codegen)
