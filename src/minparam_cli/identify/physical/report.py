"""Typed results of the physical room: the convex fit's report and the payload's identification.

``to_dict()`` writes the ``"physical"`` and ``"payload"`` entries of the identify JSON, keys in the
report's order.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass
from typing import Any, Mapping

from minparam_cli.identify.estimate.errors import Errors


@dataclass(frozen=True)
class PhysicalReport:
    """The physically consistent fit (``--physical``): solver, costs, its errors on the selection data
    and on every test part (by part), its parameters and its bodies (one mapping per link)."""

    solver: str
    status: str
    prior: str
    prior_weight: float | None
    margin_kg: float
    data_cost: float
    prior_cost: float
    elapsed_s: float
    selection: Errors
    test: Mapping[str, Errors]
    base_parameters: Mapping[str, float]
    effect_coefficients: Mapping[str, float]
    phi: Mapping[str, float]
    links: tuple[Mapping[str, Any], ...]
    not_informed: tuple[Any, ...]
    partly_informed: tuple[Any, ...]
    # links whose free directions only the tie-break holds (provenance.py: an export refuses them)
    not_fixed: tuple[Any, ...] = ()
    on_boundary: tuple[Any, ...] = ()  # links at the margin of physical consistency (flagged)
    mass_bounds: tuple[tuple[float, float], ...] = ()  # --mass-bounds per link (() none)
    total_mass: float | None = None
    geometry: tuple[str, ...] = ()  # where the links' ellipsoids came from (() none used)

    def to_dict(self) -> dict:
        return {
            "solver": self.solver, "status": self.status, "prior": self.prior, "prior_weight": self.prior_weight,
            "margin_kg": self.margin_kg, "data_cost": self.data_cost, "prior_cost": self.prior_cost,
            "elapsed_s": self.elapsed_s,
            "selection": self.selection.to_dict(),
            "test": {k: e.to_dict() for k, e in self.test.items()},
            "base_parameters": dict(self.base_parameters),
            "effect_coefficients": dict(self.effect_coefficients),
            "phi": dict(self.phi),
            "links": [copy.deepcopy(dict(b)) for b in self.links],
            "not_informed": list(self.not_informed),
            "partly_informed": list(self.partly_informed),
            "not_fixed": list(self.not_fixed),
            "on_boundary": list(self.on_boundary),
            "mass_bounds": [[lo, hi if math.isfinite(hi) else None] for lo, hi in self.mass_bounds],
            "total_mass": self.total_mass,
            "geometry": list(self.geometry),
        }


@dataclass(frozen=True)
class Entry:
    """An identified value and its σ (absolute and in % of the value)."""

    value: float
    std: float
    std_percent: float

    @staticmethod
    def of(value: Any, s: Any) -> Entry:
        return Entry(float(value), float(s), float(100 * s / abs(value)) if value != 0 else float("inf"))

    def to_dict(self) -> dict:
        return {"value": self.value, "std": self.std, "std_percent": self.std_percent}


@dataclass(frozen=True)
class GainsTLS:
    """The drive gains by total least squares, reported beside the fit (Gautier & Briot 2014)."""

    method: str
    drive_gains: Mapping[str, Entry]

    def to_dict(self) -> dict:
        return {"method": self.method, "drive_gains": {k: e.to_dict() for k, e in self.drive_gains.items()}}


@dataclass(frozen=True)
class PayloadReport:
    """``identify --payload-data``: the payload's parameters about the last link's origin (``known``:
    those given), its centre of mass, and with currents of unknown gains the drive gains and the
    model's parameters in the unit the known mass fixes (``drive_gains``, ``base_parameters``,
    ``total_least_squares``; None otherwise)."""

    method: str
    known: Mapping[str, float]
    frame: str
    parameters: Mapping[str, Entry]
    not_identifiable: tuple[str, ...]
    samples: tuple[int, int]
    relative_error: float
    sigma_per_joint: tuple[float, ...]
    com: tuple[float, ...] | None = None
    drive_gains: Mapping[str, Entry] | None = None
    base_parameters: Mapping[str, Entry] | None = None
    total_least_squares: GainsTLS | None = None
    files: tuple[str, ...] = ()

    def to_dict(self) -> dict:
        out: dict = {"method": self.method, "known": dict(self.known), "frame": self.frame,
                     "parameters": {k: e.to_dict() for k, e in self.parameters.items()},
                     "not_identifiable": list(self.not_identifiable), "samples": list(self.samples),
                     "relative_error": self.relative_error, "sigma_per_joint": list(self.sigma_per_joint)}
        if self.com is not None:
            out["com"] = list(self.com)
        if self.drive_gains is not None:
            out["drive_gains"] = {k: e.to_dict() for k, e in self.drive_gains.items()}
            out["base_parameters"] = {k: e.to_dict() for k, e in (self.base_parameters or {}).items()}
            out["total_least_squares"] = None if self.total_least_squares is None else self.total_least_squares.to_dict()
        out["files"] = list(self.files)
        return out
