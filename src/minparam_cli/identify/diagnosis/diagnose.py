"""Stepwise diagnosis: trace the residual to effects the model lacks.

At every step, with Gautier's per-joint weights from the current fit:

1. an orthonormal basis Q of the current weighted design's range (thin SVD,
   rank-revealing), residual r0;
2. for every candidate term E (an effect of the library on one joint or on all
   joints, and every grid value of its nonlinear parameter), its new part
   E⊥ = E − Q Qᵀ E, the refit g = argmin ‖r0 − E⊥ g‖ and the updated model
   parameters θ' = θ − X⁺ E g (exact least squares for [X E], without
   refactoring);
3. score each candidate on the selection data (never on the fit data, never
   on the test data): ΔBIC = N_s ln(RSS_s1/RSS_s0) + m ln N_s (m = the rank
   of E⊥, so columns already in the model cost nothing and gain nothing, plus
   one for a grid value the search chose), with the fit-data F-test beside it;
4. a candidate qualifies when ΔBIC < −10 (very strong evidence, Kass &
   Raftery 1995), it removes at least ``min_gain`` of the weighted selection
   residual energy, the unweighted selection error falls, and its fitted
   coefficients lie in the effect's physical range on every joint it is added
   to (``effects.in_bounds``: friction dissipates, inertia is positive, a
   gain stays within 0.5..1.5).  A group term whose coefficients leave the
   range on some joints is scored again on the joints where they do not.
   The qualifying candidate of lowest ΔBIC is added; when none qualifies the
   pass stops.  A candidate that would qualify but for its sign, and beats
   the one added, is kept as a ``rejected`` note: the residual it explains is
   real, its physical name is not.
5. the term added is **named** only when ΔBIC_eff (the same statistic on the
   effective sample size of its model's selection residual, ``evidence.py``)
   is below the threshold too; otherwise it is kept as a model error of that
   form (``named`` False in its statistic).  A ripple seen over fewer than
   ``MIN_PERIODS`` periods is searched as position_error, not cogging.

The simplification pass after the forward steps is ``simplify.py``.

Columns that are combinations of the model's (rotor inertia of a joint whose
axis is fixed in the base, for instance) have E⊥ = 0: they regroup with the
base parameters and are never reported as effects.

The sample is compressed once to per-joint triangular factors (``compressed``),
and each step scores all its candidates together (``scoring``): a step costs
O(K²) per candidate with K the number of catalogue columns, not O(samples).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from minparam_cli.identify.diagnosis.compressed import Compressed
from minparam_cli.measured.records import Block
from minparam_cli.identify.passes.design import Design, Term
from minparam_cli.dynamics.effects import EFFECT_IDS, EFFECTS, MIN_PERIODS, in_bounds, periods_seen
from minparam_cli.identify.diagnosis.evidence import long_run_ratio, q_range, ripple_periods, selection_residual
from minparam_cli.identify.diagnosis.scoring import score
from minparam_cli.identify.diagnosis.steps import SIMPLER, Diagnosis, Rejected, Step, present_effects
from minparam_cli.identify.diagnosis.steps import term_coefficients as term_coefficients  # re-exported

BIC_THRESHOLD = -10.0
# a selection error below this (relative) is the data's own rounding: no effect is looked for in it
ROUNDING = 1e-9
DEFAULT_MIN_GAIN = 0.02
MAX_STEPS = 25
PER_JOINT_ONLY = {"cogging", "position_error"}
# default correlation horizon of the effective sample size (s): the shortest σ block (uncertainty.MIN_BLOCK_S)
DEFAULT_HORIZON_S = 1.0


@dataclass(frozen=True)
class DiagnosisOptions:
    effects: tuple[str, ...] = EFFECT_IDS
    min_gain: float = DEFAULT_MIN_GAIN
    bic_threshold: float = BIC_THRESHOLD
    max_steps: int = MAX_STEPS
    weighted: bool = True  # Gautier's per-joint weights (False: OLS, as --ols)
    horizon_s: float = DEFAULT_HORIZON_S  # lags of the effective sample size: the σ block length (evidence.py)


def _shown(eid: str, joint: int, h: float | None, span: np.ndarray | None) -> bool:
    """Whether a ripple term goes by this name on this joint: cogging where the data cover at least
    MIN_PERIODS of its periods, position_error where they cover fewer (every other effect: True)."""
    if span is None or h is None or eid not in ("cogging", "position_error"):
        return True
    return (periods_seen(span[joint], h) >= MIN_PERIODS) == (eid == "cogging")


def candidates(design: Design, allowed: tuple[str, ...], span: np.ndarray | None = None) -> list[Term]:
    """Every term the model could gain; ``span``: each joint's range of q over the data (names ripples)."""
    n = design.chain.dof
    present = present_effects(design)
    out = []
    for eid in allowed:
        e = EFFECTS[eid]
        if e.needs_model and design.theta_model is None:
            continue
        groups: list[tuple[int, ...]] = [(j,) for j in range(n)]
        if eid not in PER_JOINT_ONLY and n > 1:
            groups.insert(0, tuple(range(n)))
        for g in groups:
            free = tuple(j for j in g if (eid, j) not in present)
            if len(free) != len(g):
                continue
            for h in e.grid or (None,):
                if all(_shown(eid, j, h, span) for j in g):
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


def _good_joints(t: Term, c: np.ndarray, new: np.ndarray) -> tuple[int, ...]:
    """The joints of ``t`` on which it adds something and its coefficients are physical."""
    return tuple(j for j, row, fresh in zip(t.joints, c, new, strict=True) if fresh and in_bounds(t.effect, row))


def _physical(cands: list[Term], scores) -> np.ndarray:
    """Candidates that add something on every joint of the term, with physical coefficients there."""
    return np.array([c is not None and len(_good_joints(t, c, nw)) == len(t.joints)
                     for t, c, nw in zip(cands, scores.coefficients, scores.new, strict=True)], dtype=bool)


def _restricted(cands: list[Term], scores, ok: np.ndarray) -> list[Term]:
    """Group terms that add nothing, or have coefficients outside the physical range, on some joints:
    the same terms on the other joints."""
    out, seen = [], set(cands)
    for i, (t, c) in enumerate(zip(cands, scores.coefficients, strict=True)):
        if not ok[i] or c is None or len(t.joints) < 2:
            continue
        good = _good_joints(t, c, scores.new[i])
        if 0 < len(good) < len(t.joints):
            new = Term(t.effect, good, t.hyper)
            if new not in seen:
                seen.add(new)
                out.append(new)
    return out


def _merge(a, b):
    """Scores of two candidate lists, one after the other."""
    from minparam_cli.identify.diagnosis.scoring import Scores

    return Scores(np.concatenate([a.m, b.m]), np.concatenate([a.rss1, b.rss1]), np.concatenate([a.rssh1, b.rssh1]),
                  np.concatenate([a.rssh1_joint, b.rssh1_joint]), a.coefficients + b.coefficients, a.new + b.new)


def diagnose(design: Design, train: Block, hold: Block, opts: DiagnosisOptions, progress=None) -> Diagnosis:
    """Add effects one at a time while the selection data say they are real and physical.

    ``train``: a sample of the fit data; ``hold``: a sample of the selection data."""
    from minparam_cli.identify.diagnosis.simplify import simplify

    simpler = tuple(a for e in opts.effects for a in SIMPLER.get(e, ()) if a not in opts.effects)
    data = Compressed.of(design, train, hold, tuple(opts.effects) + tuple(dict.fromkeys(simpler)))
    out = Diagnosis(design=design)
    N, Nh = data.N * data.n, data.Nh * data.n  # fit and selection equations
    noted: set = set()
    span = q_range(train, hold)

    def n_eff_of(d: Design, sigma: np.ndarray, theta: np.ndarray | None = None) -> float:
        """Effective number of selection equations of design ``d``'s residual (evidence.py)."""
        if theta is None:
            theta, *_ = np.linalg.lstsq(*data.stack(data.selection(d), sigma), rcond=None)
        ratio = long_run_ratio(selection_residual(d, hold, theta, sigma), hold.t, opts.horizon_s)
        return max(Nh / ratio, 2.0)

    for step in range(opts.max_steps + 1):
        sel = data.selection(out.design)
        sigma = data.joint_sigma(sel, opts.weighted)
        Xw, yw = data.stack(sel, sigma)
        Q, back = _basis(Xw, N)
        theta = back @ (Q.T @ yw)
        r0 = yw - Xw @ theta
        rss0 = float(r0 @ r0)
        Xhw, yhw = data.stack(sel, sigma, hold=True)
        rh0 = yhw - Xhw @ theta
        rssh0 = float(rh0 @ rh0)
        rssh0_plain = float(data.joint_rss(sel, theta, hold=True).sum())
        errs = data.selection_errors(sel, theta)
        if step == 0:
            out.steps.append(Step(None, {"rss_fit_weighted": rss0, "rss_selection_weighted": rssh0,
                                         "n_eff": n_eff_of(out.design, sigma, theta), "n_selection": Nh},
                                  errs, out.design, theta))
        if step == opts.max_steps:
            break
        rel = errs.relative_error
        if rel < ROUNDING:
            out.stop_reason = (f"the model explains the selection data to their rounding (relative error {rel:.1g}): "
                               "nothing left to trace")
            break
        cands = candidates(out.design, opts.effects, span)
        scores = score(data, sel, sigma, Q, back, r0, rh0, cands)
        usable = np.isfinite(scores.rss1) & (scores.m > 0)
        extra = _restricted(cands, scores, usable)
        if extra:
            cands = cands + extra
            scores = _merge(scores, score(data, sel, sigma, Q, back, r0, rh0, extra))
        out.candidates_per_step = max(out.candidates_per_step, len(cands))
        if progress:
            progress(len(cands), len(cands))
        ok = np.isfinite(scores.rss1) & (scores.m > 0) & (scores.rssh1 > 0) & (rssh0 > 0)
        if not np.any(ok):
            break
        log_ratio = np.log(np.where(ok, scores.rssh1, 1.0) / rssh0) if rssh0 > 0 else np.zeros(len(cands))
        # a grid value (Stribeck vs, ripple order k) is chosen by the search: it counts as a parameter too
        m_bic = scores.m + np.array([1 if EFFECTS[t.effect].grid else 0 for t in cands])
        dbic_iid = np.where(ok, Nh * log_ratio + m_bic * np.log(Nh), np.inf)  # as if the samples were independent
        gain = 1.0 - scores.rssh1 / rssh0 if rssh0 > 0 else np.zeros(len(cands))
        plain = (scores.rssh1_joint * sigma**2).sum(axis=1)  # unweighted selection RSS
        physical = _physical(cands, scores)
        dbic = dbic_iid  # what adds a term to the model (prediction); ΔBIC_eff below decides its name
        strong = ok & (dbic < opts.bic_threshold) & (gain >= opts.min_gain) & (plain < rssh0_plain)
        wrong_sign = np.array([c is not None and not all(in_bounds(t.effect, row) for row, fresh in zip(c, nw, strict=True) if fresh)
                               for t, c, nw in zip(cands, scores.coefficients, scores.new, strict=True)], dtype=bool)
        qualifies = strong & physical
        best_any = int(np.argmin(np.where(ok & physical, dbic, np.inf))) if np.any(ok & physical) else None
        if not np.any(qualifies):
            _note_rejected(out, cands, scores, strong & wrong_sign, dbic, gain, np.inf, noted)
            if best_any is None:
                out.stop_reason = "no candidate with coefficients in its physical range"
            else:
                t = cands[best_any]
                out.stop_reason = (
                    f"best remaining candidate {t.label()}: ΔBIC {dbic[best_any]:.1f}, removes "
                    f"{100 * gain[best_any]:.2f} % of the selection residual energy (needs ΔBIC < "
                    f"{opts.bic_threshold:g}, {100 * opts.min_gain:g} % and a falling selection error)"
                )
            break
        i = int(np.argmin(np.where(qualifies, dbic, np.inf)))
        _note_rejected(out, cands, scores, strong & wrong_sign, dbic, gain, dbic[i], noted)
        term, m, rss1 = cands[i], int(scores.m[i]), float(scores.rss1[i])
        F = ((rss0 - rss1) / m) / (rss1 / max(N - Xw.shape[1] - m, 1)) if rss1 > 0 else np.inf
        from scipy.special import fdtrc

        p_value = float(fdtrc(m, max(N - Xw.shape[1] - m, 1), F)) if np.isfinite(F) else 0.0
        out.design = out.design.with_term(term)
        sel = data.selection(out.design)
        sig = data.joint_sigma(sel, opts.weighted)
        theta_all, *_ = np.linalg.lstsq(*data.stack(sel, sig), rcond=None)
        n1 = n_eff_of(out.design, sigma)  # the larger model's, as an F-test takes its noise from the larger model
        eff = float(n1 * log_ratio[i] + m_bic[i] * np.log(n1))
        stat = {"delta_bic_eff": eff, "n_eff": float(n1), "correlation_ratio": float(Nh / n1),
                "delta_bic_selection": float(dbic_iid[i]), "selection_gain": float(gain[i]), "F": float(F),
                "p_value": p_value, "rank": m}
        periods = ripple_periods(term, span)
        if periods is not None:
            stat["periods_seen"] = periods
        stat["named"] = bool(eff < opts.bic_threshold) and (periods is None or term.effect != "cogging" or periods >= MIN_PERIODS)
        out.steps.append(Step(term, stat, data.selection_errors(sel, theta_all), out.design, theta_all))
    else:
        out.stop_reason = f"stopped after {opts.max_steps} steps"
    if not out.stop_reason:
        out.stop_reason = "no candidate left"
    simplify(out, data, opts.weighted, n_eff_of)
    return out


def _note_rejected(out: Diagnosis, cands, scores, mask, dbic, gain, beat: float, noted: set) -> None:
    """Keep the strongest wrong-sign candidate of a step when it beats the one added (``beat``)."""
    if not np.any(mask):
        return
    k = int(np.argmin(np.where(mask, dbic, np.inf)))
    t = cands[k]
    if dbic[k] >= beat or (t.effect, t.joints) in noted:
        return
    noted.add((t.effect, t.joints))
    out.rejected.append(Rejected(t, np.asarray(scores.coefficients[k]), float(gain[k]), float(dbic[k])))
