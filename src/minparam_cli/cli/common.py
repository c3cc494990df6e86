"""What every command shares: error mapping, atomic output, progress on stderr."""

from __future__ import annotations

import contextlib
import functools
import math
import os
import sys
from collections.abc import Sequence
from enum import Enum
from pathlib import Path
from typing import Any, Callable, cast

import click
import typer
import typer.core

from minparam_cli.errors import MinparamError
from minparam_cli.output import atomic_write


class Format(str, Enum):
    table = "table"
    markdown = "markdown"
    latex = "latex"
    json = "json"
    jsonl = "jsonl"


class MimicMode(str, Enum):
    """What a command does with URDF mimic joints (``describe.records.MIMIC_MODES``)."""

    coupled = "coupled"
    fixed = "fixed"


def mimic_option():
    """The --mimic option every command that loads a robot takes."""
    return typer.Option(
        MimicMode.coupled,
        "--mimic",
        help="URDF mimic joints (MJCF linear joint equalities): coupled (move with their master; data give only the independent joints) or fixed (frozen at their offset).",
    )


def floating_base_option():
    """The --floating-base option every command that loads a robot takes."""
    return typer.Option(
        False,
        "--floating-base",
        help="The URDF's root link is free (a legged robot, a humanoid): add the 6-DOF base and its six base-wrench equations.",
    )


MAX_ERROR_CHARS = 600  # an error line quotes values from the file: never a screenful


def error_line(message: str) -> None:
    """Print one error line on stderr (never a traceback), at most MAX_ERROR_CHARS long."""
    text = " ".join(str(message).split())
    if len(text) > MAX_ERROR_CHARS:
        text = text[: MAX_ERROR_CHARS - 3] + "..."
    print(f"minparam: error: {text}", file=sys.stderr)


def warning_line(message: str) -> None:
    """Print one warning line on stderr."""
    text = " ".join(str(message).split())
    if len(text) > MAX_ERROR_CHARS:
        text = text[: MAX_ERROR_CHARS - 3] + "..."
    print(f"minparam: warning: {text}", file=sys.stderr)


class _FiniteFloat(click.ParamType):
    """Mixed into a click float type (FLOAT, FloatRange), before it: 'nan', 'inf' and '1e999' are refused."""

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:

        x = super().convert(value, param, ctx)
        if x is not None and not math.isfinite(x):
            self.fail(f"{value!r} is not a finite number.", param, ctx)
        return x


def _finite_float_type(t: click.ParamType) -> click.ParamType:
    """A copy of click float type ``t`` that refuses non-finite values (same name, range and help)."""
    import copy

    if isinstance(t, _FiniteFloat) or not isinstance(t, click.types.FloatParamType):
        return t
    cls = cast("type[click.types.FloatParamType]", type(f"Finite{type(t).__name__}", (_FiniteFloat, type(t)), {}))
    new = cls.__new__(cls)
    new.__dict__.update(copy.copy(t.__dict__))
    return new


def _validate_params(command: click.Command) -> None:
    """Every float option of every command refuses non-finite values, and every --seed a negative one
    (numpy's generators take seeds >= 0): click's own messages, on click's own path."""
    for param in command.params:
        if isinstance(param.type, click.types.FloatParamType):
            param.type = _finite_float_type(param.type)
        elif param.name == "seed" and param.type is click.INT:
            param.type = click.IntRange(min=0)
    for sub in getattr(command, "commands", {}).values():
        _validate_params(sub)


class OneLineGroup(typer.core.TyperGroup):
    """The root group: option values validated (``_validate_params``), and a usage error (bad option,
    missing argument, invalid value) printed as one line on stderr, exit code 2."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        _validate_params(self)

    def main(self, args: Sequence[str] | None = None, prog_name: str | None = None, complete_var: str | None = None,
             standalone_mode: bool = True, windows_expand_args: bool = True, **extra: Any) -> Any:
        if not standalone_mode:
            return super().main(args, prog_name, complete_var, standalone_mode=False,
                                windows_expand_args=windows_expand_args, **extra)
        no_args = getattr(click.exceptions, "NoArgsIsHelpError", ())
        try:
            rv = super().main(args, prog_name, complete_var, standalone_mode=False,
                              windows_expand_args=windows_expand_args, **extra)
        except no_args as e:  # 'minparam' alone prints the help
            e.show()
            sys.exit(e.exit_code)
        except click.ClickException as e:
            error_line(_usage_line(e))
            sys.exit(e.exit_code)
        except click.Abort:
            error_line("aborted")
            sys.exit(1)
        sys.exit(rv if isinstance(rv, int) else 0)


def _usage_line(e: click.ClickException) -> str:
    """click's message, with the command and where to find its help, in one line."""
    ctx = getattr(e, "ctx", None)
    message = e.format_message()
    if ctx is None:
        return message
    help_name = ctx.help_option_names[0] if ctx.help_option_names else "--help"
    return f"{ctx.command_path}: {message} (see '{ctx.command_path} {help_name}')"


def guarded(fn: Callable) -> Callable:
    """Run a command body, mapping MinparamError to its exit code with one line on stderr.

    Exit codes: 0 success, 1 failed computation, 2 bad input.  An unexpected
    exception is reported in one line (exit 1); set MINPARAM_DEBUG=1 for the traceback.
    """

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        try:
            return fn(*args, **kwargs)
        except (typer.Exit, typer.Abort, click.ClickException):
            raise  # click prints usage errors itself, with exit code 2
        except MinparamError as e:
            error_line(str(e))
            raise typer.Exit(e.exit_code) from None
        except KeyboardInterrupt:
            error_line("interrupted")
            raise typer.Exit(130) from None
        except MemoryError:
            error_line("out of memory; try fewer samples or --method qr")
            raise typer.Exit(1) from None
        except Exception as e:  # noqa: BLE001 - the CLI must never print a traceback
            if os.environ.get("MINPARAM_DEBUG"):
                raise
            error_line(f"internal error: {type(e).__name__}: {e} (set MINPARAM_DEBUG=1 for details)")
            raise typer.Exit(1) from None

    return wrapper


def save_png(fig, path: Path, dpi: int = 110) -> None:
    """Save a matplotlib figure atomically as PNG, then close it."""
    import matplotlib.pyplot as plt

    try:
        atomic_write(Path(path), lambda tmp: fig.savefig(tmp, format="png", dpi=dpi), suffix=".png")
    finally:
        plt.close(fig)


@contextlib.contextmanager
def option_errors():
    """A shared check's ``OptionError`` as click's usage error naming the option (exit 2, one line)."""
    from minparam_cli.api.common import OptionError

    try:
        yield
    except OptionError as e:
        raise typer.BadParameter(e.detail, param_hint=e.option) from None
