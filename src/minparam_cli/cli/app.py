"""The ``minparam`` command: joins one typer module per command."""

from __future__ import annotations

import os

# Single-threaded BLAS unless the user says otherwise: every matrix here is small
# (hundreds of rows), where OpenBLAS threads cost more than they save and
# stall badly on a busy machine.  Must be set before numpy is imported.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import typer  # noqa: E402

from minparam_cli import __version__  # noqa: E402

app = typer.Typer(
    name="minparam",
    help="Base inertial parameters, identification and kinematics of robot arms from DH/MDH tables or URDF.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,
    context_settings={"help_option_names": ["-h", "--help"]},
)


def _version(value: bool):
    if value:
        print(f"minparam {__version__}")
        raise typer.Exit(0)


@app.callback()
def _root(
    version: bool = typer.Option(False, "--version", callback=_version, is_eager=True, help="Print the version and exit."),
):
    """minparam: base parameters, identification, singularities and platforms."""


def _register() -> None:
    from minparam_cli.cli import check, derive, identify, platform, simulate, singular

    app.command(name="derive", help=derive.HELP, epilog=derive.EPILOG)(derive.derive)
    app.command(name="check", help=check.HELP, epilog=check.EPILOG)(check.check)
    for module in (identify, simulate, singular, platform):
        module.register(app)


_register()


def main() -> int:
    try:
        app(standalone_mode=True)
    except SystemExit as e:
        return int(e.code or 0) if not isinstance(e.code, str) else 1
    return 0
