"""Code generation (``minparam codegen``): the option checks, the base set or the saved model, the
generated text and the files it goes to, shared by the command and by ``minparam.codegen``.

The command is a shell over ``generate`` (and ``write_files``): it adds its own refusal of C on
stdout, prints the notes and the operation counts; ``codegen`` below is the library call, whose
result holds the same text the command writes (the comment block names the equivalent command).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterable

from minparam_cli.api.common import OptionError, choice, float_option, friction_option, robot_path, warn
from minparam_cli.api.results import GeneratedCode, Robot
from minparam_cli.errors import InputError

if TYPE_CHECKING:
    from minparam_cli.codegen.functions import Generated

LANGS = ("c", "python", "casadi")
METHODS = ("qr", "projection")
PARAMETERS = ("physical", "fit")


def is_stdout(path: Any) -> bool:
    return path is not None and str(path) == "-"


def command_line(robot: Path, lang: str, output: Path | None, model: Path | None, which: str | None, full: bool,
                 name: str | None, method: str, friction: str, rotor_inertia: bool, gravity: str | None, samples: int,
                 seed: int, mimic: str, floating_base: bool) -> str:
    """The command line as the comment block shows it (the options that were given)."""
    parts = ["minparam codegen", str(robot), "--lang", lang]
    if output is not None:
        parts += ["-o", str(output)]
    for flag, value, default in (("--model", model, None), ("--parameters", which, None), ("--name", name, None),
                                 ("--method", method, "qr"), ("--friction", friction, ""), ("--gravity", gravity, None),
                                 ("--samples", samples, 100), ("--seed", seed, 0), ("--mimic", mimic, "coupled")):
        if value != default:
            parts += [flag, str(value)]
    parts += [flag for flag, on in (("--rotor-inertia", rotor_inertia), ("--full", full), ("--floating-base", floating_base)) if on]
    return " ".join(parts)


def model_chain(model: Path, robot: Path, robot_bytes: bytes, which: str | None):
    """Chain, base set and parameters of a saved model, refused when made for another robot file."""
    from minparam_cli.base.qr import derive_qr
    from minparam_cli.codegen.functions import ModelParameters
    from minparam_cli.model.file import check_robot, model_design
    from minparam_cli.model.parse import read_model
    from minparam_cli.robot import load_chain, require_fixed_base

    m = read_model(model)
    check_robot(m, str(model), str(robot), robot_bytes)
    _, chain = load_chain(robot, m.load.derive_options(m.seed))
    require_fixed_base(chain, "codegen --model")
    chain = chain.with_coulomb_smoothing(m.load.coulomb_smoothing)
    design = model_design(m, chain, str(model))
    kind = which if which is not None else ("physical" if m.physical is not None else "fit")
    base = derive_qr(chain, seed=m.seed)
    params = ModelParameters(str(model), kind, m.fit_theta(kind), design.names, tuple(m.terms), m.theta_model)
    return chain, base, params


def generate(robot: Path, lang: str, output: Path | None = None, model: Path | None = None, which: str | None = None,
             full: bool = False, name: str | None = None, method: str = "qr", friction: str = "",
             rotor_inertia: bool = False, gravity: str | None = None, samples: int = 100, seed: int = 0,
             mimic: str = "coupled", floating_base: bool = False) -> tuple[Generated, str]:
    """The generated files of ``minparam codegen`` (options as the command spells them: ``friction``
    "coulomb,viscous", ``gravity`` "X,Y,Z" text), and the file stem the C source includes."""
    from minparam_cli import __version__
    from minparam_cli.codegen.functions import Meta, generate_code, identifier
    from minparam_cli.safety import read_bounded
    from minparam_cli.model.file import sha256_hex
    from minparam_cli.robot import DeriveOptions, load_chain

    lang = choice(lang, LANGS, "--lang")
    method = choice(method, METHODS, "--method")
    mimic = choice(mimic, ("coupled", "fixed"), "--mimic")
    which = choice(which, PARAMETERS, "--parameters") if which is not None else None
    kinds = friction_option(friction)
    if samples < 1:
        raise OptionError("--samples", "must be positive")
    g3 = float_option(gravity, 3, "--gravity") if gravity is not None else None
    g = (g3[0], g3[1], g3[2]) if g3 is not None else None
    if not robot.is_file():
        raise InputError(f"{robot}: robot file not found")
    robot_bytes = read_bounded(robot)
    command = command_line(robot, lang, output, model, which, full, name, method, friction, rotor_inertia, gravity,
                           samples, seed, mimic, floating_base)
    params = None
    if model is None:
        if which is not None:
            raise InputError("--parameters needs --model")
        opts = DeriveOptions(method, kinds, rotor_inertia, g, samples, seed, mimic=mimic, floating_base=floating_base)
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
        chain, base, params = model_chain(model, robot, robot_bytes, which)
    if output is not None and not is_stdout(output):
        stem = output.stem
    else:
        stem = chain.name if lang != "c" else identifier(name if name is not None else chain.name)
    prefix = identifier(name if name is not None else stem)
    if name is not None and prefix != name:
        raise OptionError("--name", f"must be a C identifier (letters, digits, _), e.g. {prefix}")
    meta = Meta(str(robot), sha256_hex(robot_bytes), command, __version__)
    return generate_code(chain, base, lang, prefix, meta, params, full, stem=stem), stem


def _text(value: Any) -> str:
    return repr(value) if float(format(value, "g")) != value else format(value, "g")


def codegen(robot: Robot | str | Path, lang: str, *, model: Any = None, parameters: str | None = None,
            full: bool = False, name: str | None = None, output: str | Path | None = None, method: str = "qr",
            friction: str | Iterable[str] | None = None, rotor_inertia: bool | None = None, gravity: Any = None,
            samples: int = 100, seed: int = 0, mimic: str | None = None, floating_base: bool | None = None) -> GeneratedCode:
    """Generate the base regressor Y_b(q, qd, qdd) (``full=True``: also the full regressor and K) as
    self-contained code (``minparam codegen``): ``lang`` "c" (C99, a .c and a .h), "python" (NumPy)
    or "casadi".  With ``model`` (a model file of ``identify --save-model``, or ``Model.save``)
    also ``inverse_dynamics`` with its ``parameters`` ("physical" or "fit").
    ``output``: the file the code is meant for (it names the C header and the identifiers, as ``-o``
    does; nothing is written until ``.write()``).  The text is the command's, byte for byte.  A
    Robot's own friction, rotor inertia, gravity, mimic mode and floating base apply unless given here
    (not with ``model``: the model's settings apply).
    """
    path = robot_path(robot)
    if model is not None and not isinstance(model, (str, Path)):
        raise InputError(f"model: expected a model file path (of identify --save-model or Model.save), got {type(model).__name__}")
    model_path = Path(model) if model is not None else None
    if isinstance(robot, Robot) and model is None:
        o = robot.options
        friction = friction if friction is not None else o.friction
        rotor_inertia = rotor_inertia if rotor_inertia is not None else o.rotor_inertia
        gravity = gravity if gravity is not None else o.gravity
        mimic = mimic if mimic is not None else o.mimic
        floating_base = floating_base if floating_base is not None else o.floating_base
    friction_text = friction if isinstance(friction, str) else ",".join(str(k) for k in (friction or ()))
    if gravity is None or isinstance(gravity, str):
        gravity_text = gravity
    else:
        gravity_text = ",".join(_text(float(x)) for x in float_option(gravity, 3, "--gravity"))
    out = Path(output) if output is not None else None
    gen, stem = generate(path, lang, out, model_path, parameters, full, name, method, friction_text, bool(rotor_inertia),
                         gravity_text, int(samples), int(seed), mimic or "coupled", bool(floating_base))
    warn(gen.notes)
    return GeneratedCode(lang=choice(lang, LANGS, "--lang"), files=dict(gen.files), counts={k: dict(v) for k, v in gen.counts.items()},
                         base_names=tuple(gen.base_names), output=out, notes=tuple(gen.notes), _generated_stem=stem)
