"""Standard deviations of identified parameters that hold for correlated residuals.

The textbook covariance of a (weighted) least-squares fit, H⁻¹ with
H = Σ_j X_jᵀX_j / σ_j², assumes independent residuals.  Measured torques are
low-pass filtered and carry unmodelled periodic effects, so neighbouring
residuals are strongly correlated and that covariance is too small (see
docs/methods/uncertainty.md).  Two estimates that allow for the correlation
are computed here, both from one set of sufficient statistics gathered in the
same streaming pass as the fit:

* per time block b of length L (seconds, from the first fit sample) and per
  joint j, the Gram matrix G_bj = A_bjᵀA_bj of the rows A_bj = [X_j | y_j];
* **hac** (Newey & West 1987, on block sums): with the block scores
  s_b = Σ_j (g_bj − G_bj θ) / σ_j² (g: the X–y part of G), bias-reduced as in
  Bell & McCaffrey (2002),
  Cov = H⁻¹ (Σ_b s_b s_bᵀ + ½ Σ_b (s_b s_{b+1}ᵀ + s_{b+1} s_bᵀ)) H⁻¹,
  shrunk toward a scalar multiple of H⁻¹ when the blocks are few
  (Ledoit & Wolf 2004); a Bartlett kernel over block sums; deterministic;
* **bootstrap** (block bootstrap, Carlstein 1986 / Künsch 1989 with
  non-overlapping blocks): R replicates draw B blocks with replacement
  (seeded ``numpy.random.Generator``), each replicate's weighted fit is solved
  from the summed block statistics (no second pass over the data), and the
  covariance is that of the replicates' θ;
* **textbook**: H⁻¹ (Gautier's WLS weights make the weighted residual
  variance one).

Memory: at most ``MAX_BLOCKS`` blocks are kept; when a recording is longer,
neighbouring blocks are merged in pairs and L doubles (reported).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from minparam_cli.errors import DataError, InputError
from minparam_cli.identify.estimate.records import SigmaSummary

SIGMA_KINDS = ("hac", "bootstrap", "textbook")
DEFAULT_SIGMA = "hac"
DEFAULT_REPLICATES = 200
MAX_BLOCKS = 256  # blocks held in memory; beyond, pairs merge and the block length doubles
MIN_BLOCK_S = 1.0  # the block length rule: max(MIN_BLOCK_S, CUTOFF_PERIODS / cut-off)
CUTOFF_PERIODS = 5.0
FEW_BLOCKS = 20  # fewer blocks than this: the σ are themselves uncertain by ~1/sqrt(2B), flagged
CR2_FLOOR = 0.01  # a direction one block holds more than 99 % of: its score is scaled by at most 10
DOUBLING_FLAG = 1.3  # median σ(2L)/σ(L) above this: the blocks look shorter than the residual correlation


@dataclass(frozen=True)
class UncertaintyOptions:
    kind: str = DEFAULT_SIGMA
    block_s: float | None = None  # None: block_length(cutoff)
    replicates: int = DEFAULT_REPLICATES
    seed: int = 0


MAX_REPLICATES = 10_000  # --replicates: a bootstrap σ's own relative error is about 1/sqrt(2·B), 0.7 % here


def block_length(cutoff_hz: float) -> float:
    """The documented rule: at least 1 s and at least five periods of the low-pass cut-off."""
    return max(MIN_BLOCK_S, CUTOFF_PERIODS / cutoff_hz)


def check_options(opts: UncertaintyOptions) -> None:
    """Refuse a setting that cannot give a σ (one line, exit 2)."""
    if opts.kind not in SIGMA_KINDS:
        raise InputError(f"--sigma {opts.kind!r}: expected one of {', '.join(SIGMA_KINDS)}")
    if opts.block_s is not None and not (math.isfinite(opts.block_s) and opts.block_s > 0):
        raise InputError(f"--block-length {opts.block_s}: expected a positive number of seconds")
    if opts.replicates < 2:
        raise InputError(f"--replicates {opts.replicates}: a bootstrap needs at least 2 replicates")
    if opts.replicates > MAX_REPLICATES:  # each is a refit: 1e9 of them never ends
        raise InputError(f"--replicates {opts.replicates}: at most {MAX_REPLICATES} (each replicate is a refit)")


def _packed_positions(w: int, cols: np.ndarray) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray]]:
    """Where the upper triangle of the Gram of columns ``cols`` (sorted) lies in the packed upper
    triangle of a w x w Gram, and that triangle's indices (cached: a joint's columns rarely change)."""
    cols = np.asarray(cols)
    return _positions(w, cols.tobytes(), cols.dtype.str)


@functools.lru_cache(maxsize=128)  # bounded and thread-safe (the streaming threads call it); ~45 kB an entry at most
def _positions(w: int, cols_bytes: bytes, dtype: str) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray]]:
    cols = np.frombuffer(cols_bytes, dtype=dtype)
    a, b = np.triu_indices(len(cols))
    r, c = cols[a], cols[b]  # r <= c: the columns are sorted
    at = r * w - r * (r - 1) // 2 + (c - r)
    for shared in (at, a, b):  # every caller gets these arrays: read-only
        shared.setflags(write=False)
    return at, (a, b)


class BlockGrams:
    """Per time block and per joint, the Gram matrix of the rows [X_j | S_j | y_j] (streamed)."""

    def __init__(self, length_s: float, max_blocks: int = MAX_BLOCKS):
        self.length = float(length_s)
        self.max_blocks = max_blocks
        self.t0: float | None = None
        self.t_last: float | None = None
        # block index -> (n, w(w+1)/2): each joint's Gram by its upper triangle, row by row (half the
        # memory of the full matrices: 26 MB for 256 blocks of the Panda's 60 columns, not 52)
        self.packed: dict[int, np.ndarray] = {}
        self.rows: dict[int, int] = {}
        self.width = 0  # w, the width of the rows

    def add(self, t: np.ndarray, rows: np.ndarray) -> None:
        """t: (N,) times, rows: (N, n, w) as given to the accumulators."""
        self.add_columns(t, np.ascontiguousarray(rows.transpose(1, 2, 0)))

    def add_columns(self, t: np.ndarray, cols: np.ndarray) -> None:
        """t: (N,) times, cols: (n, w, N) the same rows joint-major (``Accumulator.add_columns``)."""
        segments = self.segments(t)
        n, w = cols.shape[:2]
        parts = []
        for j in range(n):  # each joint's rows cols[j, :, s:e] a matrix BLAS takes as it is (A Aᵀ: one syrk)
            parts.append((np.arange(w), [cols[j, :, s:e] @ cols[j, :, s:e].T for _, s, e in segments]))
        self.add_parts(segments, parts, w)

    def segments(self, t: np.ndarray) -> list[tuple[int, int, int]]:
        """(block index, start, end) of the runs of equal block index in the times t (one run per
        block when the times increase); sets the time origin at the first sample ever given."""
        if not len(t):
            return []
        if self.t0 is None:
            self.t0 = float(t[0])
        self.t_last = float(t[-1])
        k = np.floor((t - self.t0) / self.length).astype(np.int64)
        starts = np.flatnonzero(np.concatenate([[True], k[1:] != k[:-1]]))
        return [(int(k[s]), int(s), int(e)) for s, e in zip(starts, np.append(starts[1:], len(k)), strict=True)]

    def add_parts(self, segments: list[tuple[int, int, int]], parts: list, w: int) -> None:
        """Add the Grams of ``segments`` (from ``segments``): parts[j] = (the columns they cover,
        [their Gram for each segment]) for joint j, as ``Accumulator.add_columns`` returns them;
        w: the width of the full rows."""
        n, self.width = len(parts), w
        for i, (b, s, e) in enumerate(segments):
            P = self.packed.get(b)
            if P is None:
                P = self.packed[b] = np.zeros((n, w * (w + 1) // 2))
                self.rows[b] = 0
            self.rows[b] += e - s
            for j, (cols, grams) in enumerate(parts):
                if grams is None or not len(cols):
                    continue
                at, upper = _packed_positions(w, cols)
                P[j, at] += grams[i][upper]
        while len(self.packed) > self.max_blocks:
            self._merge()

    def _merge(self) -> None:
        packed: dict[int, np.ndarray] = {}
        rows: dict[int, int] = {}
        for b in sorted(self.packed):
            h = b // 2
            if h in packed:
                packed[h] += self.packed[b]  # in place: the pair's first Gram is not used elsewhere
                rows[h] += self.rows[b]
            else:
                packed[h], rows[h] = self.packed[b], self.rows[b]
        self.packed, self.rows, self.length = packed, rows, 2 * self.length

    def gram(self, b: int) -> np.ndarray:
        """(n, w, w): block b's Gram matrix of every joint, whole."""
        P = self.packed[b]
        w = self.width
        i, k = np.triu_indices(w)
        G = np.empty((len(P), w, w))
        G[:, i, k] = P
        G[:, k, i] = P
        return G

    def span(self) -> float:
        return 0.0 if self.t0 is None or self.t_last is None else self.t_last - self.t0

    def stack(self, maps: list[np.ndarray] | None, columns: list[int]) -> tuple[np.ndarray, np.ndarray]:
        """(B, n, q+1, q+1) block Grams of the final design's fitted ``columns`` and y, and the block indices.

        maps: per joint, M_j with [X_j | S_j | y_j] M_j = [final design columns | y_j] (None: identity)."""
        keys = sorted(self.packed)
        out = []
        for b in keys:
            G = self.gram(b)
            if maps is not None:
                G = np.stack([M.T @ Gj @ M for Gj, M in zip(G, maps, strict=True)])
            sel = list(columns) + [G.shape[-1] - 1]
            out.append(G[:, sel][:, :, sel])
        return np.array(out), np.array(keys)


@dataclass(frozen=True)
class Uncertainty:
    kind: str
    cov: np.ndarray  # (q, q) covariance of the fitted parameters, of ``kind``
    cov_textbook: np.ndarray
    theta: np.ndarray  # the weighted fit from the block statistics (equals the fit's θ)
    block_s: float
    blocks: int
    replicates: int | None
    seed: int | None
    doubling_ratio: float | None  # median over parameters of σ with blocks of 2L over σ with blocks of L (hac)
    columns: tuple[int, ...] = ()  # the design columns the covariance is over (set by the stage)
    note: str | None = None  # why another kind than the one asked for is shown (set by the stage)

    def std(self, which: str | None = None) -> np.ndarray:
        cov = self.cov_textbook if which == "textbook" else self.cov
        return np.sqrt(np.maximum(np.diag(cov), 0.0))

    def summary(self) -> SigmaSummary:
        """The report's "sigma" entry: the kind, its blocks and how it compares with the textbook σ."""
        ratio = self.std() / np.where(self.std("textbook") > 0, self.std("textbook"), np.nan)
        return SigmaSummary(self.kind, self.block_s, self.blocks, self.replicates, self.seed,
                            _num(np.nanmedian(ratio)) if len(ratio) else None, _num(self.doubling_ratio))

    def flags(self) -> list[str]:
        out = [self.note] if self.note else []
        if self.kind != "textbook" and self.blocks < FEW_BLOCKS:
            out.append(f"σ ({self.kind}) rests on {self.blocks} blocks of {self.block_s:g} s: the σ themselves are uncertain "
                       f"by about {100 / math.sqrt(2 * self.blocks):.0f} %")
        if self.doubling_ratio is not None and self.doubling_ratio > DOUBLING_FLAG:
            out.append(f"σ with blocks twice as long are {self.doubling_ratio:.2f}x larger: the residuals stay correlated "
                       f"beyond {self.block_s:g} s; try a longer --block-length")
        return out


def _num(x) -> float | None:
    return None if x is None or not np.isfinite(x) else float(x)


def _weighted(blocks: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """(B, q+1, q+1): each block's Gram summed over the joints with Gautier's weights 1/σ_j²."""
    w = 1.0 / np.asarray(sigma, dtype=float) ** 2
    return np.einsum("bjkl,j->bkl", blocks, w)


def _solve(Gw: np.ndarray) -> np.ndarray:
    q = Gw.shape[-1] - 1
    return np.linalg.solve(Gw[..., :q, :q], Gw[..., :q, q:])[..., 0]


def _hac(Gb: np.ndarray, theta: np.ndarray, keys: np.ndarray, rows: int) -> np.ndarray:
    """Newey–West (Bartlett, one lag) over block scores with Bell & McCaffrey's bias-reduced scores
    (CR2: each whitened block score divided by sqrt(I − P_b), P_b the block's share of the information,
    so that residual scores of the fitted θ are unbiased under independent errors), shrunk toward a scalar
    inflation of H⁻¹ where the blocks are too few to estimate a q x q meat (Ledoit & Wolf 2004)."""
    q = len(theta)
    H = Gb.sum(axis=0)[:q, :q]
    s = Gb[:, :q, q] - Gb[:, :q, :q] @ theta  # (B, q) block scores
    L = np.linalg.cholesky(H)
    Li = np.linalg.inv(L)
    Z = Li @ s.T  # whitened scores z_b = u_b − P_b Σ_c u_c (u: scores at the true θ, Cov u_b = P_b if independent)
    P, A = [], []
    for b in range(len(Gb)):
        P.append(Li @ Gb[b, :q, :q] @ Li.T)
        w, V = np.linalg.eigh(np.eye(q) - P[-1])
        A.append((V / np.sqrt(np.clip(w, CR2_FLOOR, None))) @ V.T)  # (I − P_b)^(-1/2)
        Z[:, b] = A[-1] @ Z[:, b]
    S = Z @ Z.T
    adjacent = np.flatnonzero(np.diff(keys) == 1)
    if len(adjacent):
        C = Z[:, adjacent] @ Z[:, adjacent + 1].T
        # E z_b z_{b+1}ᵀ = −P_b P_{b+1} for independent residuals: remove that bias of fitted scores
        C += sum(A[b] @ P[b] @ P[b + 1] @ A[b + 1] for b in adjacent)
        S += 0.5 * (C + C.T)
    lam = _shrinkage(Z)
    S = lam * (np.trace(S) / q) * np.eye(q) + (1 - lam) * S
    return Li.T @ S @ Li


def _shrinkage(Z: np.ndarray) -> float:
    """Ledoit–Wolf weight of the scaled identity for the sample second moment of the columns z_b of Z:
    near 0 with many blocks, near 1 when the blocks are fewer than the parameters."""
    q, B = Z.shape
    Sh = Z @ Z.T / B
    m = np.trace(Sh) / q
    d2 = float(np.sum((Sh - m * np.eye(q)) ** 2))
    if d2 <= 0:
        return 1.0
    n2 = np.sum(Z * Z, axis=0)
    b2 = float(np.sum(n2**2 - 2 * np.einsum("ib,ij,jb->b", Z, Sh, Z) + np.sum(Sh**2))) / B**2
    return min(b2, d2) / d2


def _bootstrap(Gb: np.ndarray, replicates: int, seed: int, progress=None, batch: int = 50) -> np.ndarray:
    """Non-overlapping block bootstrap: θ* from Σ_b c_b G_b with multinomial block counts c."""
    rng = np.random.default_rng(seed)
    B = len(Gb)
    thetas = []
    flat = Gb.reshape(B, -1)
    for r0 in range(0, replicates, batch):
        m = min(batch, replicates - r0)
        counts = rng.multinomial(B, np.full(B, 1.0 / B), size=m).astype(float)
        G = (counts @ flat).reshape((m,) + Gb.shape[1:])
        thetas.append(_solve(G))
        if progress is not None:
            progress(r0 + m, replicates)
    T = np.vstack(thetas)
    return np.cov(T, rowvar=False).reshape(Gb.shape[1] - 1, Gb.shape[1] - 1)


def _merge_pairs(Gb: np.ndarray, keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    half = keys // 2
    uniq = np.unique(half)
    out = np.array([Gb[half == h].sum(axis=0) for h in uniq])
    return out, uniq


def estimate(grams: BlockGrams, maps, columns: list[int], sigma: np.ndarray | None, rows: int, opts: UncertaintyOptions,
             progress=None) -> Uncertainty:
    """σ of the weighted fit of the final design's ``columns`` (weights ``sigma`` per joint; None: OLS, whose
    textbook covariance is s²(XᵀX)⁻¹ with s² = rss / (N − q)) from the blocks.

    rows: the number of equations (samples × joints) of the fit."""
    blocks, keys = grams.stack(maps, columns)
    if len(blocks) < 2 and opts.kind != "textbook":
        raise DataError(f"--block-length {grams.length:g} s is longer than the fit data ({grams.span():.4g} s): "
                        "the σ need at least two blocks; give a shorter --block-length")
    return from_weighted(_weighted(blocks, resolve_sigma(blocks, sigma, rows)), keys, rows, opts, grams.length, progress)


def resolve_sigma(blocks: np.ndarray, sigma: np.ndarray | None, rows: int) -> np.ndarray:
    """Gautier's per-joint σ_j, or for OLS (None) one common s = sqrt(rss / (N − q)) on every joint."""
    if sigma is not None:
        return np.asarray(sigma, dtype=float)
    G = blocks.sum(axis=(0, 1))
    t = np.concatenate([_solve(G), [-1.0]])
    s = math.sqrt(max(float(t @ G @ t), 0.0) / max(rows - (G.shape[0] - 1), 1)) or 1.0
    return np.full(blocks.shape[1], s)


def weighted_blocks(grams: BlockGrams, maps, columns: list[int], sigma: np.ndarray | None, rows: int) -> tuple[np.ndarray, np.ndarray]:
    """(B, q+1, q+1) block Grams of ``columns`` and y with the joint weights 1/σ_j², and the block indices."""
    blocks, keys = grams.stack(maps, columns)
    return _weighted(blocks, resolve_sigma(blocks, sigma, rows)), keys


def from_weighted(Gb: np.ndarray, keys: np.ndarray, rows: int, opts: UncertaintyOptions, block_s: float,
                  progress=None) -> Uncertainty:
    """The fit and its σ from weighted block Grams (blocks whose indices differ by one are neighbours in time)."""
    q = Gb.shape[-1] - 1
    theta = _solve(Gb.sum(axis=0))
    cov_text = np.linalg.inv(Gb.sum(axis=0)[:q, :q])
    cov_hac = _hac(Gb, theta, keys, rows) if len(Gb) >= 2 else cov_text
    doubling = None
    G2, k2 = _merge_pairs(Gb, keys)
    if len(G2) >= 2 and len(Gb) >= 2:
        s1 = np.sqrt(np.maximum(np.diag(cov_hac), 0))
        s2 = np.sqrt(np.maximum(np.diag(_hac(G2, theta, k2, rows)), 0))
        ok = s1 > 0
        doubling = float(np.median(s2[ok] / s1[ok])) if ok.any() else None
    replicates = seed = None
    if opts.kind == "hac":
        cov = cov_hac
    elif opts.kind == "bootstrap":
        cov = _bootstrap(Gb, opts.replicates, opts.seed, progress)
        replicates, seed = opts.replicates, opts.seed
    else:
        cov = cov_text
    return Uncertainty(opts.kind, cov, cov_text, theta, block_s, len(Gb), replicates, seed, doubling)


def relative_percent(theta: np.ndarray, std: np.ndarray) -> np.ndarray:
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(theta != 0, 100.0 * std / np.abs(theta), np.inf)


def restrict_maps(maps: list[np.ndarray] | None, old, new, grams: BlockGrams) -> list[np.ndarray]:
    """The maps to ``old``'s columns followed by the choice of ``new``'s columns among them (keep_physical)."""
    from minparam_cli.identify.assess.quality import positions

    cols = positions(old, new)
    width = grams.width if grams.packed else old.p + 1
    out = []
    for j in range(len(next(iter(grams.packed.values())))):
        M = maps[j] if maps is not None else np.eye(width)
        out.append(M[:, cols + [M.shape[1] - 1]])
    return out
