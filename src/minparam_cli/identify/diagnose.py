"""Stepwise diagnosis: trace the residual to effects the model lacks.

At every step, with Gautier's per-joint weights from the current fit:

1. an orthonormal basis Q of the current weighted design's range (thin SVD,
   rank-revealing), residual r0;
2. for every candidate term E (an effect of the library on one joint or on all
   joints, and every grid value of its nonlinear parameter), its new part
   E⊥ = E − Q Qᵀ E, the refit g = argmin ‖r0 − E⊥ g‖ and the updated model
   parameters θ' = θ − X⁺ E g (exact least squares for [X E], without
   refactoring);
3. score each candidate on the held-out data: ΔBIC = N_h ln(RSS_h1/RSS_h0)
   + m ln N_h (m = the rank of E⊥, so columns already in the model cost
   nothing and gain nothing), with the training F-test beside it;
4. add the best candidate if ΔBIC < −10 (very strong evidence, Kass & Raftery
   1995) and it removes at least ``min_gain`` of the held-out residual energy;
   otherwise stop.

Columns that are combinations of the model's (rotor inertia of a joint whose
axis is fixed in the base, for instance) have E⊥ = 0: they regroup with the
base parameters and are never reported as effects.

The sample is compressed once to per-joint triangular factors (``compressed``),
and each step scores all its candidates together (``scoring``): a step costs
O(K²) per candidate with K the number of catalogue columns, not O(samples).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from minparam_cli.identify.compressed import Compressed
from minparam_cli.identify.data import Block
from minparam_cli.identify.design import Design, Term
from minparam_cli.identify.effects import EFFECT_IDS, EFFECTS
from minparam_cli.identify.scoring import score

BIC_THRESHOLD = -10.0
DEFAULT_MIN_GAIN = 0.02
MAX_STEPS = 25
PER_JOINT_ONLY = {"cogging"}
# a term that contains a simpler one: tried again after the forward pass (the greedy path can
# pick asymmetric Coulomb, which also absorbs part of another effect, where plain Coulomb is enough)
SIMPLER = {"asymmetric_coulomb": ("coulomb",), "load_coulomb": ("coulomb",)}
DECLARED = {"coulomb": "coulomb", "viscous": "viscous", "offset": "offset", "rotor_inertia": "rotor_inertia"}


@dataclass(frozen=True)
class DiagnosisOptions:
    effects: tuple[str, ...] = EFFECT_IDS
    min_gain: float = DEFAULT_MIN_GAIN
    bic_threshold: float = BIC_THRESHOLD
    max_steps: int = MAX_STEPS


@dataclass
class Step:
    term: Term | None
    statistic: dict
    errors: dict  # held-out, unweighted: rms_per_joint, rms_total, relative_error
    design: Design | None = None
    theta: np.ndarray | None = None


@dataclass
class Diagnosis:
    steps: list[Step] = field(default_factory=list)
    design: Design | None = None
    candidates_per_step: int = 0
    stop_reason: str = ""


def candidates(design: Design, allowed: tuple[str, ...]) -> list[Term]:
    n = design.chain.n
    present = {(t.effect, j) for t in design.terms for j in t.joints}
    for j, extras in enumerate(design.chain.layout.extras):
        for e in extras:
            present.add((DECLARED.get(e, e), j))
    out = []
    for eid in allowed:
        e = EFFECTS[eid]
        if e.needs_model and design.theta_model is None:
            continue
        groups = [(j,) for j in range(n)]
        if eid not in PER_JOINT_ONLY and n > 1:
            groups.insert(0, tuple(range(n)))
        for g in groups:
            free = tuple(j for j in g if (eid, j) not in present)
            if len(free) != len(g):
                continue
            for h in e.grid or (None,):
                out.append(Term(eid, g, h))
    return out


def _basis(Xw: np.ndarray, rows: int) -> tuple[np.ndarray, np.ndarray]:
    """Orthonormal basis Q of the weighted design's range and B with X⁺ = B Qᵀ (thin SVD, rank-revealing).

    A design can be rank deficient (gain on every joint is a rescaling of the base parameters): Q
    then spans only the range, so a candidate's new part E − QQᵀE is exact.  Tolerance as numpy's
    lstsq on the uncompressed ``rows``.
    """
    U, s, Vt = np.linalg.svd(Xw, full_matrices=False)
    r = int(np.sum(s > s.max(initial=0.0) * max(rows, Xw.shape[1]) * np.finfo(float).eps))
    return U[:, :r], Vt[:r].T / s[:r]


def diagnose(design: Design, train: Block, hold: Block, opts: DiagnosisOptions, progress=None) -> Diagnosis:
    """Add effects one at a time while the held-out data say they are real."""
    simpler = tuple(a for e in opts.effects for a in SIMPLER.get(e, ()) if a not in opts.effects)
    data = Compressed.of(design, train, hold, tuple(opts.effects) + tuple(dict.fromkeys(simpler)))
    out = Diagnosis(design=design)
    N, Nh = data.N * data.n, data.Nh * data.n  # training and held-out equations

    for step in range(opts.max_steps + 1):
        sel = data.selection(out.design)
        sigma = data.joint_sigma(sel)
        Xw, yw = data.stack(sel, sigma)
        Q, back = _basis(Xw, N)
        theta = back @ (Q.T @ yw)
        r0 = yw - Xw @ theta
        rss0 = float(r0 @ r0)
        Xhw, yhw = data.stack(sel, sigma, hold=True)
        rh0 = yhw - Xhw @ theta
        rssh0 = float(rh0 @ rh0)
        if step == 0:
            out.steps.append(Step(None, {"rss_train_weighted": rss0, "rss_holdout_weighted": rssh0}, data.holdout_errors(sel, theta), out.design, theta))
        if step == opts.max_steps:
            break
        cands = candidates(out.design, opts.effects)
        out.candidates_per_step = max(out.candidates_per_step, len(cands))
        scores = score(data, sel, sigma, Q, back, r0, rh0, cands)
        if progress:
            progress(len(cands), len(cands))
        ok = np.isfinite(scores.rss1) & (scores.m > 0) & (scores.rssh1 > 0) & (rssh0 > 0)
        if not np.any(ok):
            break
        dbic = np.where(ok, Nh * np.log(np.where(ok, scores.rssh1, 1.0) / rssh0) + scores.m * np.log(Nh), np.inf)
        i = int(np.argmin(dbic))
        term, m, rss1, rssh1 = cands[i], int(scores.m[i]), float(scores.rss1[i]), float(scores.rssh1[i])
        dbic_i = float(dbic[i])
        F = ((rss0 - rss1) / m) / (rss1 / max(N - Xw.shape[1] - m, 1)) if rss1 > 0 else np.inf
        gain = 1 - rssh1 / rssh0
        if not (dbic_i < opts.bic_threshold and gain >= opts.min_gain):
            out.stop_reason = (
                f"best remaining candidate {term.label()}: ΔBIC {dbic_i:.1f}, "
                f"removes {100 * gain:.2f} % of the held-out residual energy (needs ΔBIC < {opts.bic_threshold:g} "
                f"and {100 * opts.min_gain:g} %)"
            )
            break
        from scipy.special import fdtrc

        p_value = float(fdtrc(m, max(N - Xw.shape[1] - m, 1), F)) if np.isfinite(F) else 0.0
        out.design = out.design.with_term(term)
        sel = data.selection(out.design)
        sig = data.joint_sigma(sel)
        theta_all, *_ = np.linalg.lstsq(*data.stack(sel, sig), rcond=None)
        stat = {"delta_bic_holdout": dbic_i, "holdout_gain": float(gain), "F": float(F), "p_value": p_value, "rank": m}
        out.steps.append(Step(term, stat, data.holdout_errors(sel, theta_all), out.design, theta_all))
    else:
        out.stop_reason = f"stopped after {opts.max_steps} steps"
    if not out.stop_reason:
        out.stop_reason = "no candidate left"
    _simplify(out, data)
    return out


def _holdout_bic(data: Compressed, design: Design) -> tuple[float, np.ndarray, dict]:
    """Held-out BIC of a design fitted on the training part (Gautier weights), with its theta and held-out errors."""
    sel = data.selection(design)
    sigma = data.joint_sigma(sel)
    Xw, yw = data.stack(sel, sigma)
    theta, *_ = np.linalg.lstsq(Xw, yw, rcond=None)
    sv = np.linalg.svd(Xw, compute_uv=False)
    # the rank as np.linalg.matrix_rank gives it on the uncompressed rows (its tolerance grows with their number)
    rank = int(np.sum(sv > sv.max(initial=0.0) * max(data.N * data.n, Xw.shape[1]) * np.finfo(float).eps))
    Xhw, yhw = data.stack(sel, sigma, hold=True)
    rssh = float(np.sum((yhw - Xhw @ theta) ** 2))
    Nh = data.Nh * data.n
    return Nh * np.log(rssh) + rank * np.log(Nh), theta, data.holdout_errors(sel, theta)


def _simplify(out: Diagnosis, data: Compressed) -> None:
    """Replace a term by a simpler one it contains when the held-out BIC prefers it."""
    from dataclasses import replace

    changed = True
    while changed:
        changed = False
        current, _, _ = _holdout_bic(data, out.design)
        for i, term in enumerate(out.design.terms):
            for alt in SIMPLER.get(term.effect, ()):
                new = Term(alt, term.joints, None)
                if any(t == new for t in out.design.terms):
                    continue
                terms = out.design.terms[:i] + (new,) + out.design.terms[i + 1 :]
                cand = replace(out.design, terms=terms)
                score_, theta, errs = _holdout_bic(data, cand)
                if score_ < current:
                    out.design = cand
                    stat = {"replaces": term.label(), "delta_bic_holdout": float(score_ - current)}
                    out.steps.append(Step(new, stat, errs, cand, theta))
                    changed = True
                    break
            if changed:
                break
