"""Whether an identification can be trusted: excitation, physical ranges, flags.

* **Excitation** (before any result is reported): the fit data's design,
  each column scaled to unit norm, must have a condition number below
  ``COND_LIMIT``.  Column scaling makes the number independent of units
  (a raw condition number of 1e4 can be a good trajectory in mixed units);
  a base parameter whose column barely moves shows as a huge scaled
  condition number, and its σ would be meaningless.  Past the limit the
  command stops (exit 1) naming the joints that did not move.
* **Physical ranges** (after the final refit on all the fit data): an added
  effect whose coefficients left its range on the whole fit data (the
  diagnosis judged a thinned sample) is kept only on the joints where they
  did not, or removed, and the model refitted.
* **Flags**: a joint whose error rises by more than ``RISE_FLAG`` from the
  rigid-body model to the final one (selection or test data), a declared
  friction coefficient of the wrong sign, a joint or a selection/test block
  that stands still for a large share of the samples, no test data, selection
  data that are the data file itself.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any, Mapping, Protocol

import numpy as np

from minparam_cli.errors import ComputationError
from minparam_cli.identify.passes.design import Design, Term
from minparam_cli.identify.diagnosis.diagnose import term_coefficients
from minparam_cli.dynamics.effects import EFFECTS, in_bounds
from minparam_cli.identify.estimate.fit import Errors, full_theta, solve
from minparam_cli.identify.estimate.records import Step, TestFigures
from minparam_cli.identify.passes.roles import overlaps, span_text

# Column-scaled condition number of the fit data's rigid-body design past which the fit is refused.
# Measured: Panda recording 9.8, TX40 recording 5.7, simulated PUMA 560 10.3 (fit blocks of the default
# split); data in which joints 2-6 of the PUMA move by 1e-8 rad: 1e10 and more.
COND_LIMIT = 1e4
# A joint whose position range over the fit data is below this did not move (rad; m for prismatic joints).
MOTION_MIN = {"revolute": 0.05, "prismatic": 0.005}
RISE_FLAG = 0.10  # per-joint error rise (relative) that is flagged
STILL_FLAG = 0.20  # share of still samples on a joint that is flagged
STILL_PART_FLAG = 0.30  # share of all-joints-still samples in a selection or test block that is flagged


def check_excitation(acc, design: Design, motion, limit: float = COND_LIMIT) -> float:
    """The column-scaled condition number of the fit data's design (unit weights), or ComputationError."""
    A = acc.stacked(np.ones(acc.n))[:, : acc.p]
    norms = np.linalg.norm(A, axis=0)
    if np.all(norms > 0):
        s = np.linalg.svd(A / norms, compute_uv=False)
        cond = float(s[0] / s[-1]) if s[-1] > 0 else float("inf")
    else:
        cond = float("inf")
    if cond <= limit:
        return cond
    chain = design.chain
    rng = motion.range
    types = chain.coordinate_types  # the data's joints (mimic joints follow their master)
    still = [j for j in range(chain.dof) if rng[j] < MOTION_MIN.get(types[j], MOTION_MIN["revolute"])]
    if still:
        unit = lambda j: "m" if types[j] == "prismatic" else "rad"  # noqa: E731
        why = "joint{} {} barely moved ({})".format(
            "s" if len(still) > 1 else "", ", ".join(str(j + 1) for j in still),
            ", ".join(f"{j + 1}: range {rng[j]:.2g} {unit(j)}" for j in still))
    else:
        weak = _weakest(A, norms, design.names[: acc.p])
        why = f"every joint moved, but the data barely separate {weak}"
    shown = "inf" if not np.isfinite(cond) else f"{cond:.3g}"
    raise ComputationError(
        f"poor excitation: the fit data's column-scaled condition number is {shown} (limit {limit:g}); "
        f"{why}: record a trajectory that moves every joint over a wide range, at varied speeds"
    )


def _weakest(A: np.ndarray, norms: np.ndarray, names) -> str:
    """The parameters of the least excited direction."""
    safe = np.where(norms > 0, norms, 1.0)
    _, _, Vt = np.linalg.svd(A / safe, full_matrices=False)
    v = np.abs(Vt[-1])
    top = [names[i] for i in np.argsort(-v)[:4] if v[i] >= 0.3 * v.max()]
    return ", ".join(top)


def positions(old: Design, new: Design) -> list[int]:
    """Columns of ``new`` (whose terms are a subset of ``old``'s, joint by joint) in ``old``'s order."""
    at, c = {}, len(old.kept)
    for t in old.terms:
        m = len(EFFECTS[t.effect].column_names)
        for j in t.joints:
            at[(t.effect, t.hyper, j)] = c
            c += m
    cols = list(range(len(new.kept)))
    for t in new.terms:
        m = len(EFFECTS[t.effect].column_names)
        for j in t.joints:
            cols += list(range(at[(t.effect, t.hyper, j)], at[(t.effect, t.hyper, j)] + m))
    return cols


def keep_physical(design: Design, fit, acc: dict, weighted: bool):
    """Refit without the (term, joint) pairs whose coefficients left their physical range on all the fit data.

    Returns the design, fit and accumulators kept, and one report step per term restricted or removed."""
    from minparam_cli.identify.estimate.fit import errors

    steps = []
    for _ in range(len(design.terms) + 1):
        coefs = term_coefficients(design, full_theta(fit, design.p))
        if all(in_bounds(t.effect, c) for t, c in zip(design.terms, coefs, strict=True)):
            break
        terms, changed = [], []
        for t, c in zip(design.terms, coefs, strict=True):
            good = tuple(j for j, row in zip(t.joints, c, strict=True) if in_bounds(t.effect, row))
            if len(good) == len(t.joints):
                terms.append(t)
                continue
            if good:
                terms.append(Term(t.effect, good, t.hyper))
            bad = [(j, row) for j, row in zip(t.joints, c, strict=True) if not in_bounds(t.effect, row)]
            changed.append((t, good, bad))
        new = replace(design, terms=tuple(terms))
        cols = positions(design, new)
        acc = {k: a.restrict(cols) for k, a in acc.items()}
        fit = solve(acc["fit"], new.names, weighted)
        design = new
        e = errors(acc["selection"], fit.theta, fit.columns)
        for t, good, bad in changed:
            names = ", ".join(f"{EFFECTS[t.effect].column_names[0]}{j + 1} = {row[0]:.3g}" for j, row in bad)
            label = f"{t.effect} kept on joint(s) {', '.join(str(j + 1) for j in good)}" if good else f"{t.effect} removed"
            steps.append(Step(t.effect, tuple(j + 1 for j in good),
                              {"removed": t.label(), "why": f"outside the physical range on all the fit data ({names})"},
                              e, t.hyper, label))
    return design, fit, acc, steps


class Figures(Protocol):
    """What the flags read of an identification (``identify.result.IdentifyResult``, a frozen record:
    hence read-only members)."""

    @property
    def data(self) -> str: ...
    @property
    def validate(self) -> str | None: ...
    @property
    def roles(self) -> Mapping[str, Any]: ...
    @property
    def files(self) -> tuple[Mapping[str, Any], ...]: ...
    @property
    def steps(self) -> tuple[Step, ...]: ...
    @property
    def before(self) -> Errors: ...
    @property
    def after(self) -> Errors: ...
    @property
    def test(self) -> TestFigures: ...


def flags(result: Figures, fit) -> list[str]:
    """Warnings a user must see next to the figures (strings, one line each)."""
    out = []
    if result.validate and overlaps(Path(result.data), Path(result.validate)):
        out.append("the selection data (--validate) are the data file itself: before and after are in-sample "
                   "figures there, and the effects were chosen on data that also fitted them")
    if not result.test.files:
        out.append("no test data (--split test share 0, no --test file): every figure comes from data that fitted "
                   "or chose the model")
    comparisons = [("selection", result.before, result.after)]
    for f in result.test.files:
        comparisons.append((f"test ({span_text(f.entry)})", f.rigid, f.final))
    if result.steps[1:]:
        for name, b, a in comparisons:
            for j, (x, y) in enumerate(zip(b.rms_per_joint, a.rms_per_joint, strict=True)):
                if x > 0 and y > (1 + RISE_FLAG) * x:
                    out.append(f"joint {j + 1}: the {name} rms rises from {x:.4g} to {y:.4g} "
                               f"(+{100 * (y / x - 1):.0f} %) from the rigid-body model to the final one")
    for name, v in zip(fit.names, fit.theta, strict=True):
        kind = name.rstrip("0123456789")
        if kind in ("Fc", "Fv", "Ia") and v < 0:
            what = {"Fc": "Coulomb friction", "Fv": "viscous friction", "Ia": "rotor inertia"}[kind]
            out.append(f"declared {what} {name} = {v:.4g} is negative: not {what} (a model error or a "
                       "standstill artefact is taking its place)")
    for role in ("selection", "test"):
        for entry in result.roles.get(role, []):
            share = entry.get("still_share")
            if share is not None and share > STILL_PART_FLAG:
                out.append(f"the {role} data ({span_text(entry)}) stand still in {100 * share:.0f} % of their samples "
                           "(every joint): their figures measure standstill more than motion")
    for file in result.files:
        still = [(j, s) for j, s in enumerate(file.get("still_share") or []) if s > STILL_FLAG]
        if still:
            js = ", ".join(str(j + 1) for j, _ in still)
            shares = ", ".join(f"{100 * s:.0f}" for _, s in still)
            out.append(f"{file['path']}: joint{'s' if len(still) > 1 else ''} {js} stand{'' if len(still) > 1 else 's'} "
                       f"still in {shares} % of the samples: the torque at standstill (static friction) is not in the "
                       "model (sign(0) = 0); --trim-still SECONDS cuts long still segments")
    return out
