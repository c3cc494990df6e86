"""What ``minparam --version`` prints: the version and the regressor backend in use (the compiled
kernel and its lane width, or numpy). Imports no numpy: the version answers fast."""

from __future__ import annotations

from minparam_cli import __version__


def version_line() -> str:
    """``minparam 0.1.0 (regressor: compiled kernel, ...)``."""
    from minparam_cli.dynamics.backend import describe

    return f"minparam {__version__} (regressor: {describe()})"
