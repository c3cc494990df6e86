"""The simplification pass after the forward diagnosis: simpler terms and overlapping terms.

* A term that contains a simpler one (asymmetric or load-dependent Coulomb contain plain Coulomb, a
  spring K·(q − q₀) contains a constant) is replaced by it when the selection BIC prefers it.
* A term on a joint where another term contains it (an offset where a spring K·(q − q₀) has its own
  constant) is dropped there: it adds nothing.
* Terms that overlap on a joint (a spring, a gravity error A·sin q + B·cos q and a smooth position
  error sin kq, cos kq all describe a smooth function of q over a limited range) are tried without
  each other: the second one is dropped when the selection BIC prefers the model without it.

Both models are scored under the same per-joint weights (those of the current model) and with the
same effective sample size (that of the current model's selection residual, ``evidence``), the
result's added coefficients must be physical, and its unweighted selection error may rise by at most
``SIMPLER_TOLERANCE``.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from minparam_cli.dynamics.effects import in_bounds
from minparam_cli.identify.diagnosis.compressed import Compressed
from minparam_cli.identify.diagnosis.steps import SIMPLER, Diagnosis, Step, present_effects, term_coefficients
from minparam_cli.identify.estimate.errors import Errors
from minparam_cli.identify.passes.design import Design, Term

# smooth functions of q that can stand in for each other over the range the data cover
SMOOTH_IN_Q = frozenset({"spring", "gravity_error", "position_error"})
# a simpler term may raise the unweighted selection error by at most this share to replace a larger one
SIMPLER_TOLERANCE = 0.01


def selection_score(data: Compressed, design: Design, sigma: np.ndarray, n_eff: float
                    ) -> tuple[float, float, np.ndarray, Errors, bool]:
    """Selection-data BIC (effective sample size ``n_eff``) of a design fitted on the fit data under the
    weights ``sigma`` (the same for every design compared), its unweighted selection RSS, theta, errors
    and whether its added terms' coefficients lie in their physical ranges."""
    sel = data.selection(design)
    Xw, yw = data.stack(sel, sigma)
    theta, *_ = np.linalg.lstsq(Xw, yw, rcond=None)
    sv = np.linalg.svd(Xw, compute_uv=False)
    # the rank as np.linalg.matrix_rank gives it on the uncompressed rows (its tolerance grows with their number)
    rank = int(np.sum(sv > sv.max(initial=0.0) * max(data.N * data.n, Xw.shape[1]) * np.finfo(float).eps))
    Xhw, yhw = data.stack(sel, sigma, hold=True)
    rssh = float(np.sum((yhw - Xhw @ theta) ** 2))
    plain = float(data.joint_rss(sel, theta, hold=True).sum())
    physical = all(in_bounds(t.effect, c) for t, c in zip(design.terms, term_coefficients(design, theta), strict=True))
    return n_eff * np.log(rssh) + rank * np.log(n_eff), plain, theta, data.selection_errors(sel, theta), physical


def _alternatives(design: Design, i: int) -> list[tuple[Term | None, str]]:
    """What term i may become: a simpler effect on the same joints, or nothing (an overlapping term on
    one of its joints came first)."""
    term = design.terms[i]
    others = replace(design, terms=design.terms[:i] + design.terms[i + 1 :])
    present = present_effects(others)  # the model without this term
    out: list[tuple[Term | None, str]] = [
        (Term(alt, term.joints, None), "replaces")
        for alt in SIMPLER.get(term.effect, ())
        if not any((alt, j) in present for j in term.joints)  # that would only delete the term
    ]
    covered = tuple(j for j in term.joints if (term.effect, j) in present)  # inside another term (an offset in a spring)
    if covered:
        rest = tuple(j for j in term.joints if j not in covered)
        out.append((Term(term.effect, rest, term.hyper) if rest else None, "covered"))
    if term.effect in SMOOTH_IN_Q:
        earlier = {(t.effect, j) for t in design.terms[:i] for j in t.joints}
        if any((e, j) in earlier for e in SMOOTH_IN_Q for j in term.joints):
            out.append((None, "drops"))
    return out


def simplify(out: Diagnosis, data: Compressed, weighted: bool, n_eff_of) -> None:
    """Apply the module's replacements while the selection BIC prefers them; ``n_eff_of(design,
    sigma)``: the effective sample size of a design's selection residual."""
    changed = True
    while changed:
        changed = False
        sigma = data.joint_sigma(data.selection(out.design), weighted)
        n_eff = n_eff_of(out.design, sigma)
        current, plain0, _, _, _ = selection_score(data, out.design, sigma, n_eff)
        for i, term in enumerate(out.design.terms):
            for new, how in _alternatives(out.design, i):
                rest = out.design.terms[:i] + ((new,) if new is not None else ()) + out.design.terms[i + 1 :]
                cand = replace(out.design, terms=rest)
                score_, plain, theta, errs, physical = selection_score(data, cand, sigma, n_eff)
                # a term inside another adds no rank: its removal scores the same (up to rounding); and a
                # simpler term that spans what the larger one did (asymmetric Coulomb beside a constant, which
                # sign q̇ and the constant span as well) scores the same too: a tie goes to the simpler model,
                # not to the last bit of rounding (a drop must still score better). The score's rounding is
                # about n_eff·ε·(the residual's condition), whatever the score's own size, which can be near
                # zero (unweighted, in N·m²): hence the tolerance's floor of 1e-9·n_eff
                tie = how in ("covered", "replaces")
                better = score_ <= current + 1e-9 * max(abs(current), n_eff) if tie else score_ < current
                if better and physical and plain <= plain0 * (1 + SIMPLER_TOLERANCE) ** 2:
                    out.design = cand
                    if how == "covered":
                        how = "drops" if new is None else "replaces"
                    stat = {how: term.label(), "delta_bic_eff": float(score_ - current), "n_eff": float(n_eff),
                            "named": _named(out, term)}  # a replacement is named as the term it replaces was
                    out.steps.append(Step(new if new is not None else term, stat, errs, cand, theta))
                    changed = True
                    break
            if changed:
                break


def _named(out: Diagnosis, term: Term) -> bool:
    """Whether the step that added ``term`` named it (True for a term no step added)."""
    for step in reversed(out.steps):
        if step.term == term:
            return bool(step.statistic.get("named", True))
    return True
