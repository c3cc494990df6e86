"""Score every candidate of a diagnosis step at once, on the compressed sample.

For the current weighted fit (Q an orthonormal basis of the range of Xw,
residual r0, selection-data residual rh0) and a candidate E (catalogue columns of
some joints, each acting on its own joint's rows): E⊥ = E − Q QᵀE, the refit g = argmin ‖r0 − E⊥ g‖ through
E⊥ᵀE⊥ = EᵀE − (QᵀE)ᵀQᵀE (its eigenvalues give m, the rank E adds), the model
correction u = X⁺E g (X⁺ = B Qᵀ), and the selection residual rh0 + Xh u − Eh g.

QᵀC, CᵀC and Cᵀr0 are computed once for every catalogue column C of every
joint; a candidate then only gathers entries, and candidates of the same width
are solved together (batched eigh).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from minparam_cli.identify.diagnosis.compressed import Compressed
from minparam_cli.identify.passes.design import Term


@dataclass(frozen=True)
class Scores:
    m: np.ndarray  # rank each candidate adds (0: nothing new, not a candidate)
    rss1: np.ndarray  # weighted fit-data residual sum of squares after the refit
    rssh1: np.ndarray  # weighted selection-data residual sum of squares
    rssh1_joint: np.ndarray  # (candidates, n): the same, per joint (times σ_j²: unweighted)
    coefficients: list  # per candidate, (joints of the term, columns of the effect): its fitted coefficients
    new: list  # per candidate, (joints of the term,): whether the term adds anything on that joint (see NEW_TOL)


# A candidate's columns on a joint add nothing when the part of them outside the model's range has
# less than this share of their squared norm (rotor inertia of a joint whose axis is fixed in the base).
NEW_TOL = 1e-8


def _layout(data: Compressed, cands: list[Term]) -> dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Candidates by width: (indices, joints (Nc, w), catalogue columns (Nc, w))."""
    groups: dict[int, tuple[list, list, list]] = {}
    for i, term in enumerate(cands):
        cols = data.cat.columns(term)
        J = [j for j in term.joints for _ in cols]
        C = [c for _ in term.joints for c in cols]
        g = groups.setdefault(len(C), ([], [], []))
        g[0].append(i)
        g[1].append(J)
        g[2].append(C)
    return {w: (np.array(i), np.array(J), np.array(C)) for w, (i, J, C) in groups.items()}


def _offsets(factors: list) -> np.ndarray:
    return np.concatenate([[0], np.cumsum([T.shape[0] for T in factors])])


def score(data: Compressed, sel: np.ndarray, sigma: np.ndarray, Q: np.ndarray, back: np.ndarray,
          r0: np.ndarray, rh0: np.ndarray, cands: list[Term]) -> Scores:
    """Q: orthonormal basis of the weighted design's range, back: X⁺ = back·Qᵀ (see diagnose._basis)."""
    n, K = data.n, data.T[0].shape[1]
    at, ath = _offsets(data.T), _offsets(data.Th)
    QtC = np.stack([Q[at[j] : at[j + 1]].T @ (data.T[j] / sigma[j]) for j in range(n)])  # (n, p, K)
    G = np.stack([(T.T @ T) / sigma[j] ** 2 for j, T in enumerate(data.T)])  # (n, K, K)
    B = np.stack([data.T[j].T @ r0[at[j] : at[j + 1]] / sigma[j] for j in range(n)])  # (n, K)
    rss0 = float(r0 @ r0)

    nc = len(cands)
    m = np.zeros(nc, dtype=int)
    rss1 = np.full(nc, np.nan)
    U = np.zeros((nc, back.shape[0]))  # model corrections u
    coef = [None] * nc
    new = [None] * nc
    entries = []  # (candidate, joint, column, coefficient) of every candidate column, for the selection residual
    for w, (idx, J, C) in _layout(data, cands).items():
        QtE = np.moveaxis(QtC[J, :, C], 1, 2)  # (Nc, p, w)
        EtE = G[J[:, :, None], C[:, :, None], C[:, None, :]] * (J[:, :, None] == J[:, None, :])
        b = B[J, C]  # (Nc, w)
        norms2 = np.diagonal(EtE, axis1=1, axis2=2)
        perp = EtE - np.swapaxes(QtE, 1, 2) @ QtE
        share = np.diagonal(perp, axis1=1, axis2=2) / np.where(norms2 > 0, norms2, 1.0)  # (Nc, w)
        evals, evecs = np.linalg.eigh(perp)
        keep = (evals > norms2.max(axis=1)[:, None] * 1e-12) & np.any(norms2 > 0, axis=1)[:, None]
        inv = np.divide(1.0, evals, out=np.zeros_like(evals), where=keep)
        g = (evecs @ (inv * (np.swapaxes(evecs, 1, 2) @ b[..., None])[..., 0])[..., None])[..., 0]
        m[idx] = keep.sum(axis=1)
        rss1[idx] = rss0 - np.sum(g * b, axis=1)
        U[idx] = (QtE @ g[..., None])[..., 0] @ back.T
        entries.append((np.repeat(idx, w), J.ravel(), C.ravel(), g.ravel()))
        for k, i in enumerate(idx):
            coef[i] = g[k].reshape(len(cands[i].joints), -1)
            new[i] = share[k].reshape(len(cands[i].joints), -1).max(axis=1) > NEW_TOL

    cand, Jall, Call, gall = (np.concatenate(x) for x in zip(*entries, strict=True)) if entries else (np.zeros(0, int),) * 4
    rssh1 = np.zeros((nc, n))
    for j in range(n):
        Z = np.zeros((K, nc))
        np.add.at(Z, sel[j], U.T)  # the model's columns on joint j (ZERO lands in the zero column)
        on = Jall == j
        np.add.at(Z, (Call[on], cand[on]), -gall[on])
        rh1 = rh0[ath[j] : ath[j + 1], None] + (data.Th[j] @ Z) / sigma[j]
        rssh1[:, j] = np.sum(rh1**2, axis=0)
    return Scores(m, rss1, rssh1.sum(axis=1), rssh1, coef, new)
