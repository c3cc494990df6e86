"""The evidence an effect needs under correlated residuals, and how much of its signature the data show.

Effective sample size.  The selection residuals are filtered, time-correlated samples: N_s of them
carry the information of fewer independent ones.  With e_j(t) joint j's weighted selection residual of
the current model (in time order) and ρ_j(l) its autocorrelation at lag l, the long-run variance ratio
with Bartlett's kernel over M lags (M = the samples in one σ block of ``--block-length`` seconds, the
same correlation horizon as the hac σ, docs/methods/uncertainty.md) is

    R_j = 1 + 2 Σ_{l=1..M} (1 − l/(M+1)) ρ_j(l),      R = Σ_j γ_j R_j / Σ_j γ_j   (γ_j = Σ_t e_j(t)²)

floored at 1 (no evidence is ever made stronger than for independent samples), and

    N_eff = N_s / R,     ΔBIC_eff = N_eff ln(RSS_s1 / RSS_s0) + m ln N_eff.

Periods seen.  A ripple sin kq, cos kq over a motion spanning Δq rad shows kΔq/2π of its periods;
below ``MIN_PERIODS`` it is not told apart from a smooth error in q (gravity, a cable).

docs/methods/selection.md gives the equations and their sources.
"""

from __future__ import annotations

import numpy as np

from minparam_cli.dynamics.effects import periods_seen
from minparam_cli.identify.passes.design import Design, Term
from minparam_cli.measured.records import Block

# a time step above this many median steps starts a new piece: lags never span a gap or a file boundary
GAP_STEPS = 3.0
# effects whose columns are a periodic function of q with the grid value as the number of periods a turn
RIPPLES = ("cogging", "position_error")


def pieces(t: np.ndarray) -> list[slice]:
    """Contiguous runs of ``t``: split where time goes back or jumps by more than GAP_STEPS median steps."""
    if len(t) < 2:
        return [slice(0, len(t))]
    dt = np.diff(t)
    step = float(np.median(dt[dt > 0])) if np.any(dt > 0) else 1.0
    cut = np.flatnonzero((dt <= 0) | (dt > GAP_STEPS * step)) + 1
    edges = [0, *cut.tolist(), len(t)]
    return [slice(a, b) for a, b in zip(edges[:-1], edges[1:], strict=True) if b > a]


def lag_count(t: np.ndarray, horizon_s: float) -> int:
    """M: the samples within ``horizon_s`` seconds at the block's median step."""
    dt = np.diff(t)
    dt = dt[dt > 0]
    if dt.size == 0:
        return 0
    return max(int(round(horizon_s / float(np.median(dt)))), 1)


def long_run_ratio(e: np.ndarray, t: np.ndarray, horizon_s: float) -> float:
    """R of the module docstring for residuals ``e`` (N, n) sampled at ``t``, floored at 1."""
    e = np.asarray(e, dtype=float)
    if e.ndim == 1:
        e = e[:, None]
    M = lag_count(t, horizon_s)
    parts = pieces(t)
    gamma0 = float(np.sum(e**2))
    if gamma0 <= 0.0 or M == 0:
        return 1.0
    cross = 0.0  # Σ_l w_l Σ_t e(t)·e(t+l), pooled over joints (the γ-weighted mean of R_j) and pieces
    for p in parts:
        x = e[p]
        for lag in range(1, min(M, len(x) - 1) + 1):
            cross += (1.0 - lag / (M + 1.0)) * float(np.sum(x[:-lag] * x[lag:]))
    return max(1.0 + 2.0 * cross / gamma0, 1.0)


def selection_residual(design: Design, hold: Block, theta: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """(N, n): the weighted residual (τ − Xθ)/σ_j of the selection sample, in time order."""
    X = design.columns(hold)  # (N, n, p)
    return (hold.tau - X @ theta) / sigma


def q_range(*blocks: Block) -> np.ndarray:
    """Range of each joint's position over the diagnosis samples."""
    q = np.concatenate([b.q for b in blocks if len(b)])
    return q.max(axis=0) - q.min(axis=0) if len(q) else np.zeros(0)


def ripple_periods(term: Term, span: np.ndarray) -> float | None:
    """Fewest periods of a ripple term seen over the joints it is on; None for other effects."""
    if term.effect not in RIPPLES or term.hyper is None:
        return None
    return min(periods_seen(span[j], term.hyper) for j in term.joints)


def term_evidence(terms, steps) -> dict:
    """Final term -> the evidence of the diagnosis step that added it (a term restricted to fewer
    joints after the final refit keeps the evidence of the step that added it on more)."""
    added = [(s.term, s.statistic) for s in steps if s.term is not None and "drops" not in s.statistic]
    out = {}
    for t in terms:
        for term, stat in reversed(added):
            if term.effect == t.effect and term.hyper == t.hyper and set(t.joints) <= set(term.joints):
                keys = ("named", "delta_bic_eff", "n_eff", "correlation_ratio", "delta_bic_selection",
                        "selection_gain", "periods_seen", "replaces")
                out[t] = {k: stat[k] for k in keys if k in stat}
                break
    return out

