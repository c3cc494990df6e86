"""Stepwise diagnosis: trace the residual to effects the model lacks.

At every step, with Gautier's per-joint weights from the current fit:

1. factor the current weighted design, X = Q R, residual r0;
2. for every candidate term E (an effect of the library on one joint or on all
   joints, and every grid value of its nonlinear parameter), its new part
   E⊥ = E − Q Qᵀ E, the refit g = argmin ‖r0 − E⊥ g‖ and the updated model
   parameters θ' = θ − R⁻¹ Qᵀ E g (exact least squares for [X E], without
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
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from minparam_cli.identify.data import Block
from minparam_cli.identify.design import Design, Term, term_blocks, term_columns
from minparam_cli.identify.effects import EFFECT_IDS, EFFECTS

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


def _flat(X: np.ndarray) -> np.ndarray:
    return X.reshape(-1, X.shape[-1])


def joint_sigma(X: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Gautier's weights: each joint's residual standard deviation after OLS (1 where it is zero)."""
    theta, *_ = np.linalg.lstsq(_flat(X), y.reshape(-1), rcond=None)
    res = y - X @ theta
    sigma = np.sqrt(np.sum(res**2, axis=0) / max(len(y) - X.shape[-1] / y.shape[1], 1))
    return np.where(sigma > 0, sigma, 1.0)


def _holdout_errors(yh: np.ndarray, pred: np.ndarray) -> dict:
    r = yh - pred
    rss = np.sum(r**2, axis=0)
    return {
        "rms_per_joint": [float(x) for x in np.sqrt(rss / len(yh))],
        "rms_total": float(np.sqrt(rss.sum() / r.size)),
        "relative_error": float(np.sqrt(rss.sum() / np.sum(yh**2))),
    }


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


def diagnose(design: Design, train: Block, hold: Block, opts: DiagnosisOptions, progress=None) -> Diagnosis:
    """Add effects one at a time while the held-out data say they are real."""
    n = design.chain.n
    X = design.columns(train)
    Xh = design.columns(hold)
    y, yh = train.tau, hold.tau
    s_train, s_hold = design.signals(train), design.signals(hold)
    out = Diagnosis(design=design)

    for step in range(opts.max_steps + 1):
        sigma = joint_sigma(X, y)
        Xw = _flat(X / sigma[None, :, None])
        yw = (y / sigma).reshape(-1)
        Q, R = np.linalg.qr(Xw)
        theta = np.linalg.lstsq(R, Q.T @ yw, rcond=None)[0]
        r0 = yw - Xw @ theta
        rss0 = float(r0 @ r0)
        Xhw = _flat(Xh / sigma[None, :, None])
        yhw = (yh / sigma).reshape(-1)
        rh0 = yhw - Xhw @ theta
        rssh0 = float(rh0 @ rh0)
        if step == 0:
            out.steps.append(Step(None, {"rss_train_weighted": rss0, "rss_holdout_weighted": rssh0}, _holdout_errors(yh, Xh @ theta), out.design, theta))
        if step == opts.max_steps:
            break
        Nh, N = len(yhw), len(yw)
        best = None
        cands = candidates(out.design, opts.effects)
        out.candidates_per_step = max(out.candidates_per_step, len(cands))
        Q3 = Q.reshape(len(y), n, -1)  # rows of joint j: Q3[:, j, :]
        r03 = r0.reshape(len(y), n)
        Xh3 = Xhw.reshape(len(yh), n, -1)
        rh03 = rh0.reshape(len(yh), n)
        Rinv = np.linalg.pinv(R)
        for i, term in enumerate(cands):
            # E is block-sparse (joint j's columns live in joint j's rows): work block by block through
            # small Gram matrices, E⊥ᵀE⊥ = EᵀE − (QᵀE)ᵀQᵀE and E⊥ᵀr0 = Eᵀr0 (Qᵀr0 = 0)
            blocks = [blk / sigma[j] for blk, j in zip(term_blocks(term, s_train), term.joints)]
            QtE = np.hstack([Q3[:, j, :].T @ blk for blk, j in zip(blocks, term.joints)])
            EtE = np.zeros((QtE.shape[1],) * 2)
            b = np.empty(QtE.shape[1])
            c = 0
            for blk, j in zip(blocks, term.joints):
                w = blk.shape[1]
                EtE[c : c + w, c : c + w] = blk.T @ blk
                b[c : c + w] = blk.T @ r03[:, j]
                c += w
            norms2 = np.diag(EtE)
            if not np.any(norms2 > 0):
                continue
            evals, evecs = np.linalg.eigh(EtE - QtE.T @ QtE)
            keep = evals > norms2.max() * 1e-12  # singular values of E⊥ above 1e-6 of the largest column norm
            m = int(keep.sum())
            if m == 0:
                continue  # already in the span of the model: it regroups
            g = evecs[:, keep] @ ((evecs[:, keep].T @ b) / evals[keep])
            rss1 = rss0 - float(g @ b)
            rh1 = rh03 + Xh3 @ (Rinv @ (QtE @ g))
            c = 0
            for blk, j in zip(term_blocks(term, s_hold), term.joints):
                w = blk.shape[1]
                rh1[:, j] -= (blk / sigma[j]) @ g[c : c + w]
                c += w
            rssh1 = float(np.sum(rh1**2))
            if rssh1 <= 0 or rssh0 <= 0:
                continue
            dbic = Nh * np.log(rssh1 / rssh0) + m * np.log(Nh)
            if best is None or dbic < best[0]:
                F = ((rss0 - rss1) / m) / (rss1 / max(N - Xw.shape[1] - m, 1)) if rss1 > 0 else np.inf
                best = (dbic, term, m, F, rss1, rssh1)
            if progress:
                progress(i + 1, len(cands))
        if best is None:
            break
        dbic, term, m, F, rss1, rssh1 = best
        gain = 1 - rssh1 / rssh0
        if not (dbic < opts.bic_threshold and gain >= opts.min_gain):
            out.stop_reason = (
                f"best remaining candidate {term.label()}: ΔBIC {dbic:.1f}, "
                f"removes {100 * gain:.2f} % of the held-out residual energy (needs ΔBIC < {opts.bic_threshold:g} "
                f"and {100 * opts.min_gain:g} %)"
            )
            break
        from scipy.stats import f as f_dist

        p_value = float(f_dist.sf(F, m, max(N - Xw.shape[1] - m, 1))) if np.isfinite(F) else 0.0
        out.design = out.design.with_term(term)
        X = np.concatenate([X, term_columns(term, s_train, n)], axis=2)
        Xh = np.concatenate([Xh, term_columns(term, s_hold, n)], axis=2)
        sig = joint_sigma(X, y)
        theta_all, *_ = np.linalg.lstsq(_flat(X / sig[None, :, None]), (y / sig).reshape(-1), rcond=None)
        stat = {"delta_bic_holdout": float(dbic), "holdout_gain": float(gain), "F": float(F), "p_value": p_value, "rank": m}
        out.steps.append(Step(term, stat, _holdout_errors(yh, Xh @ theta_all), out.design, theta_all))
    else:
        out.stop_reason = f"stopped after {opts.max_steps} steps"
    if not out.stop_reason:
        out.stop_reason = "no candidate left"
    _simplify(out, design, train, hold)
    return out


def _holdout_bic(design: Design, train: Block, hold: Block) -> tuple[float, np.ndarray, np.ndarray]:
    """Held-out BIC of a design fitted on ``train`` (Gautier weights), with its theta and held-out prediction."""
    X, Xh = design.columns(train), design.columns(hold)
    sigma = joint_sigma(X, train.tau)
    Xw = _flat(X / sigma[None, :, None])
    theta, *_ = np.linalg.lstsq(Xw, (train.tau / sigma).reshape(-1), rcond=None)
    rank = np.linalg.matrix_rank(Xw)
    pred = Xh @ theta
    rssh = float(np.sum(((hold.tau - pred) / sigma) ** 2))
    Nh = hold.tau.size
    return Nh * np.log(rssh) + rank * np.log(Nh), theta, pred


def _simplify(out: Diagnosis, start: Design, train: Block, hold: Block) -> None:
    """Replace a term by a simpler one it contains when the held-out BIC prefers it."""
    from dataclasses import replace

    changed = True
    while changed:
        changed = False
        current, _, _ = _holdout_bic(out.design, train, hold)
        for i, term in enumerate(out.design.terms):
            for alt in SIMPLER.get(term.effect, ()):
                new = Term(alt, term.joints, None)
                if any(t == new for t in out.design.terms):
                    continue
                terms = out.design.terms[:i] + (new,) + out.design.terms[i + 1 :]
                cand = replace(out.design, terms=terms)
                score, theta, pred = _holdout_bic(cand, train, hold)
                if score < current:
                    out.design = cand
                    stat = {"replaces": term.label(), "delta_bic_holdout": float(score - current)}
                    out.steps.append(Step(new, stat, _holdout_errors(hold.tau, pred), cand, theta))
                    changed = True
                    break
            if changed:
                break
