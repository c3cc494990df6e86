"""Base parameters from random samples and QR (Gautier 1990; Zhu et al., paper 003).

1. Stack the regressor W = Y(q, qd, qdd) of ``samples`` seeded random states.
2. Normalise the columns (dependence does not change under column scaling).
3. Keep rule (Gautier & Khalil 1990): scan the columns in the standard order
   (link 1..n, XX..M within a link, then the extras) and keep a column unless
   it is a combination of the columns already kept.  This is QR in the scan
   order: |R_ii| of column i is the norm of its part orthogonal to the columns
   before it (computed by Gram–Schmidt with re-orthogonalisation).
4. The rank is confirmed independently by pivoted (Businger–Golub) QR; both
   use numpy's ``matrix_rank`` cut, max|R_ii| · max(M, N) · eps.
5. β solves W_kept β = W_dropped (paper 003: β = R1⁻¹ R2), so that
   W φ = W_kept (φ_kept + β φ_dropped).
"""

from __future__ import annotations

import time

import numpy as np

from minparam_cli.base.result import COEFFICIENT_CUTOFF, BaseSet, regrouping_matrix
from minparam_cli.chain import Chain
from minparam_cli.dynamics.regressor import random_states, regressor
from minparam_cli.errors import ComputationError, InputError

DEFAULT_SAMPLES = 100
DEFAULT_SEED = 0
# β is accurate to ~1e-13 relative; 12 significant digits drop only rounding noise (1 - 2e-16 -> 1)
BETA_DIGITS = 12


def _round_significant(x: np.ndarray, digits: int) -> np.ndarray:
    out = np.zeros_like(x)
    nz = x != 0
    mag = np.floor(np.log10(np.abs(x[nz])))
    scale = 10.0 ** (digits - 1 - mag)
    out[nz] = np.round(x[nz] * scale) / scale
    return out


def stacked_regressor(chain: Chain, samples: int, rng: np.random.Generator) -> np.ndarray:
    q, qd, qdd = random_states(chain, samples, rng)
    Y = regressor(chain, q, qd, qdd)
    return Y.reshape(-1, Y.shape[-1])


def ordered_scan(Wn: np.ndarray, tol: float):
    """Keep-rule scan on unit-norm columns.  Returns (kept, residual norm of every column)."""
    rows, P = Wn.shape
    Q = np.zeros((rows, P))
    r = np.zeros(P)
    kept = []
    for i in range(P):
        v = Wn[:, i].copy()
        if kept:
            Qk = Q[:, : len(kept)]
            v -= Qk @ (Qk.T @ v)
            v -= Qk @ (Qk.T @ v)  # second pass: classical Gram–Schmidt needs it (Giraud et al. 2005)
        r[i] = np.linalg.norm(v)
        if r[i] > tol:
            Q[:, len(kept)] = v / r[i]
            kept.append(i)
    return kept, r


def derive_qr(chain: Chain, samples: int = DEFAULT_SAMPLES, seed: int = DEFAULT_SEED) -> BaseSet:
    """Base parameter set of ``chain`` by the random-sample QR route."""
    if samples < 1:
        raise InputError(f"--samples must be positive, got {samples}")
    t0 = time.perf_counter()
    rng = np.random.default_rng(seed)
    W = stacked_regressor(chain, samples, rng)
    rows, P = W.shape
    if rows < P:
        raise InputError(
            f"{samples} samples give {rows} equations for {P} parameters; use at least {-(-P // chain.n)} samples"
        )
    norms = np.linalg.norm(W, axis=0)
    eps = np.finfo(float).eps
    zero_tol = norms.max() * max(rows, P) * eps
    effect = norms > zero_tol
    Wn = np.zeros_like(W)
    Wn[:, effect] = W[:, effect] / norms[effect]
    tol = max(rows, P) * eps  # columns have unit norm, so max |R_ii| <= 1
    kept, r = ordered_scan(Wn, tol)
    unident = [i for i in range(P) if not effect[i]]

    from scipy.linalg import qr

    Rp = qr(Wn[:, effect], mode="r", pivoting=True)[0]
    diag = np.abs(np.diag(Rp))
    rank_pivoted = int(np.sum(diag > diag[0] * max(rows, P) * eps))
    if rank_pivoted != len(kept):
        raise ComputationError(
            f"{chain.source}: ordered scan keeps {len(kept)} columns but pivoted QR finds rank {rank_pivoted}; "
            "the rank decision is too close to call (try more --samples or another --seed)"
        )
    dropped = [i for i in range(P) if i not in set(kept)]
    beta_n, *_ = np.linalg.lstsq(Wn[:, kept], Wn[:, dropped], rcond=None)
    beta_n[np.abs(beta_n) < COEFFICIENT_CUTOFF] = 0.0
    scale_d = np.where(effect[dropped], norms[dropped], 0.0)
    beta = _round_significant(beta_n / norms[kept][:, None] * scale_d[None, :], BETA_DIGITS)
    K = regrouping_matrix(kept, beta, dropped, P)

    kept_r = r[kept]
    dropped_r = r[[i for i in dropped if effect[i]]]
    margin = {
        "criterion": "|R_ii| of unit-norm columns in scan order; cut at max(M,N)*eps",
        "tolerance": tol,
        "last_kept": float(kept_r.min()) if len(kept_r) else None,
        "first_dropped": float(dropped_r.max()) if len(dropped_r) else None,
        "pivoted_qr_rank": rank_pivoted,
        "pivoted_qr_gap": [float(diag[rank_pivoted - 1] / diag[0]), float(diag[rank_pivoted] / diag[0])]
        if rank_pivoted < len(diag)
        else [float(diag[-1] / diag[0]), None],
        "coefficient_cutoff": COEFFICIENT_CUTOFF,
        "coefficient_digits": BETA_DIGITS,
        "rows": rows,
    }
    return BaseSet(
        standard_names=chain.layout.names,
        kept=tuple(kept),
        K=K,
        unidentifiable=tuple(unident),
        method="qr",
        rank_margin=margin,
        exact=False,
        seed=seed,
        samples=samples,
        elapsed_s=time.perf_counter() - t0,
    )
