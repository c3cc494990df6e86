"""Base parameters from random samples and QR (Gautier 1990; Zhu et al., paper 003).

1. Stack the regressor W = Y(q, qd, qdd) of ``samples`` seeded random states.
2. Normalise the columns (dependence does not change under column scaling).
3. Keep rule (Gautier & Khalil 1990): scan the columns in the standard order
   (link 1..n, XX..M within a link, then the extras) and keep a column unless
   it is a combination of the columns already kept.  This is Householder QR
   in the scan order, without pivoting: |R_ii| is the norm of column i's part
   orthogonal to the columns before it.  (Paper 003 pivots the QR; pivoting
   picks the kept set by size, not by the documented order, so the order is
   fixed here and the pivot's job, the rank, is done by the singular values.)
4. The count is confirmed independently by the singular values; both cut at
   numpy's ``matrix_rank`` tolerance, max · max(M, N) · eps.
5. A second QR of the kept columns, W_kept = Q1 R1, gives β = R1⁻¹ Q1ᵀ W_dropped
   (paper 003: β = R1⁻¹ R2), so that W φ = W_kept (φ_kept + β φ_dropped).
"""

from __future__ import annotations

import random
import time

import numpy as np

from minparam_cli.base.result import BaseSet, beta_from_unit_columns, regrouping_matrix, scan_margin
from minparam_cli.chain import Chain
from minparam_cli.dynamics.regressor import random_states, regressor
from minparam_cli.errors import ComputationError, InputError

DEFAULT_SAMPLES = 100
DEFAULT_SEED = 0
def sample_rng(seed: int) -> random.Random:
    """The seeded generator of the random states (stdlib: see dynamics.regressor.random_states)."""
    return random.Random(seed)


def stacked_regressor(chain: Chain, samples: int, rng) -> np.ndarray:
    q, qd, qdd = random_states(chain, samples, rng)
    Y = regressor(chain, q, qd, qdd)
    return Y.reshape(-1, Y.shape[-1])


def derive_qr(chain: Chain, samples: int = DEFAULT_SAMPLES, seed: int = DEFAULT_SEED) -> BaseSet:
    """Base parameter set of ``chain`` by the random-sample QR route."""
    if samples < 1:
        raise InputError(f"--samples must be positive, got {samples}")
    t0 = time.perf_counter()
    rows, P = samples * chain.n, chain.layout.size
    if rows < P:
        raise InputError(
            f"{samples} samples give {rows} equations for {P} parameters; use at least {-(-P // chain.n)} samples"
        )
    W = stacked_regressor(chain, samples, sample_rng(seed))
    kept, K, unident, margin = base_from_regressor(W, chain.source)
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


def base_from_regressor(W: np.ndarray, source: str = ""):
    """Kept columns, regrouping matrix K, no-effect columns and rank margin of a stacked regressor."""
    rows, P = W.shape
    norms = np.sqrt(np.einsum("ij,ij->j", W, W))  # no (rows, P) temporary
    eps = np.finfo(float).eps
    zero_tol = norms.max() * max(rows, P) * eps
    effect = norms > zero_tol
    tol = max(rows, P) * eps  # columns have unit norm, so max |R_ii| <= 1
    cols = np.flatnonzero(effect)
    Wn = W[:, cols]
    Wn *= 1.0 / norms[cols]
    # one Householder QR in scan order: Wn = Q R, Q orthogonal, so R carries
    # every column norm, singular value and least-squares solution of Wn
    R = np.linalg.qr(Wn, mode="r")
    r = np.zeros(P)
    r[cols] = np.abs(np.diagonal(R))
    kept = [int(i) for i in cols if r[i] > tol]
    unident = [i for i in range(P) if not effect[i]]

    # independent confirmation of the count: numerical rank by singular values (numpy's matrix_rank cut)
    sv = np.linalg.svd(R, compute_uv=False)
    rank_svd = int(np.sum(sv > sv[0] * max(rows, P) * eps))
    if rank_svd != len(kept):
        raise ComputationError(
            f"{source}: the ordered QR keeps {len(kept)} columns but the singular values give rank {rank_svd}; "
            "the rank decision is too close to call (try more --samples or another --seed)"
        )
    kept_set = set(kept)
    dropped = [i for i in range(P) if i not in kept_set]
    # paper 003: a second QR of the kept columns, R[:, kept] = Q1 R1, beta = R1^-1 Q1^T R[:, dropped]
    position = {c: k for k, c in enumerate(cols)}
    Rk = R[:, [position[c] for c in kept]]
    Rd = np.zeros((R.shape[0], len(dropped)))
    for k, c in enumerate(dropped):
        if c in position:
            Rd[:, k] = R[:, position[c]]
    Q1, R1 = np.linalg.qr(Rk)
    beta_n = np.linalg.solve(R1, Q1.T @ Rd)
    beta = beta_from_unit_columns(beta_n, norms, effect, kept, dropped)
    K = regrouping_matrix(kept, beta, dropped, P)

    margin = scan_margin(r, kept, dropped, effect, "|R_ii| of unit-norm columns, QR in scan order; cut at max(M,N)*eps", tol, rows)
    margin["svd_rank"] = rank_svd
    margin["svd_gap"] = [float(sv[rank_svd - 1] / sv[0]), float(sv[rank_svd] / sv[0]) if rank_svd < len(sv) else None]
    return kept, K, unident, margin
