"""One error hierarchy for the whole package.

The CLI maps :class:`InputError` subclasses to exit code 2 (bad input) and
:class:`ComputationError` to exit code 1 (a computation that failed).  Every
message names the file, the element and what was expected, in one line.
"""

from __future__ import annotations


class MinparamError(Exception):
    """Root of every error minparam raises on purpose."""

    exit_code = 1


class InputError(MinparamError):
    """The user gave something we cannot use: exit code 2."""

    exit_code = 2


class DescriptionError(InputError):
    """A robot or platform description file is malformed or unsupported."""

    def __init__(self, message: str, source: str | None = None, element: str | None = None):
        self.source = source
        self.element = element
        parts = [p for p in (source, element) if p]
        prefix = ": ".join(parts)
        super().__init__(f"{prefix}: {message}" if prefix else message)


class NotARobotError(DescriptionError):
    """A valid file that describes something else (e.g. a parallel platform); batch runs skip it."""

    skippable = True


class DataError(InputError):
    """A measured-data file is malformed."""


class UnsupportedError(DescriptionError):
    """A valid description that uses a feature minparam does not support yet."""


class ComputationError(MinparamError):
    """A computation could not be completed (rank decision too close to call, out of memory...)."""

    exit_code = 1


class MinparamWarning(UserWarning):
    """A note the CLI prints as 'minparam: warning: ...' on stderr; the Python API issues it through
    ``warnings.warn`` instead."""
