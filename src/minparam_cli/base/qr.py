"""Base parameters from random samples and QR (Gautier 1990; Zhu et al., paper 003).

1. Stack the regressor W = Y(q, qd, qdd) of ``samples`` seeded random states.
2. Put W in physical units with lengths in units of the robot's size L
   (``result.physical_scales``): a column's size then measures its effect on
   the torques, so the cut below means the same on every robot and in every
   unit system, and a parameter whose effect is tiny (a mass at 1.6 mm from an
   axis) is not magnified up to the size of the others.
3. Keep rule (Gautier & Khalil 1990): scan the columns in the standard order
   (link 1..n, XX..M within a link, then the extras) and keep a column unless
   it is a combination of the columns already kept: r_i, the norm of column
   i's part orthogonal to the kept columns before it, relative to the largest
   column, exceeds RANK_RTOL (1e-8); a column whose whole norm is below that
   has no effect.  The scan runs on the R factor of one Householder QR (same
   inner products, square) and twice (``result.scan_in_order``): columns above
   WEAK_RTOL (1e-4) first, then the rest above RANK_RTOL, so that a column
   independent only by a hair (romeo.urdf's float32 cos(pi/2) in its hand
   axes) does not take the place of a later full-size one and leave every
   later decision at the cut's size (docs/methods/qr.md, "The rank cut").
   (Paper 003 pivots the QR; pivoting picks the kept set by size, not by the
   documented order, so the order is fixed here and the pivot's job, the
   rank, is confirmed by the singular values.)
4. The count is confirmed independently by the singular values of the same
   matrix, cut at RANK_RTOL times the largest column (the scan's scale).  Where
   they disagree, ``RankUndecided.explained`` names the parameters at the cut
   and the near-special geometry to write exactly (``--snap-angles``).
5. A second QR of the kept columns, W_kept = Q1 R1, gives β = R1⁻¹ Q1ᵀ W_dropped
   (paper 003: β = R1⁻¹ R2), so that W φ = W_kept (φ_kept + β φ_dropped).
   Column scaling does not change β's relations, so it is computed on
   unit-norm columns for accuracy and scaled back.
"""

from __future__ import annotations

import random
import time

import numpy as np

from minparam_cli.base.result import (
    RANK_RTOL,
    SMALL_RTOL,
    BaseSet,
    beta_from_unit_columns,
    physical_scales,
    regrouping_matrix,
    scan_in_order,
    scan_margin,
    small_columns_that_regroup,
)
from minparam_cli.chain import Chain
from minparam_cli.dynamics.regressor import random_states, regressor
from minparam_cli.errors import ComputationError, InputError

DEFAULT_SAMPLES = 100
DEFAULT_SEED = 0
# the scan and the singular values can disagree only for columns within this factor of the cut
BAND = 100.0


class RankUndecided(ComputationError):
    """The ordered scan and the singular values disagree: columns sit at the cut (RANK_RTOL)."""

    def __init__(self, source: str, kept: int, rank_svd: int, near: list[tuple[int, float]]):
        self.source, self.kept, self.rank_svd, self.near = source, kept, rank_svd, near
        super().__init__(f"{source}: the ordered scan keeps {kept} columns but the singular values give rank "
                         f"{rank_svd}: the rank decision is too close to call")

    def explained(self, chain: Chain) -> ComputationError:
        """The same error naming the parameters at the cut and the near-special geometry to write exactly."""
        from minparam_cli.base.near_special import near_special_relations

        names = chain.layout.names
        at_cut = ", ".join(f"{names[i]} ({r:.2g})" for i, r in sorted(self.near, key=lambda x: -x[1])[:6])
        relations = sorted(near_special_relations(chain), key=lambda c: c["delta"])
        text = f"{self.args[0]} (parameters at the cut {RANK_RTOL:g}: {at_cut or 'none found'})"
        close = [c for c in relations if c["delta"] < RANK_RTOL * BAND * 10]
        if close:
            worst = max(c["delta"] for c in close)
            tol = 10.0 ** np.ceil(np.log10(worst * 10))
            text += (f"; {close[0]['text']}: write it exactly (a DH/MDH angle: --snap-angles {tol:g}; "
                     "gravity: --gravity)")
        else:
            text += "; no near-special geometry found: check the description's angles and offsets"
        return ComputationError(text)
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
    rows, P = samples * chain.dof, chain.layout.size
    if rows < P:
        raise InputError(
            f"{samples} samples give {rows} equations for {P} parameters; use at least {-(-P // chain.dof)} samples"
        )
    W = stacked_regressor(chain, samples, sample_rng(seed))
    try:
        kept, K, unident, margin = base_from_regressor(W, chain.source, *chain_scales(chain))
    except RankUndecided as e:
        raise e.explained(chain) from None
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


def chain_scales(chain: Chain) -> tuple[np.ndarray, np.ndarray]:
    """Column factors and per-row factors (stacked rows: sample-major) of ``chain``'s regressor
    in physical units, lengths in units of the robot's size (``result.physical_scales``)."""
    return physical_scales(chain.layout, chain.types, chain.length_scale, chain.coordinate_types)


def base_from_regressor(W: np.ndarray, source: str = "", col_scale: np.ndarray | None = None, joint_row_scale: np.ndarray | None = None):
    """Kept columns, regrouping matrix K, no-effect columns and rank margin of a stacked regressor.

    ``col_scale`` and ``joint_row_scale`` (one factor per joint, rows stacked sample by sample)
    put W in physical units (``chain_scales``); without them W is taken as it is.
    """
    rows, P = W.shape
    if joint_row_scale is not None and np.any(joint_row_scale != 1.0):
        W = W * np.tile(joint_row_scale, rows // len(joint_row_scale))[:, None]
    norms = np.sqrt(np.einsum("ij,ij->j", W, W))  # no (rows, P) temporary
    size = norms * (col_scale if col_scale is not None else 1.0)  # column norms in physical units
    largest = size.max() if P else 0.0
    effect = size > RANK_RTOL * largest if largest > 0 else np.zeros(P, dtype=bool)
    # columns below the cut but above rounding: never kept, they regroup or have no effect (below)
    small = (size > SMALL_RTOL * largest) & ~effect if largest > 0 else np.zeros(P, dtype=bool)
    cols = np.flatnonzero(effect | small)
    Wn = W[:, cols]
    Wn *= 1.0 / norms[cols]
    # one Householder QR: Wn = Q R, Q orthogonal, so R's columns have Wn's inner products and
    # carry every residual, singular value and least-squares solution of Wn in a square matrix;
    # scaling a column scales its column of R
    R: np.ndarray = np.linalg.qr(Wn, mode="r")  # type: ignore[assignment]  # numpy stubs: qr() gives QRResult for every mode; mode="r" returns R
    rel = size[cols] / largest if cols.size else size[cols]
    kept_c, r_c = scan_in_order(R, rel)  # the keep rule, on R's columns (result.scan_in_order)
    r = np.zeros(P)
    r[cols] = r_c
    kept = [int(cols[i]) for i in kept_c]

    # independent confirmation of the count: singular values of the same matrix (the columns above
    # the cut), cut against the same scale as the scan (the largest column, not the largest singular
    # value, which can be up to √P larger)
    big = effect[cols]
    sv = np.linalg.svd(R[:, big] * rel[big], compute_uv=False) if big.any() else np.zeros(0)
    rank_svd = int(np.sum(sv > RANK_RTOL * float(rel.max()))) if sv.size else 0
    if rank_svd != len(kept):
        near = [i for i in range(P) if effect[i] and RANK_RTOL / BAND < r[i] < RANK_RTOL * BAND]
        raise RankUndecided(source, len(kept), rank_svd, [(i, float(r[i])) for i in near])
    position = {int(c): k for k, c in enumerate(cols)}
    small_c = [position[int(c)] for c in np.flatnonzero(small)]
    acts = effect.copy()  # the columns with an effect: above the cut, or small ones that regroup
    noise = {int(cols[k]): rho for k, rho in small_columns_that_regroup(R, [position[c] for c in kept], small_c).items()}
    acts[list(noise)] = True  # real effects the kept columns carry (result.SMALL_RTOL)
    unident = [i for i in range(P) if not acts[i]]
    kept_set = set(kept)
    dropped = [i for i in range(P) if i not in kept_set]
    # paper 003: a second QR of the kept columns, R[:, kept] = Q1 R1, beta = R1^-1 Q1^T R[:, dropped]
    Rk = R[:, [position[c] for c in kept]]
    Rd = np.zeros((R.shape[0], len(dropped)))
    for k, c in enumerate(dropped):
        if acts[c]:
            Rd[:, k] = R[:, position[c]]
    Q1, R1 = np.linalg.qr(Rk)
    beta_n = np.linalg.solve(R1, Q1.T @ Rd)
    beta = beta_from_unit_columns(beta_n, norms, acts, kept, dropped, noise)
    K = regrouping_matrix(kept, beta, dropped, P)

    criterion = "distance from the kept columns before it / largest column, columns in physical units (lengths in units of the robot's size), scan order, full-size columns first"
    margin = scan_margin(r, kept, dropped, effect, criterion, RANK_RTOL, rows)
    margin["svd_rank"] = rank_svd
    margin["svd_gap"] = [
        float(sv[rank_svd - 1] / sv[0]) if rank_svd else None,
        float(sv[rank_svd] / sv[0]) if rank_svd < len(sv) else None,
    ]
    return kept, K, unident, margin
