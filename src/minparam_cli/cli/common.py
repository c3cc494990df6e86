"""What every command shares: error mapping, atomic output, progress on stderr."""

from __future__ import annotations

import contextlib
import functools
import math
import os
import sys
import time
from enum import Enum
from pathlib import Path
from typing import Callable

import click
import typer
import typer.core

from minparam_cli.errors import ComputationError, InputError, MinparamError


class Format(str, Enum):
    table = "table"
    markdown = "markdown"
    latex = "latex"
    json = "json"
    jsonl = "jsonl"


class MimicMode(str, Enum):
    """What a command does with URDF mimic joints (``describe.urdf.MIMIC_MODES``)."""

    coupled = "coupled"
    fixed = "fixed"


def mimic_option():
    """The --mimic option every command that loads a robot takes."""
    return typer.Option(
        MimicMode.coupled,
        "--mimic",
        help="URDF mimic joints: coupled (move with their master; data give only the independent joints) or fixed (frozen at their offset).",
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


class _FiniteFloat:
    """Mixed into a click float type (FLOAT, FloatRange): 'nan', 'inf' and '1e999' are refused."""

    def convert(self, value, param, ctx):
        import math

        x = super().convert(value, param, ctx)
        if x is not None and not math.isfinite(x):
            self.fail(f"{value!r} is not a finite number.", param, ctx)
        return x


def _finite_float_type(t):
    """A copy of click float type ``t`` that refuses non-finite values (same name, range and help)."""
    import copy

    if isinstance(t, _FiniteFloat) or not isinstance(t, click.types.FloatParamType):
        return t
    cls = type(f"Finite{type(t).__name__}", (_FiniteFloat, type(t)), {})
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

    def main(self, args=None, prog_name=None, complete_var=None, standalone_mode=True, **extra):
        if not standalone_mode:
            return super().main(args, prog_name, complete_var, standalone_mode=False, **extra)
        no_args = getattr(click.exceptions, "NoArgsIsHelpError", ())
        try:
            rv = super().main(args, prog_name, complete_var, standalone_mode=False, **extra)
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


STDOUT = "-"  # `-o -`: the output goes to stdout


def is_stdout(path) -> bool:
    """True for the output name ``-`` (stdout)."""
    return path is not None and str(path) == STDOUT


def output_target(path: Path) -> tuple[Path, bool]:
    """Where an output name really writes, and whether that is a regular file to replace atomically.

    A symlink (or a chain of them) is followed to its target, so that the link stays a link and
    its target receives the new contents.  A character device, FIFO, socket or other special file
    is written through in place (``-o /dev/null``, a named pipe): it cannot be replaced by a rename.
    A folder, a link loop, or a missing output folder is refused before any work is done."""
    path = Path(path)
    target = Path(os.path.realpath(path)) if path.is_symlink() else path
    if path.is_symlink() and target.is_symlink():  # realpath gave up: a loop
        raise InputError(f"{path}: symbolic link loop; expected an output file name")
    if target.is_dir():
        raise InputError(f"{path}: is a folder; expected an output file name")
    if target.exists() and not target.is_file():
        return target, False
    directory = target.parent if str(target.parent) else Path(".")
    if not directory.is_dir():
        where = f"output folder {directory}" if target == path else f"the folder {directory} of its link target"
        raise InputError(f"{path}: {where} does not exist")
    return target, True


def check_output_path(path: Path) -> None:
    """An output file name must name a file in an existing folder (or ``-``, or a special file);
    refused before any work is done (a command that writes two files checks both first, so that a
    failure leaves neither)."""
    if not is_stdout(path):
        output_target(Path(path))


def output_folder(path: Path, flag: str) -> Path:
    """A folder for output files (``identify --plot figs/``), created with its parents when missing.

    An existing file of that name, or a folder that cannot be created, is refused in one line."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise InputError(f"{flag} {path}: exists and is not a folder")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise InputError(f"{flag} {path}: cannot create the folder ({e.strerror})") from None
    return path


def atomic_write(path: Path, write: Callable[[str], None], suffix: str = ".tmp") -> None:
    """Write one output file, never leaving a partial one.

    ``write`` fills the file named by its argument.  For a regular file (new or existing, or the
    target of a symlink) that is a temporary file in the same folder, renamed over the target; the
    file keeps its permission bits if it existed, otherwise it gets 0666 less the umask.  A special
    file (a device, a FIFO) is written through directly.  ``-`` writes to stdout (through a
    temporary file, so that ``write`` may be any file writer)."""
    import tempfile  # only when writing a file: not on the start-up path of every command

    if is_stdout(path):
        _write_stdout(write, suffix)
        return
    path = Path(path)
    target, regular = output_target(path)
    if not regular:
        try:
            write(str(target))
        except OSError as e:
            raise ComputationError(f"{path}: cannot write ({e.strerror})") from None
        return
    directory = target.parent if str(target.parent) else Path(".")
    try:
        mode = target.stat().st_mode & 0o7777 if target.exists() else None
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=suffix, dir=directory)
    except OSError as e:
        raise ComputationError(f"{path}: cannot write ({e.strerror})") from None
    os.close(fd)
    try:
        write(tmp)
        if mode is None:
            umask = os.umask(0)
            os.umask(umask)
            mode = 0o666 & ~umask  # mkstemp makes 0600; give a new file the usual permissions
        os.chmod(tmp, mode)
        os.replace(tmp, target)
    except OSError as e:
        raise ComputationError(f"{path}: cannot write ({e.strerror})") from None
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def _write_stdout(write: Callable[[str], None], suffix: str) -> None:
    """Run ``write`` on a temporary file, then copy its bytes to stdout."""
    import shutil
    import tempfile

    fd, tmp = tempfile.mkstemp(prefix=".minparam-stdout.", suffix=suffix)
    os.close(fd)
    try:
        write(tmp)
        sys.stdout.flush()
        with open(tmp, "rb") as fh:
            shutil.copyfileobj(fh, sys.stdout.buffer)
        sys.stdout.buffer.flush()
    finally:
        os.unlink(tmp)


def write_output(text: str, output: Path | None) -> None:
    """Write to stdout (no output, or ``-``), or to ``output`` through ``atomic_write``."""
    text = text if text.endswith("\n") else text + "\n"
    if output is None or is_stdout(output):
        sys.stdout.write(text)
        sys.stdout.flush()
        return
    atomic_write(Path(output), lambda tmp: Path(tmp).write_text(text, encoding="utf-8"))


def save_png(fig, path: Path, dpi: int = 110) -> None:
    """Save a matplotlib figure atomically as PNG, then close it."""
    import matplotlib.pyplot as plt

    try:
        atomic_write(Path(path), lambda tmp: fig.savefig(tmp, format="png", dpi=dpi), suffix=".png")
    finally:
        plt.close(fig)


class Progress:
    """A minimal progress bar on stderr.

    Silent when ``quiet``, when stderr is not a terminal, or until ``delay``
    seconds have passed (short runs print nothing).
    """

    def __init__(self, total: int, label: str, quiet: bool = False, delay: float = 1.0):
        self.total = max(int(total), 1)
        self.label = label
        self.enabled = not quiet and sys.stderr.isatty()
        self.start = time.perf_counter()
        self.delay = delay
        self.done = 0
        self.shown = False

    def __call__(self, done: int, total: int | None = None) -> None:
        if total is not None:
            self.total = max(int(total), 1)
        self.done = done
        if not self.enabled:
            return
        elapsed = time.perf_counter() - self.start
        if elapsed < self.delay and done < self.total:
            return
        frac = min(done / self.total, 1.0)
        width = 30
        bar = "#" * int(frac * width) + "-" * (width - int(frac * width))
        sys.stderr.write(f"\r{self.label} [{bar}] {done}/{self.total} {elapsed:5.1f}s")
        sys.stderr.flush()
        self.shown = True

    def close(self) -> None:
        if self.shown:
            sys.stderr.write("\n")
            sys.stderr.flush()


@contextlib.contextmanager
def option_errors():
    """A shared check's ``OptionError`` as click's usage error naming the option (exit 2, one line)."""
    from minparam_cli.api.common import OptionError

    try:
        yield
    except OptionError as e:
        raise typer.BadParameter(e.detail, param_hint=e.option) from None


def parse_floats(text: str, n: int | None, what: str) -> tuple[float, ...]:
    """'0,0,-9.81' -> floats, with a BadParameter naming the option on failure."""
    try:
        vals = tuple(float(x) for x in text.replace(" ", "").split(",") if x != "")
    except ValueError:
        raise typer.BadParameter(f"expected comma-separated numbers, got {text!r}", param_hint=what) from None
    if n is not None and len(vals) != n:
        raise typer.BadParameter(f"expected {n} comma-separated numbers, got {len(vals)}", param_hint=what)
    if not all(math.isfinite(v) for v in vals):
        raise typer.BadParameter(f"expected finite numbers, got {text!r}", param_hint=what)
    return vals
