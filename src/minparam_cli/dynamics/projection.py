"""Method of projections, part 2: the coordinate matrix Z, by Krutikov's forward recursion.

Krutikov (2011), paper 000.  The Lagrangian is linear in the standard
parameters, L = K - Π = w_L(q, q̇) · p, and every influence coefficient (entry
of w_L) lies in the span of the basis (theorem on the basis set)

    B = ((Q12 ∪ Q21) * Y1 * ... * YN) ∪ (X1 * ... * XN),

Q12 = {q̇_i²/2}, Q21 = {q̇_i q̇_j, j < i}; X_k, Y_k as in ``projection_terms``.
Row r of Z holds the coordinates, on basis function b_r, of the influence
coefficients of all parameters (columns in ``chain.layout`` order).

Kinetic energy (eq. 5-6): K = Σ_i a_ii q̇_i²/2 + Σ_{j<i} a_ij q̇_i q̇_j with
a_ij = Σ_k tr(U_kj H_k U_kiᵀ) = Σ_k ⟨H_k, G_k(i, j)⟩, G_k(i, j) = U_kjᵀ U_ki,
U_ki = ∂T_k/∂q_i.  Forward recursion along every path from the root
(eq. 3, 9, 15-19; c is a child of k, A = A_c, D = dA_c/dq_c):

    N_c      = Aᵀ N_k A          (N = TᵀT, N_root = E)
    M_c(c)   = Dᵀ N_k A          (M(j) = U_jᵀ T)
    M_c(j)   = Aᵀ M_k(j) A
    G_c(c,c) = Dᵀ N_k D
    G_c(c,j) = Aᵀ M_k(j) D
    G_c(i,j) = Aᵀ G_k(i,j) A

each product re-expanded on Y_c (eq. 13), so every N, M and G is computed
once.  The coefficient of link k's parameters on basis function
q̇_i q̇_j · y is ⟨H_k, G_k(i,j)^y⟩ (eq. 16-18).  Potential energy (eq. 4):
L ∋ g̃ᵀ T_k H_k e4 = (g̃ᵀ T_k) · (MX, MY, MZ, M), with g̃ᵀ T_c = (g̃ᵀ T_k) A_c
expanded on X_c.

Streaming.  A basis function whose deepest joint is t reaches link t and the
links below t only through the fixed maps C⁰ (the y = 1 term of Aᵀ · A), so
its row of Z is Ψ_t applied to ten numbers: the symmetric part of G_t(i,j)^y
(kinetic) or four: g̃ᵀ T_t^y (potential).  The recursion therefore yields
blocks of these short coordinates, grouped by t, never the dense Z.

What Z leaves out, and why.
* The constant basis function (all ones in X1*...*XN) is excluded: a constant
  term of L does not enter the equations of motion (NOTES.md).
* Rotor inertia Ia_j: its energy Ia_j q̇_j²/2 puts 1 on the basis function
  q̇_j²/2 alone (a marker coordinate on that row of block t = j).
* Offset OFF_j: a constant generalised force is the force of the potential
  -OFF_j q_j.  For a prismatic joint q_j is in X_j, so OFF_j gets -1 on the
  basis function q_j (a marker coordinate on that row), where gravity along
  the axis also lands: the two columns can then be dependent, as they are in
  the equations of motion.  For a revolute joint q_j is not a trigonometric
  polynomial, so OFF_j has a row of its own.
* Coulomb and viscous friction are not energy terms: their generalised forces
  sign(q̇_j) and q̇_j on joint j are independent of every energy column and of
  each other, so each has a row of its own (added by the caller).

This module runs the recursion; ``projection_rows`` turns its short coordinates into rows of Z
and counts them, ``projection_work`` estimates its work up front.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterator

import numpy as np

from minparam_cli.chain import PRISMATIC, Chain
from minparam_cli.dynamics.projection_terms import (
    FLOAT_EXACT_LIMIT,
    SYM_PAIRS,
    X_SIZE,
    Y_SIZE,
    InexactFloat,
    ProjectionGeometry,
    sym_matrix,
)

KINETIC, POTENTIAL = "kinetic", "potential"
ROUNDING = 32 * np.finfo(float).eps  # relative rounding level of one recursion step (16-term sums)
CHUNK = 8192  # matrices per recursion step: bounds memory, keeps the products cache-sized
KINETIC_DIM = len(SYM_PAIRS) + 1  # symmetric part of G, plus the rotor-inertia marker
POTENTIAL_DIM = 4 + 1  # g̃ᵀ T, plus the offset marker


@dataclass(frozen=True)
class Block:
    """Rows of Z with the same deepest joint ``node``, as short coordinates (see module doc)."""

    kind: str
    node: int
    pair: tuple[int, int] | None  # (i, j), j an ancestor of i or i itself (kinetic only)
    path: tuple[int, ...]  # joints from the root to node
    index: np.ndarray  # (n,) multi-index over ``path``, mixed radix, the last joint fastest
    coords: np.ndarray  # (KINETIC_DIM or POTENTIAL_DIM, n)
    skipped: int = 0  # rows found zero (pruned) since the previous block: for progress

    @property
    def rows(self) -> int:
        return self.coords.shape[1]


class _Recursion:
    """The forward recursion over the tree, chunked, as a generator of blocks."""

    def __init__(self, geom: ProjectionGeometry, chunk: int = CHUNK):
        self.geom = geom
        self.chain = geom.chain
        self.chunk = max(int(chunk), 1)
        self.dtype = geom.dtype
        self.guard = geom.exact and geom.dtype is np.float64
        self.S = sym_matrix(self.dtype)
        self.ops = geom.maps
        self.absmaps = [{k: np.abs(m.astype(np.float64)) for k, m in maps.items()} for maps in geom.maps]
        self.paths = [self.chain.ancestors(j) for j in range(self.chain.n)]
        self.below = _rows_below(self.chain)
        self.skipped = 0

    def _block(self, kind: str, node: int, pair: tuple[int, int] | None, path: tuple[int, ...], index: np.ndarray,
               coords: np.ndarray) -> Block:
        b = Block(kind, node, pair, path, index, coords, skipped=self.skipped)
        self.skipped = 0
        return b

    # one step: X' = M X re-expanded on Y_c (or X_c), as pieces of at most ~chunk columns.
    # Zero matrices are dropped: every product of a zero matrix is zero, and most of Z is.
    def _step(self, c: int, name: str, X: np.ndarray, idx: np.ndarray, size: int, what: str, protect: tuple[int, ...] = ()):
        """``what`` names the output (seed, G, M, N, V): how many basis rows a dropped zero stands for."""
        M = self.ops[c][name]
        if self.guard and X.size:
            # every partial sum of M X is bounded by |M| @ max|X| (per coordinate); keep it < 2**52
            bound = float(np.max(self.absmaps[c][name] @ np.abs(X).max(axis=1)))
            if bound >= FLOAT_EXACT_LIMIT / 2:
                raise InexactFloat
        d, n = X.shape
        out = M @ X
        if not self.geom.exact:
            # float64: a result below the rounding error of its own sums is a cancellation, not a
            # coefficient (exact arithmetic gives 0 there); flush it so that zeros stay zeros
            out[np.abs(out) <= ROUNDING * (self.absmaps[c][name] @ np.abs(X))] = 0.0
        out = out.reshape(size, d, n)
        if size * n <= self.chunk or n == 1:
            flat = np.ascontiguousarray(out.transpose(1, 0, 2)).reshape(d, size * n)
            ids = (idx[None, :] * size + np.arange(size)[:, None]).reshape(-1)
            keep = np.any(flat != 0, axis=0) | np.isin(ids, protect)  # marker rows stay even if zero
            if not keep.all():
                self._count_dropped(c, what, ids[~keep] % size)
                first = int(np.count_nonzero(keep[:n]))
                return [(flat[:, keep], ids[keep], first)]
            return [(flat, ids, n)]  # columns from n on have y_c != 1
        pieces = []
        for y in range(size):
            ids = idx * size + y
            keep = np.any(out[y] != 0, axis=0) | np.isin(ids, protect)
            if not keep.all():
                self._count_dropped(c, what, np.full(int(np.count_nonzero(~keep)), y))
            if keep.any():
                pieces.append((out[y][:, keep], ids[keep], 0 if y else int(keep.sum())))
        return pieces

    def _count_dropped(self, c: int, what: str, y: np.ndarray) -> None:
        """Basis rows that a dropped zero entry at node c (Y or X index y) stands for."""
        own = {"seed": len(y), "G": int(np.count_nonzero(y)), "V": int(np.count_nonzero(y))}.get(what, 0)
        self.skipped += own + len(y) * self.below[what][c]

    def _split(self, X, idx):
        n = X.shape[1]
        for lo in range(0, n, self.chunk):
            yield X[:, lo : lo + self.chunk], idx[lo : lo + self.chunk]

    def _kin_block(self, t, pair, X, idx, first=0, marker=False):
        X, idx = X[:, first:], idx[first:]
        if X.shape[1] == 0:
            return None
        coords = np.zeros((KINETIC_DIM, X.shape[1]), dtype=self.dtype)
        coords[:-1] = self.S @ X
        if marker:
            coords[-1] = idx == 0
        return self._block(KINETIC, t, pair, self.paths[t], idx, coords)

    # --- kinetic energy ---------------------------------------------------
    def kinetic(self) -> Iterator[Block]:
        E: np.ndarray = np.eye(4, dtype=self.dtype).reshape(16, 1)
        yield from self._walk_N(-1, E, np.zeros(1, dtype=np.int64))

    def _walk_N(self, k, X, idx):
        for c in self.chain.children(k):
            nY = Y_SIZE[self.chain.types[c]]
            for Xs, ids in self._split(X, idx):
                for G, gi, _ in self._step(c, "DD", Xs, ids, nY, "seed", protect=(0,)):  # q̇_c²/2 alone: Ia_c
                    b = self._kin_block(c, (c, c), G, gi, 0, marker=True)
                    if b is not None:
                        yield b
                    yield from self._walk_G(c, (c, c), G, gi)
                for M, mi, _ in self._step(c, "DA", Xs, ids, nY, "M"):
                    yield from self._walk_M(c, c, M, mi)
                for N, ni, _ in self._step(c, "AA", Xs, ids, nY, "N"):
                    yield from self._walk_N(c, N, ni)

    def _walk_M(self, k, j, X, idx):
        for c in self.chain.children(k):
            nY = Y_SIZE[self.chain.types[c]]
            for Xs, ids in self._split(X, idx):
                for G, gi, _ in self._step(c, "AD", Xs, ids, nY, "seed"):
                    b = self._kin_block(c, (c, j), G, gi)
                    if b is not None:
                        yield b
                    yield from self._walk_G(c, (c, j), G, gi)
                for M, mi, _ in self._step(c, "AA", Xs, ids, nY, "M"):
                    yield from self._walk_M(c, j, M, mi)

    def _walk_G(self, k, pair, X, idx):
        for c in self.chain.children(k):
            nY = Y_SIZE[self.chain.types[c]]
            for Xs, ids in self._split(X, idx):
                for G, gi, first in self._step(c, "AA", Xs, ids, nY, "G"):
                    b = self._kin_block(c, pair, G, gi, first)
                    if b is not None:
                        yield b
                    yield from self._walk_G(c, pair, G, gi)

    # --- potential energy ---------------------------------------------------
    def potential(self) -> Iterator[Block]:
        v: np.ndarray = np.asarray(self.geom.gravity, dtype=self.dtype).reshape(4, 1)
        yield from self._walk_V(-1, v, np.zeros(1, dtype=np.int64))

    def _walk_V(self, k, X, idx):
        for c in self.chain.children(k):
            nX = X_SIZE[self.chain.types[c]]
            for Xs, ids in self._split(X, idx):
                # keep the all-ones prefix (0) alive, and q_c alone (1) for OFF_c when prismatic
                protect = (0, 1) if self.chain.types[c] == PRISMATIC else (0,)
                for V, vi, first in self._step(c, "X", Xs, ids, nX, "V", protect=protect):
                    if V.shape[1] > first:
                        coords = np.zeros((POTENTIAL_DIM, V.shape[1] - first), dtype=self.dtype)
                        coords[:-1] = V[:, first:]
                        if self.chain.types[c] == PRISMATIC:
                            coords[-1] = vi[first:] == 1  # the basis function q_c alone
                        yield self._block(POTENTIAL, c, None, self.paths[c], vi[first:], coords)
                    yield from self._walk_V(c, V, vi)


def _rows_below(chain: Chain) -> dict[str, list[int]]:
    """Basis rows produced below one entry at node c, not counting its own row, per kind of entry.

    G (fixed pair): each child d yields |Y_d| entries, |Y_d| - 1 of them rows at d;
    M(j) adds the seeds G_d(d, j); N adds the seeds G_d(d, d) and M_d(d); V like G on X.
    """
    n = chain.n
    G, M, N, V = [0] * n, [0] * n, [0] * n, [0] * n
    for c in reversed(range(n)):  # children come after parents
        for d in chain.children(c):
            y, x = Y_SIZE[chain.types[d]], X_SIZE[chain.types[d]]
            G[c] += y * (1 + G[d]) - 1
            M[c] += y * (1 + G[d] + M[d])
            N[c] += y * (1 + G[d] + M[d] + N[d])
            V[c] += x * (1 + V[d]) - 1
    return {"seed": G, "G": G, "M": M, "N": N, "V": V}


def energy_blocks(geom: ProjectionGeometry, chunk: int = CHUNK) -> Iterator[Block]:
    """Every nonconstant, nonzero row of Z, in blocks of short coordinates: potential first, then kinetic.

    Zero rows are never produced; ``Block.skipped`` counts the basis rows they
    stand for, so the rows plus the skipped of all blocks add up to
    ``projection_rows.produced_rows`` (the last block may be empty, carrying only a count).

    In exact mode on float64, raises :class:`InexactFloat` if an intermediate
    could exceed 2**53 (the caller then reruns on Python integers).
    """
    rec = _Recursion(geom, chunk)
    yield from rec.potential()
    yield from rec.kinetic()
    if rec.skipped:  # zeros found after the last block: an empty block carries their count
        yield Block(KINETIC, -1, None, (), np.zeros(0, dtype=np.int64), np.zeros((KINETIC_DIM, 0)), rec.skipped)


__all__ = ["Block", "KINETIC", "POTENTIAL", "energy_blocks"]
