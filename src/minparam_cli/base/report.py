"""What ``derive`` adds to a base set, and the derive JSON (the contract) built from them.

``Derivation`` holds the robot the base set was derived for (``RobotSummary``), the notes, the
weakly identifiable parameters, the snapped angles and the symbolic set; ``BaseSet.to_dict()`` calls
``report_dict`` here, and every renderer (``base.text``: table, Markdown, LaTeX) reads the same
objects.  No module here imports ``base.result`` (the base set is passed in).
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from typing import Any

import numpy as np

SCHEMA = "minparam.derive/1"
UNITS = {"length": "m", "mass": "kg", "first_moment": "kg·m", "inertia": "kg·m²", "torque": "N·m or N"}


def format_coefficient(c: float) -> str:
    return f"{c:.6g}"


def expression(terms: dict[str, float]) -> str:
    """{'ZZ1': 1, 'YY2': 1, 'M3': 0.18645} -> 'ZZ1 + YY2 + 0.18645*M3'."""
    out = ""
    for name, c in terms.items():
        sign = "-" if c < 0 else "+"
        mag = abs(c)
        coef = format_coefficient(mag)
        body = name if coef == "1" else f"{coef}*{name}"
        out = (f"-{body}" if sign == "-" else body) if not out else f"{out} {sign} {body}"
    return out


@dataclass(frozen=True)
class Mimic:
    """A mimic joint's law: joint = multiplier · master + offset."""

    joint: str  # the master joint
    multiplier: float
    offset: float

    def to_dict(self) -> dict[str, Any]:
        return {"joint": self.joint, "multiplier": self.multiplier, "offset": self.offset}


@dataclass(frozen=True)
class Link:
    """One row of the robot's links: its parameter index, joint, link, joint type, parent link
    (0: the fixed base; None: the free root of a floating base) and mimic law."""

    index: int
    joint: str
    link: str
    type: str
    parent: int | None
    mimic: Mimic | None = None

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"index": self.index, "joint": self.joint, "link": self.link, "type": self.type,
                               "parent": self.parent}
        if self.mimic is not None:
            out["mimic"] = self.mimic.to_dict()
        return out


@dataclass(frozen=True)
class RobotSummary:
    """The robot a base set was derived for, as the report names it."""

    robot: str
    source: str
    dof: int
    floating_base: bool
    convention: str
    gravity: tuple[float, ...]
    gravity_source: str
    links: tuple[Link, ...]

    @staticmethod
    def of(chain) -> RobotSummary:
        links = []
        coupling = chain.coupling
        for j, number in enumerate(chain.layout.link_numbers):
            # the parent link's number; 0 is the fixed base (or, on a floating base, the free link)
            parent = chain.layout.link_numbers[chain.parents[j]] if chain.parents[j] >= 0 else (None if chain.floating_base else 0)
            mimic = None
            if coupling is not None and j not in coupling.coordinates:
                i = int(np.flatnonzero(coupling.G[j])[0]) if np.any(coupling.G[j]) else 0
                master = coupling.coordinates[i]
                mimic = Mimic(chain.joint_names[master], float(coupling.G[j, i]), float(coupling.offset[j]))
            links.append(Link(number, chain.joint_names[j], chain.link_names[j], chain.types[j], parent, mimic))
        return RobotSummary(chain.name, chain.source, chain.dof, chain.floating_base, chain.convention,
                            tuple(float(g) for g in chain.gravity), chain.gravity_source, tuple(links))


@dataclass(frozen=True)
class Symbolic:
    """The symbolic set (``base.symbolic.add_symbolic``): the report's symbolic fields in their order
    (symbols, generic_n_base, symbolic_verification, symbolic_generic, symbolic_notes, symbolic_latex,
    ...) and, when the file's set is printed symbolically, each base parameter's forms (``symbolic``,
    ``symbolic_text``, ``symbolic_latex``; None otherwise)."""

    fields: dict[str, Any]
    parameters: tuple[dict[str, Any], ...] | None = None


@dataclass(frozen=True)
class Derivation:
    """What ``derive`` adds to a base set: the robot, notes on its inertial values (``warnings``), the
    angles ``--snap-angles`` changed, the weakly identifiable parameters, the symbolic set and the
    time the whole derivation took."""

    about: RobotSummary
    warnings: tuple[str, ...] = ()
    snap_angles: dict[str, Any] | None = None  # {"tolerance_rad": ..., "changed": [...]}
    weak: tuple[dict[str, Any], ...] = ()  # base.weak.weak_parameters
    symbolic: Symbolic | None = None
    elapsed_s: float = 0.0


def report_dict(base) -> dict[str, Any]:
    """The derive JSON of a base set (``BaseSet.to_dict``); without a ``Derivation`` (a base set from a
    stage call), the base set's own fields only."""
    d = base.derivation
    names = list(base.standard_names)
    params = [{"name": n, "expression": expression(t), "terms": t} for n, t in zip(base.names, base.terms, strict=True)]
    if d is not None and d.symbolic is not None and d.symbolic.parameters is not None:
        params = [dict(b, **s) for b, s in zip(params, d.symbolic.parameters, strict=True)]
    head: dict[str, Any] = {"schema": SCHEMA}
    if d is not None:
        a = d.about
        head.update({"robot": a.robot, "source": a.source, "method": base.method, "dof": a.dof,
                     "floating_base": a.floating_base, "convention": a.convention, "gravity": list(a.gravity),
                     "gravity_source": a.gravity_source})
    else:
        head["method"] = base.method
    report = {
        **head,
        "seed": base.seed,
        "samples": base.samples,
        "exact": bool(base.exact),
        "units": UNITS,
        "standard_parameters": names,
        "base_parameters": params,
        "unidentifiable": [names[i] for i in base.unidentifiable],
        "n_standard": base.n_standard,
        "n_base": base.n_base,
        "rank_margin": jsonable(base.rank_margin),
    }
    if d is not None:
        report["links"] = [link.to_dict() for link in d.about.links]
        report["elapsed_s"] = round(float(d.elapsed_s), 6)
    if base.extra:
        report["diagnostics"] = jsonable(base.extra)
    if d is None:
        return copy.deepcopy(report)
    if d.warnings:
        report["warnings"] = list(d.warnings)
    if d.snap_angles is not None:
        report["snap_angles"] = d.snap_angles
    if d.weak:
        report["weakly_identifiable"] = [dict(w) for w in d.weak]
    if d.symbolic is not None:
        report.update(d.symbolic.fields)
    return copy.deepcopy(report)  # the caller may change it: nothing here changes with it


def jsonable(x):
    if isinstance(x, dict):
        return {str(k): jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(v) for v in x]
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    return x
