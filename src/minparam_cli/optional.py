"""Optional dependencies ([ros], [physical], ...): imported when first needed, with one line naming the
extra to install.  Every command that needs one goes through ``import_optional``."""

from __future__ import annotations

import importlib

from minparam_cli.errors import InputError


def import_optional(module: str, extra: str, purpose: str):
    """``module`` imported, or an InputError (exit code 2) that says which extra provides it."""
    try:
        return importlib.import_module(module)
    except ImportError:
        top = module.split(".")[0]
        raise InputError(f"{purpose} needs the {top} library: pip install 'minparam[{extra}]'") from None
