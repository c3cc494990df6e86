"""The typed result of ``minparam identify``: what the stage found, frozen; ``to_dict()`` is the JSON.

``IdentifyResult`` holds the figures of one identification, each part typed where code reads it
(errors, steps, test figures, parameters, σ, the physical fit, the payload, the essential set) and
the data's own records (roles, preprocessing, effects found and rejected) as the stage wrote them.
The renderers (``render.identify_text``), the quality flags (``assess.quality.flags``) and the model
file (``model.file.saved_model``) read it; the JSON contract is ``to_dict()``, versioned by
``SCHEMA`` (its first key).
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from typing import Any, Mapping

from minparam_cli.identify.assess.essential import EssentialReport
from minparam_cli.identify.estimate.errors import Errors
from minparam_cli.identify.estimate.records import Estimate, SigmaSummary, Step, TestFigures, selection_dict
from minparam_cli.identify.physical.report import PayloadReport, PhysicalReport

SCHEMA = "minparam.identify/1"


@dataclass(frozen=True)
class IdentifyResult:
    """One identification: the fields of the identify JSON, in its order (see docs/identify.md)."""

    robot: str
    data: str
    validate: str | None
    test_files: tuple[str, ...]
    split: tuple[float, ...]
    roles: Mapping[str, Any]  # per role (fit, selection, test): where its data came from
    samples_used: int
    samples_fit: int
    samples_selection: int
    samples_test: int
    dropped: Mapping[str, int]
    preprocessing: Mapping[str, Any]  # the data file's reading and filtering
    files: tuple[Mapping[str, Any], ...]  # the same, per file read
    coulomb_model: str
    method: str
    condition_number: float
    condition_number_scaled: float
    sigma_per_joint: tuple[float, ...]
    steps: tuple[Step, ...]
    stop_reason: str
    before: Errors  # the rigid-body model on the selection data
    after: Errors  # the final model on the selection data
    test: TestFigures
    effects: tuple[Mapping[str, Any], ...]
    rejected: tuple[Mapping[str, Any], ...]
    parameters: tuple[Estimate, ...]
    sigma: SigmaSummary | None  # None: the textbook σ, without blocks
    regrouped_on_this_data: tuple[str, ...]
    nominal_notes: tuple[str, ...]
    diagnosis: Mapping[str, Any]
    seed: int
    physical: PhysicalReport | None = None
    essential: EssentialReport | None = None
    flags: tuple[str, ...] = ()
    elapsed_s: float = 0.0
    payload: PayloadReport | None = None
    # --current: the side, the gains the currents were read with, their source, whether the torque unit is arbitrary
    current: Mapping[str, Any] | None = None

    @property
    def sigma_kind(self) -> str:
        return "textbook" if self.sigma is None else self.sigma.kind

    def to_dict(self) -> dict[str, Any]:
        """The identify JSON (a new document each call: changing it changes nothing here)."""
        out: dict[str, Any] = {
            "schema": SCHEMA,
            "robot": self.robot,
            "data": self.data,
            "validate": self.validate,
            "test_files": list(self.test_files),
            "split": list(self.split),
            "roles": copy.deepcopy(dict(self.roles)),
            "samples_used": self.samples_used,
            "samples_fit": self.samples_fit,
            "samples_selection": self.samples_selection,
            "samples_test": self.samples_test,
            "dropped": dict(self.dropped),
            "preprocessing": copy.deepcopy(dict(self.preprocessing)),
            "files": [copy.deepcopy(dict(f)) for f in self.files],
            "coulomb_model": self.coulomb_model,
            "method": self.method,
            "condition_number": self.condition_number,
            "condition_number_scaled": self.condition_number_scaled,
            "sigma_per_joint": list(self.sigma_per_joint),
            "steps": [s.to_dict() for s in self.steps],
            "stop_reason": self.stop_reason,
            "before": selection_dict(self.before),
            "after": selection_dict(self.after),
            "test": self.test.to_dict(),
            "effects": [copy.deepcopy(dict(e)) for e in self.effects],
            "rejected": [copy.deepcopy(dict(r)) for r in self.rejected],
            "parameters": {p.name: p.to_dict() for p in self.parameters},
            "sigma": {"kind": "textbook"} if self.sigma is None else self.sigma.to_dict(),
            "regrouped_on_this_data": list(self.regrouped_on_this_data),
            "nominal_notes": list(self.nominal_notes),
            "diagnosis": copy.deepcopy(dict(self.diagnosis)),
            "seed": self.seed,
        }
        if self.physical is not None:
            out["physical"] = self.physical.to_dict()
        if self.essential is not None:
            out["essential"] = self.essential.to_dict()
        out["flags"] = list(self.flags)
        out["elapsed_s"] = self.elapsed_s
        if self.payload is not None:
            out["payload"] = self.payload.to_dict()
        if self.current is not None:
            out["current"] = copy.deepcopy(dict(self.current))
        return out
