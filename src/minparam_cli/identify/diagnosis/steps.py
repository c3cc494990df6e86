"""The records of a diagnosis (its steps, the rejected candidates) and what the model already holds.

Shared by the forward pass (``diagnose``) and the simplification pass (``simplify``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from minparam_cli.identify.estimate.errors import Errors
from minparam_cli.identify.passes.design import Design, Term

# a term that contains a simpler one, tried again after the forward pass (simplify.py): the greedy path can
# pick asymmetric Coulomb, which also absorbs part of another effect, where plain Coulomb is enough
SIMPLER = {"asymmetric_coulomb": ("coulomb",), "load_coulomb": ("coulomb",), "spring": ("offset",)}
DECLARED = {"coulomb": "coulomb", "viscous": "viscous", "offset": "offset", "rotor_inertia": "rotor_inertia"}


@dataclass
class Step:
    term: Term | None
    statistic: dict
    errors: Errors  # selection data, unweighted
    design: Design | None = None
    theta: np.ndarray | None = None


@dataclass(frozen=True)
class Rejected:
    """A candidate that explained the residual but with coefficients outside its physical range."""

    term: Term
    coefficients: np.ndarray  # (joints, columns)
    gain: float  # share of the weighted selection residual energy it would remove
    delta_bic: float


@dataclass
class Diagnosis:
    steps: list[Step] = field(default_factory=list)
    design: Design = field(kw_only=True)  # the model so far
    candidates_per_step: int = 0
    stop_reason: str = ""
    rejected: list[Rejected] = field(default_factory=list)


def present_effects(design: Design) -> set[tuple[str, int]]:
    """(effect, joint) already in the model: declared extras and added terms (asymmetric Coulomb
    contains plain Coulomb: its two columns sum to sign q̇)."""
    present = {(t.effect, j) for t in design.terms for j in t.joints}
    coordinate = {joint: k for k, joint in enumerate(design.chain.coordinates)}  # terms number the data's joints
    for j, extras in enumerate(design.chain.layout.extras):
        for e in extras:
            if j in coordinate:
                present.add((DECLARED.get(e, e), coordinate[j]))
    present |= {("coulomb", j) for e, j in list(present) if e == "asymmetric_coulomb"}
    present |= {("offset", j) for e, j in list(present) if e == "spring"}  # K·(q − q₀) has a constant column
    tr = design.chain.transmission
    if tr is not None:  # a declared motor-side column of motor k covers the effect on every joint motor k moves
        for k, extras in enumerate(tr.motor_extras):
            present |= {(e, coordinate[j]) for e in extras for j, v in enumerate(tr.matrix[k]) if v != 0 and j in coordinate}
    return present


def term_coefficients(design: Design, theta: np.ndarray) -> list[np.ndarray]:
    """Each added term's coefficients in ``theta`` (the design's column order), as (joints, columns)."""
    out, c = [], len(design.kept)
    for t in design.terms:
        w = t.width()
        out.append(np.asarray(theta[c : c + w]).reshape(len(t.joints), -1))
        c += w
    return out
