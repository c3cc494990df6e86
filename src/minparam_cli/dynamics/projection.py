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
    float_geometry,
    phi_matrix,
    sym_matrix,
)
from minparam_cli.params import N_LINK_PARAMS

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


def _children(chain: Chain, k: int) -> tuple[int, ...]:
    return tuple(j for j, p in enumerate(chain.parents) if p == k)


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

    def _block(self, *args) -> Block:
        b = Block(*args, skipped=self.skipped)
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
        E = np.eye(4, dtype=self.dtype).reshape(16, 1)
        yield from self._walk_N(-1, E, np.zeros(1, dtype=np.int64))

    def _walk_N(self, k, X, idx):
        for c in _children(self.chain, k):
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
        for c in _children(self.chain, k):
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
        for c in _children(self.chain, k):
            nY = Y_SIZE[self.chain.types[c]]
            for Xs, ids in self._split(X, idx):
                for G, gi, first in self._step(c, "AA", Xs, ids, nY, "G"):
                    b = self._kin_block(c, pair, G, gi, first)
                    if b is not None:
                        yield b
                    yield from self._walk_G(c, pair, G, gi)

    # --- potential energy ---------------------------------------------------
    def potential(self) -> Iterator[Block]:
        v = np.asarray(self.geom.gravity, dtype=self.dtype).reshape(4, 1)
        yield from self._walk_V(-1, v, np.zeros(1, dtype=np.int64))

    def _walk_V(self, k, X, idx):
        for c in _children(self.chain, k):
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
        for d in _children(chain, c):
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
    :func:`produced_rows` (the last block may be empty, carrying only a count).

    In exact mode on float64, raises :class:`InexactFloat` if an intermediate
    could exceed 2**53 (the caller then reruns on Python integers).
    """
    rec = _Recursion(geom, chunk)
    yield from rec.potential()
    yield from rec.kinetic()
    if rec.skipped:  # zeros found after the last block: an empty block carries their count
        yield Block(KINETIC, -1, None, (), np.zeros(0, dtype=np.int64), np.zeros((KINETIC_DIM, 0)), rec.skipped)


# --- from short coordinates to rows of Z ------------------------------------------


def row_maps(geom: ProjectionGeometry, t: int) -> tuple[np.ndarray, np.ndarray]:
    """(Ψ_kin, Ψ_pot) of node t: Z rows = Ψ @ coords, shapes (P, KINETIC_DIM) and (P, POTENTIAL_DIM).

    The kinetic rows hold ``geom.kinetic_scale`` times the Lagrangian
    coordinates, the potential rows ``geom.potential_scale`` times them (in
    the rescaled units of exact mode).
    """
    chain = geom.chain
    dtype = object if geom.exact else np.float64  # exact mode: Python integers, whatever the recursion used
    conv = _as_python_ints if geom.exact else (lambda a: np.asarray(a, dtype=np.float64))
    layout = chain.layout
    P = layout.size
    Phi = phi_matrix(dtype)
    kin16 = np.zeros((P, 16), dtype=dtype)
    pot4 = np.zeros((P, 4), dtype=dtype)
    # C⁰ products from t down to every link k below it (parents come before children)
    carry = {t: conv(np.eye(16))}
    vcarry = {t: conv(np.eye(4))}
    for k in chain.subtree(t):
        if k != t:
            p = chain.parents[k]
            carry[k] = conv(geom.maps[k]["A0"]).dot(carry[p])
            vcarry[k] = conv(geom.terms[k].A[0]).T.dot(vcarry[p])
        cols = slice(N_LINK_PARAMS * k, N_LINK_PARAMS * k + N_LINK_PARAMS)
        kin16[cols] = Phi @ carry[k]
        pot4[N_LINK_PARAMS * k + 6 : N_LINK_PARAMS * k + 10] = vcarry[k]
    kin = np.zeros((P, KINETIC_DIM), dtype=dtype)
    for i, (a, b) in enumerate(SYM_PAIRS):
        kin[:, i] = kin16[:, 4 * a + b]  # equals kin16[:, 4b + a]: ⟨H, ·⟩ and C⁰ commute with transposition
    pot = np.zeros((P, POTENTIAL_DIM), dtype=dtype)
    pot[:, :4] = pot4
    for c, (j, kind) in enumerate(layout.extra_columns):
        if j != t:
            continue
        col = layout.n_inertial + c
        if kind == "rotor_inertia":
            kin[col, -1] = geom.kinetic_scale  # Ia_t q̇_t²/2
        elif kind == "offset" and chain.types[t] == PRISMATIC:
            pot[col, -1] = -geom.potential_scale  # L ∋ -OFF_t q_t
    return kin, pot


def _as_python_ints(a) -> np.ndarray:
    a = np.asarray(a)
    out = np.empty(a.shape, dtype=object)
    for idx, v in np.ndenumerate(a):
        out[idx] = int(v)
    return out


def basis_dimension(chain: Chain) -> int:
    """dim B of the theorem: (N²+N)/2 · 5^v 3^(N-v) + 3^v 2^(N-v), constant function included."""
    n = chain.n
    y = x = 1
    for kind in chain.types:
        y *= Y_SIZE[kind]
        x *= X_SIZE[kind]
    return (n * n + n) // 2 * y + x


def produced_rows(chain: Chain) -> tuple[int, int]:
    """(kinetic, potential) rows the recursion produces: nonconstant basis functions that
    can carry a nonzero coordinate.  For a serial chain they sum to dim B - 1; a tree
    has fewer (functions mixing two branches never appear)."""
    prodY, prodX = {}, {}
    for j in range(chain.n):  # parents come before children
        p = chain.parents[j]
        prodY[j] = (prodY[p] if p >= 0 else 1) * Y_SIZE[chain.types[j]]
        prodX[j] = (prodX[p] if p >= 0 else 1) * X_SIZE[chain.types[j]]
    kin = pot = 0
    for t in range(chain.n):
        p = chain.parents[t]
        before = prodY[p] if p >= 0 else 1
        depth = len(chain.ancestors(t))
        # seeds (t, j) for every j on the path: all functions over path(t)
        kin += depth * prodY[t]
        # pairs (i, j) seeded above t: functions with y_t != 1
        kin += (depth - 1) * depth // 2 * before * (Y_SIZE[chain.types[t]] - 1)
        pot += (prodX[p] if p >= 0 else 1) * (X_SIZE[chain.types[t]] - 1)
    return kin, pot


def decode_index(chain: Chain, path: tuple[int, ...], index: int, kind: str) -> tuple[int, ...]:
    """Per-joint basis indices (0 = the function 1) of one flat multi-index over ``path``."""
    sizes = Y_SIZE if kind == KINETIC else X_SIZE
    digits = [0] * chain.n
    for j in reversed(path):
        index, digits[j] = divmod(int(index), sizes[chain.types[j]])
    return tuple(digits)


def coordinate_matrix(chain: Chain, max_rows: int = 100_000) -> tuple[list[tuple], np.ndarray]:
    """Z itself, dense, in SI units, for small chains (tests and documentation).

    Returns (labels, Z): label ("kinetic", i, j, y) for basis function q̇_i q̇_j ·
    Π y (q̇_i²/2 · Π y when i == j; i, j 0-based) or ("potential", x), with y, x
    per-joint indices into Y_NAMES / X_NAMES.  Only energy rows: Coulomb,
    viscous and revolute offset columns are zero here.
    """
    kin, pot = produced_rows(chain)
    if kin + pot > max_rows:
        raise ValueError(f"Z has {kin + pot} rows, more than max_rows={max_rows}")
    geom = float_geometry(chain)
    maps = [row_maps(geom, t) for t in range(chain.n)]
    labels, rows = [], []
    for b in energy_blocks(geom):
        if not b.rows:
            continue
        psi = maps[b.node][0 if b.kind == KINETIC else 1]
        Z = (psi @ b.coords).T
        if b.kind == KINETIC:
            Z = Z / geom.kinetic_scale
        rows.append(Z)
        for ix in b.index:
            digits = decode_index(chain, b.path, ix, b.kind)
            labels.append((KINETIC, *b.pair, digits) if b.kind == KINETIC else (POTENTIAL, digits))
    return labels, np.concatenate(rows, axis=0)


__all__ = [
    "Block",
    "KINETIC",
    "POTENTIAL",
    "basis_dimension",
    "coordinate_matrix",
    "decode_index",
    "energy_blocks",
    "produced_rows",
    "row_maps",
]


# --- up-front work estimate -------------------------------------------------------


class _Support:
    """Bit masks of one map's nonzero pattern: for input entry i, the outputs it reaches, per y."""

    def __init__(self, M: np.ndarray, size: int):
        d = M.shape[1]
        nz = np.asarray(M != 0).reshape(size, d, d)  # [y, out, in]
        weights = 1 << np.arange(d, dtype=np.int64)
        self.size = size
        self.reach = [[int((nz[y, :, i] * weights).sum()) for i in range(d)] for y in range(size)]
        self.cache: dict[int, tuple[int, ...]] = {}

    def apply(self, pattern: int) -> tuple[int, ...]:
        """Output pattern per y of one input pattern (0: that output is zero and dropped)."""
        out = self.cache.get(pattern)
        if out is None:
            bits = [i for i in range(pattern.bit_length()) if pattern >> i & 1]
            out = tuple(_or(reach[i] for i in bits) for reach in self.reach)
            self.cache[pattern] = out
        return out


def _or(masks) -> int:
    m = 0
    for x in masks:
        m |= x
    return m


def recursion_work(geom: ProjectionGeometry) -> int:
    """Matrices the kinetic recursion multiplies, counted on the maps' nonzero patterns.

    The recursion of ``energy_blocks`` drops every zero matrix; a matrix is zero
    for the structure of the maps (right angles, axes along the frame axes) or by
    cancellation.  Walking the same tree on bit patterns of nonzero entries, with
    multiplicities, counts every matrix the recursion can produce (cancellations
    aside: an upper bound), in time proportional to the number of distinct
    patterns, not of matrices.  The time of ``derive_projection`` grows with it.
    """
    chain = geom.chain
    n = chain.n
    sup = [{k: _Support(geom.maps[c][k], Y_SIZE[chain.types[c]]) for k in ("AA", "DA", "AD", "DD")} for c in range(n)]
    kids = [_children(chain, k) for k in range(-1, n)]  # kids[k + 1]
    total = 0

    def step(c: int, name: str, patterns: dict[int, int]) -> dict[int, int]:
        nonlocal total
        out: dict[int, int] = {}
        s = sup[c][name]
        for p, count in patterns.items():
            total += count * s.size
            for q in s.apply(p):
                if q:
                    out[q] = out.get(q, 0) + count
        return out

    def walk(kind: str, k: int, patterns: dict[int, int]) -> None:
        for c in kids[k + 1]:
            if kind == "N":
                walk("G", c, step(c, "DD", patterns))
                walk("M", c, step(c, "DA", patterns))
                walk("N", c, step(c, "AA", patterns))
            elif kind == "M":
                walk("G", c, step(c, "AD", patterns))
                walk("M", c, step(c, "AA", patterns))
            else:
                walk("G", c, step(c, "AA", patterns))

    walk("N", -1, {int(sum(1 << i for i in (0, 5, 10, 15))): 1})  # the identity, flattened 4x4
    return total
