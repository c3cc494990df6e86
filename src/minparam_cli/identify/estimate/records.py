"""Typed records of an identification's figures: one diagnosis step, the test figures, one parameter.

They sit in the lowest room of ``identify/`` so that every room of the stage can build its part
(``assess.quality`` its removal steps, the stage the rest); ``identify.result.IdentifyResult`` holds
them, and each ``to_dict()`` writes its part of the identify JSON, keys in the report's order.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from typing import Any, Mapping

from minparam_cli.identify.estimate.errors import Errors


def selection_dict(e: Errors) -> dict:
    """``before``/``after`` in the report: the errors on the selection data, named as such."""
    return {"data": "selection", **e.to_dict()}


@dataclass(frozen=True)
class Step:
    """One step of the diagnosis: the rigid-body model (``label`` None), an added effect, or an effect
    restricted or removed after the final refit; ``errors`` on the selection data."""

    effect: str | None
    joints: tuple[int, ...]  # numbered from 1
    statistic: Mapping[str, Any] | None
    errors: Errors
    hyper: Any = None
    label: str | None = None

    def to_dict(self) -> dict:
        stat = copy.deepcopy(self.statistic)
        if self.label is None:  # the rigid-body model as declared
            return {"effect": self.effect, "joints": list(self.joints), "statistic": stat, **self.errors.to_dict()}
        e = self.errors
        return {"effect": self.effect, "joints": list(self.joints), "hyper": self.hyper, "label": self.label,
                "statistic": stat, "rms_per_joint": [float(x) for x in e.rms_per_joint],
                "rms_total": float(e.rms_total), "relative_error": float(e.relative_error)}


@dataclass(frozen=True)
class TestFile:
    """The rigid-body and the final model's errors on one test part; ``entry``: where the part comes
    from (``roles.describe``: part, source, time_s, samples, still_share)."""

    entry: Mapping[str, Any]
    rigid: Errors
    final: Errors

    @property
    def part(self) -> str:
        return str(self.entry["part"])

    def to_dict(self) -> dict:
        return {**copy.deepcopy(dict(self.entry)), "rigid": self.rigid.to_dict(), "final": self.final.to_dict()}


@dataclass(frozen=True)
class TestFigures:
    """Errors on the test data, per test part and pooled over all of them (None without test data)."""

    files: tuple[TestFile, ...] = ()
    rigid: Errors | None = None
    final: Errors | None = None

    def to_dict(self) -> dict:
        return {"files": [f.to_dict() for f in self.files],
                "rigid": None if self.rigid is None else self.rigid.to_dict(),
                "final": None if self.final is None else self.final.to_dict()}


@dataclass(frozen=True)
class Estimate:
    """One fitted parameter: its value and relative σ (%) of the kind the report shows, and the
    textbook one (None where infinite)."""

    name: str
    value: float
    std_percent: float | None
    std_percent_textbook: float | None

    def to_dict(self) -> dict:
        return {"value": self.value, "std_percent": self.std_percent, "std_percent_textbook": self.std_percent_textbook}


@dataclass(frozen=True)
class SigmaSummary:
    """Which σ the report shows (``identify.assess.uncertainty``): its kind, the time blocks, the
    bootstrap's replicates and seed, and the median ratio to the textbook σ."""

    kind: str
    block_length_s: float
    blocks: int
    replicates: int | None
    seed: int | None
    ratio_to_textbook_median: float | None
    block_doubling_ratio: float | None

    def to_dict(self) -> dict:
        return {"kind": self.kind, "block_length_s": self.block_length_s, "blocks": self.blocks,
                "replicates": self.replicates, "seed": self.seed,
                "ratio_to_textbook_median": self.ratio_to_textbook_median,
                "block_doubling_ratio": self.block_doubling_ratio}
