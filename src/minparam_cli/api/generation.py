"""Code generation (``minparam codegen``): the option checks, the base set or the saved model, the
generated text and the files it goes to, shared by the command and by ``minparam.codegen``.

The command is a shell over ``generate`` (and ``write_files``): it adds its own refusal of C on
stdout, prints the notes and the operation counts; ``codegen`` below is the library call, whose
result holds the same text the command writes (the comment block names the equivalent command).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterable, cast

from minparam_cli.api.common import robot_path, warn
from minparam_cli.api.generated import GeneratedCode
from minparam_cli.api.options.codegen import CodegenOptions
from minparam_cli.api.results import Robot
from minparam_cli.errors import InputError
from minparam_cli.output import is_stdout

if TYPE_CHECKING:
    from minparam_cli.codegen.functions import Generated


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
    params = ModelParameters(str(model), kind, m.fit_theta(kind), design.names, tuple(m.terms), m.theta_model,
                             tuple(m.term_evidence(i) for i in range(len(m.terms))))
    return chain, base, params


def generate(robot: Path, opts: CodegenOptions) -> tuple[Generated, str]:
    """The generated files of ``minparam codegen`` for ``robot``, and the file stem the C source includes."""
    from minparam_cli import __version__
    from minparam_cli.codegen.functions import Meta, generate_code, identifier
    from minparam_cli.model.file import sha256_hex
    from minparam_cli.robot import DeriveOptions, load_chain
    from minparam_cli.safety import read_bounded

    if not robot.is_file():
        raise InputError(f"{robot}: robot file not found")
    robot_bytes = read_bounded(robot)
    params = None
    if opts.model is None:
        stage = DeriveOptions(opts.method, opts.friction_kinds, opts.rotor_inertia, opts.gravity_vector, opts.samples,
                              opts.seed, mimic=opts.mimic, floating_base=opts.floating_base)
        desc, chain = load_chain(robot, stage, loops=True)
        if desc.loops is not None:  # a closed chain: the actuated torques' base regressor (codegen/closed.py)
            return _closed(desc, chain, robot, robot_bytes, opts), _stem(opts, chain.name)
        if opts.method == "projection":
            from minparam_cli.base.projection import derive_projection

            base = derive_projection(chain)
        else:
            from minparam_cli.base.qr import derive_qr

            base = derive_qr(chain, samples=opts.samples, seed=opts.seed)
    else:
        chain, base, params = model_chain(opts.model, robot, robot_bytes, opts.parameters)
    output, name = opts.output, opts.name
    if output is not None and not is_stdout(output):
        stem = output.stem
    else:
        stem = chain.name if opts.lang != "c" else identifier(name if name is not None else chain.name)
    prefix = identifier(name if name is not None else stem)
    meta = Meta(str(robot), sha256_hex(robot_bytes), opts.command_line(robot), __version__)
    return generate_code(chain, base, opts.lang, prefix, meta, params, opts.full, stem=stem), stem


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
    if isinstance(robot, Robot) and model is None:
        o = robot.options
        friction = friction if friction is not None else o.friction
        rotor_inertia = rotor_inertia if rotor_inertia is not None else o.rotor_inertia
        gravity = gravity if gravity is not None else o.gravity
        mimic = mimic if mimic is not None else o.mimic
        floating_base = floating_base if floating_base is not None else o.floating_base
    # cast(Any, ...): raw values (text, sequences, mappings) that the record normalises on construction (its fields: the stored types)
    opts = CodegenOptions(lang=lang, output=cast(Any, output), model=model, parameters=parameters, full=full, name=name,
                          method=method, friction=cast(Any, friction if friction is not None else ""),
                          rotor_inertia=bool(rotor_inertia), gravity=gravity, samples=int(samples), seed=int(seed),
                          mimic=mimic or "coupled", floating_base=bool(floating_base))
    gen, stem = generate(path, opts)
    warn(gen.notes)
    return GeneratedCode(lang=opts.lang, files=dict(gen.files), counts={k: dict(v) for k, v in gen.counts.items()},
                         base_names=tuple(gen.base_names), output=opts.output, notes=tuple(gen.notes), _generated_stem=stem)


def _stem(opts: CodegenOptions, name: str) -> str:
    from minparam_cli.codegen.functions import identifier

    if opts.output is not None and not is_stdout(opts.output):
        return opts.output.stem
    return name if opts.lang != "c" else identifier(opts.name if opts.name is not None else name)


def _closed(desc, chain, robot: Path, robot_bytes: bytes, opts: CodegenOptions) -> Generated:
    """A closed chain's generated base regressor (C or NumPy; codegen/closed.py)."""
    from minparam_cli import __version__
    from minparam_cli.codegen.closed import generate_closed_code
    from minparam_cli.codegen.functions import Meta, identifier
    from minparam_cli.errors import UnsupportedError
    from minparam_cli.loops.derive import derive_closed
    from minparam_cli.loops.model import closed_model
    from minparam_cli.model.file import sha256_hex

    if opts.full:
        raise UnsupportedError("codegen --full of a closed chain: not supported (the base regressor only)", str(robot))
    base = derive_closed(desc, chain, opts.samples, opts.seed, opts.method)
    stem = _stem(opts, chain.name)
    prefix = identifier(opts.name if opts.name is not None else stem)
    meta = Meta(str(robot), sha256_hex(robot_bytes), opts.command_line(robot), __version__)
    return generate_closed_code(closed_model(desc, chain), base, opts.lang, prefix, meta, stem)
