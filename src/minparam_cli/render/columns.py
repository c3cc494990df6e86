"""Aligned text columns (``output.columns``, where the derive table below the renderers uses it too)."""

from __future__ import annotations

from minparam_cli.output import columns

__all__ = ["columns"]
