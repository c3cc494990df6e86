"""The ``minparam`` command: joins one typer module per command.

Start-up time matters (``minparam derive robot.yaml`` is a short process), so
the command modules are imported, and their click commands built, only when
needed: ``main()`` registers just the command named first on the command line
and every command otherwise (``minparam --help``, an unknown name, options
before the command).  A command's own help and errors look the same either
way, because they never list the other commands.  ``app`` (the full app, for
tests and embedding) is built on first access.

Shell completion is typer's own (``--install-completion``, ``--show-completion``;
bash, zsh, fish).  It costs nothing measurable at start-up: typer imports its
completion module anyway, and the two root options take about 0.1 ms to build.
A completion request (``_MINPARAM_COMPLETE`` set) carries no command name on
the command line, so every command is registered for it.
"""

from __future__ import annotations

import importlib
import os
import sys

from minparam_cli import runtime

# Single-threaded BLAS unless the user says otherwise: every matrix here is small
# (hundreds of rows), where OpenBLAS threads cost more than they save and
# stall badly on a busy machine.  Must happen before numpy is imported.
runtime.single_thread_blas()

import typer  # noqa: E402



def _version(value: bool):
    if value:
        from minparam_cli.api.about import version_line

        print(version_line())
        raise typer.Exit(0)


def _root(
    version: bool = typer.Option(False, "--version", callback=_version, is_eager=True, help="Print the version and exit."),
):
    """minparam: base parameters, identification, singularities and platforms."""


def _add_derive(app: typer.Typer) -> None:
    from minparam_cli.cli import derive

    app.command(name="derive", help=derive.HELP, epilog=derive.EPILOG)(derive.derive)


def _add_check(app: typer.Typer) -> None:
    from minparam_cli.cli import check

    app.command(name="check", help=check.HELP, epilog=check.EPILOG)(check.check)


def _add_module(name: str):
    def add(app: typer.Typer) -> None:
        importlib.import_module(f"minparam_cli.cli.{name}").register(app)

    return add


# Every top-level command, in the order `minparam --help` lists them.
COMMANDS = {
    "derive": _add_derive,
    "check": _add_check,
    "identify": _add_module("identify"),
    "evaluate": _add_module("evaluate"),
    "simulate": _add_module("simulate"),
    "excite": _add_module("excite"),
    "singular": _add_module("singular"),
    "codegen": _add_module("codegen"),
    "platform": _add_module("platform"),
}


def build_app(names: tuple[str, ...] | None = None) -> typer.Typer:
    """The typer app with the commands ``names`` (every command when None), in COMMANDS order."""
    from minparam_cli.cli.common import OneLineGroup

    app = typer.Typer(
        cls=OneLineGroup,
        name="minparam",
        help="Base inertial parameters, identification and kinematics of robot arms from DH/MDH tables, URDF or MJCF.",
        no_args_is_help=True,
        add_completion=True,
        pretty_exceptions_enable=False,
        rich_markup_mode=None,
        context_settings={"help_option_names": ["-h", "--help"]},
    )
    app.callback()(_root)
    for name, add in COMMANDS.items():
        if names is None or name in names:
            add(app)
    return app


def commands_for(argv: list[str]) -> tuple[str, ...] | None:
    """The commands a command line needs: the one it starts with, or None (all) when it
    starts with anything else (an option such as --help, an unknown name, nothing)."""
    if argv and argv[0] in COMMANDS:
        return (argv[0],)
    return None


def __getattr__(name: str):
    if name == "app":  # the full app, built once on first access
        app = build_app()
        globals()["app"] = app
        return app
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _one_line_warnings() -> None:
    """The library's MinparamWarning notes (e.g. MuJoCo's compiler warnings on an MJCF file) printed as
    'minparam: warning: ...', one line; cvxpy's "Solution may be inaccurate" not at all (the physical fit's
    report gives the solver status and checks the constraints); every other warning as Python shows it.
    Our own process only."""
    import warnings

    from minparam_cli.errors import MinparamWarning

    shown = warnings.showwarning
    if getattr(shown, "minparam", False):  # main() run again in the same process
        return

    def show(message, category, filename, lineno, file=None, line=None):
        if issubclass(category, MinparamWarning):
            print(f"minparam: warning: {message}", file=sys.stderr)
        elif "Solution may be inaccurate" in str(message):
            pass  # cvxpy's, in identify --physical: the report's solver status and its constraint check say it
        else:
            shown(message, category, filename, lineno, file, line)

    show.minparam = True  # type: ignore[attr-defined]
    warnings.showwarning = show


def main() -> int:
    runtime.tune_allocator()  # our own process only: see runtime.py
    _one_line_warnings()
    # a command never renders: MuJoCo (imported for an MJCF file) then skips loading its OpenGL
    # backend, about 0.2 s of every .xml command; a user's own MUJOCO_GL is kept
    os.environ.setdefault("MUJOCO_GL", "disable")
    app = build_app(commands_for(sys.argv[1:]))
    try:
        app(standalone_mode=True)
    except SystemExit as e:
        return int(e.code or 0) if not isinstance(e.code, str) else 1
    return 0


def entry() -> int:
    """The ``minparam`` console script: ``main()``, then ready the process for a quick exit.

    Only here, never in ``main()``: a caller that runs ``main()`` in its own process goes on
    living, and would keep every reference cycle alive at the freeze (see runtime.py)."""
    code = main()
    runtime.freeze_before_exit()
    return code
