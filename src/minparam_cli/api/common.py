"""What the API functions share: robot arguments, option checks, progress, warnings."""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any, Callable, Iterable, Union

from minparam_cli.errors import InputError, MinparamWarning

ProgressArg = Union[bool, Callable[[int, int], None]]


def progress_callback(progress: ProgressArg, total: int, label: str):
    """None (no bar: the default), the caller's own callable, or the CLI's bar on stderr (True)."""
    if progress is True:
        from minparam_cli.output import Progress

        return Progress(total, label)
    if callable(progress):
        return progress
    return None


def close(bar: Any) -> None:
    if bar is not None and hasattr(bar, "close"):
        bar.close()


def warn(messages: Iterable[str]) -> None:
    for m in messages:
        warnings.warn(m, MinparamWarning, stacklevel=3)


def friction_kinds(friction: str | Iterable[str] | None) -> tuple[str, ...]:
    """("coulomb", "viscous") from a list or from the CLI's "coulomb,viscous"; unknown kinds refused."""
    from minparam_cli.params import FRICTION_KINDS

    if friction is None:
        return ()
    items = friction.split(",") if isinstance(friction, str) else list(friction)
    kinds = tuple(str(k).strip() for k in items if str(k).strip())
    for k in kinds:
        if k not in FRICTION_KINDS:
            raise InputError(f"friction: unknown friction kind {k!r}; expected any of {','.join(FRICTION_KINDS)}")
    return kinds


def choice(value: str, allowed: Iterable[str], what: str) -> str:
    value = getattr(value, "value", value)
    allowed = tuple(allowed)
    if value not in allowed:
        raise InputError(f"{what}: {value!r} is not one of {', '.join(map(repr, allowed))}")
    return str(value)


def gravity3(gravity: Any) -> tuple[float, float, float] | None:
    import math

    if gravity is None:
        return None
    try:
        g = tuple(float(x) for x in gravity)
    except (TypeError, ValueError):
        raise InputError(f"gravity: expected three numbers, got {gravity!r}") from None
    if len(g) != 3 or not all(math.isfinite(x) for x in g):
        raise InputError(f"gravity: expected three finite numbers, got {gravity!r}")
    return (g[0], g[1], g[2])


def robot_path(robot: Any) -> Path:
    """The file of a Robot, or a path given directly."""
    from minparam_cli.api.results import Robot

    if isinstance(robot, Robot):
        return robot.path
    if isinstance(robot, (str, Path)):
        path = Path(robot)
        if not path.exists():  # the CLI's words (cli.batch.expand_paths)
            raise InputError(f"{path}: no such file or folder")
        return path
    raise InputError(f"expected a robot file path or a minparam.Robot, got {type(robot).__name__}")


class OptionError(InputError):
    """A bad option value, named by the CLI's flag: the API raises it as ``"--flag: detail"``; the CLI
    re-raises it as click's usage error naming the option (``cli_option_errors``), as it always printed."""

    def __init__(self, option: str, detail: str):
        self.option = option
        self.detail = detail
        super().__init__(f"{option}: {detail}")


def friction_option(text: str | Iterable[str] | None) -> tuple[str, ...]:
    """The CLI's --friction ("coulomb,viscous"; a list from Python) checked against the known kinds."""
    from minparam_cli.params import FRICTION_KINDS

    if text is None:
        return ()
    items = text.split(",") if isinstance(text, str) else [str(k) for k in text]
    kinds = tuple(k.strip() for k in items if k.strip())
    for k in kinds:
        if k not in FRICTION_KINDS:
            raise OptionError("--friction", f"unknown friction kind {k!r}; expected any of {','.join(FRICTION_KINDS)}")
    return kinds


def float_option(value: Any, n: int | None, option: str) -> tuple[float, ...]:
    """Finite numbers (``n`` of them, or any number for None) from the command line's "X,Y,Z" text or a
    sequence (a numpy array too), with the command line's messages."""
    import math

    if isinstance(value, str):
        try:
            vals = tuple(float(x) for x in value.replace(" ", "").split(",") if x != "")
        except ValueError:
            raise OptionError(option, f"expected comma-separated numbers, got {value!r}") from None
    else:
        try:
            vals = tuple(float(x) for x in (value.tolist() if hasattr(value, "tolist") else value))
        except (TypeError, ValueError):
            expected = "comma-separated numbers" if n is None else f"{n} numbers"
            raise OptionError(option, f"expected {expected}, got {value!r}") from None
    if n is not None and len(vals) != n:
        raise OptionError(option, f"expected {n} comma-separated numbers, got {len(vals)}")
    if not all(math.isfinite(v) for v in vals):
        raise OptionError(option, f"expected finite numbers, got {value!r}")
    return vals


def choice_option(value: Any, allowed: Iterable[str], option: str) -> str:
    """``value`` (a str or a str Enum) when it is one of ``allowed``; else an ``OptionError`` naming the flag."""
    value = getattr(value, "value", value)
    allowed = tuple(allowed)
    if value not in allowed:
        raise OptionError(option, f"{value!r} is not one of {', '.join(map(repr, allowed))}")
    return str(value)


def expand_paths(paths: Iterable[Path], recursive: bool) -> tuple[list[Path], bool]:
    """Files named directly, plus robot files found in folders.  Returns (files, any_folder)."""
    from minparam_cli.describe import ROBOT_SUFFIXES

    files: list[Path] = []
    any_folder = False
    for p in map(Path, paths):
        if p.is_dir():
            any_folder = True
            pattern = "**/*" if recursive else "*"
            found = sorted(f for f in p.glob(pattern) if f.is_file() and f.suffix.lower() in ROBOT_SUFFIXES)
            if not found:
                raise InputError(f"{p}: no robot files (*.yaml, *.yml, *.urdf, *.xml) in this folder")
            files.extend(found)
        elif p.exists():
            files.append(p)
        else:
            raise InputError(f"{p}: no such file or folder")
    return files, any_folder
