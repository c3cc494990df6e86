"""Streaming row spaces and echelon forms for the method of projections.

* :class:`ExactRowSpace` keeps an exact basis of the span of integer rows fed
  to it in blocks.  A block is tested against the integer kernel of the basis
  (row x is in the span iff x · N = 0); only rows that fail are reduced, one at
  a time, in exact rational arithmetic.  The test runs in float64 when a bound
  proves every partial sum is an integer below 2**53, else on Python integers.
* :class:`FloatRowSpace` keeps the triangular factor R of the rows fed to it
  (Householder QR of the stacked blocks), so that Rᵀ R = Σ Xᵀ X: any question
  about column dependencies, least squares included, has the same answer for
  R as for the rows themselves.
* :func:`integer_rref` brings integer rows to reduced row echelon form with
  exact integer arithmetic (fraction-free, rows kept primitive): its pivot
  columns are the columns kept by the scan-in-order rule.
"""

from __future__ import annotations

from fractions import Fraction
from math import gcd, lcm

import numpy as np

from minparam_cli.dynamics.projection_terms import FLOAT_EXACT_LIMIT


def _primitive(row: list[int]) -> list[int]:
    g = 0
    for v in row:
        if v:
            g = gcd(g, v)
    if g > 1:
        row = [v // g for v in row]
    return row


class ExactRowSpace:
    """Exact span of integer rows of length ``d``, fed as (d, n) column blocks."""

    def __init__(self, d: int):
        self.d = d
        self.pivots: list[int] = []
        self.rref: list[list[Fraction]] = []  # rows with 1 at their pivot, 0 at the other pivots
        self.rows: list[list[int]] = []  # the primitive integer rows as fed (a basis of the span)
        self._kernel()

    @property
    def rank(self) -> int:
        return len(self.pivots)

    def _kernel(self) -> None:
        """Integer basis of {v : basis · v = 0}, as columns (d, f), in float64 and object form."""
        free = [c for c in range(self.d) if c not in self.pivots]
        cols = []
        for f in free:
            v = [Fraction(0)] * self.d
            v[f] = Fraction(1)
            for p, r in zip(self.pivots, self.rref, strict=True):
                v[p] = -r[f]
            den = lcm(*[x.denominator for x in v])
            cols.append(_primitive([int(x * den) for x in v]))
        K = np.zeros((self.d, len(cols)), dtype=object)
        for i, c in enumerate(cols):
            K[:, i] = c
        self.K_obj = K
        big = max((abs(int(x)) for x in K.ravel()), default=0)
        self.K_f = K.astype(np.float64) if big < FLOAT_EXACT_LIMIT else None

    def _residual(self, X: np.ndarray) -> np.ndarray:
        """Kᵀ X exactly: nonzero columns are rows outside the span."""
        if X.dtype != object and self.K_f is not None:
            bound = float(np.max(np.abs(self.K_f.T) @ np.abs(X).max(axis=1))) if X.size and self.K_f.size else 0.0
            if bound < FLOAT_EXACT_LIMIT:
                return self.K_f.T @ X
        Xo = X if X.dtype == object else np.vectorize(int, otypes=[object])(X)
        return self.K_obj.T.dot(Xo)

    def _insert(self, row: list[int]) -> None:
        r = [Fraction(v) for v in row]
        for p, b in zip(self.pivots, self.rref, strict=True):
            if r[p]:
                f = r[p]
                r = [x - f * y for x, y in zip(r, b, strict=True)]
        lead = next(i for i, x in enumerate(r) if x)
        f = r[lead]
        r = [x / f for x in r]
        for i, b in enumerate(self.rref):
            if b[lead]:
                g = b[lead]
                self.rref[i] = [x - g * y for x, y in zip(b, r, strict=True)]
        self.pivots.append(lead)
        self.rref.append(r)
        self.rows.append(_primitive(row))
        self._kernel()

    def add(self, X: np.ndarray) -> None:
        """Add the columns of X (d, n), integers held exactly in float64 or as Python ints."""
        if self.rank == self.d or X.shape[1] == 0:
            return
        res = self._residual(X)
        bad = np.flatnonzero(np.any(res != 0, axis=0))
        while bad.size:
            self._insert([int(v) for v in X[:, bad[0]]])
            if self.rank == self.d:
                return
            rest = bad[1:]
            if not rest.size:
                return
            res = self._residual(X[:, rest])
            bad = rest[np.any(res != 0, axis=0)]


class FloatRowSpace:
    """Triangular factor R of all rows fed to it (Rᵀ R = Σ Xᵀ X), fed as (d, n) column blocks."""

    FLUSH = 65536

    def __init__(self, d: int):
        self.d = d
        self._R = np.zeros((0, d))
        self._buf: list[np.ndarray] = []
        self._buffered = 0

    def add(self, X: np.ndarray) -> None:
        if X.shape[1] == 0:
            return
        self._buf.append(np.asarray(X, dtype=np.float64).T)
        self._buffered += X.shape[1]
        if self._buffered >= self.FLUSH:
            self._flush()

    def _flush(self) -> None:
        if self._buf:
            stacked = np.concatenate([self._R, *self._buf], axis=0)
            self._R = np.linalg.qr(stacked, mode="r")  # type: ignore[assignment]  # numpy stubs: qr() gives QRResult for every mode; mode="r" returns R
            self._buf, self._buffered = [], 0

    @property
    def R(self) -> np.ndarray:
        self._flush()
        return self._R


def integer_rref(rows: list[list[int]]) -> tuple[list[int], list[list[int]]]:
    """Reduced row echelon form of integer rows, exactly (fraction-free Gauss–Jordan).

    Returns (pivots, reduced): reduced[i] has its first nonzero entry at
    pivots[i] (positive), zeros at every other pivot, and is primitive.  Rows
    are returned sorted by pivot.  A column is a pivot iff it is not a
    combination of the columns before it, and then for a non-pivot column d,
    column d = Σ_i reduced[i][d] / reduced[i][pivots[i]] · column pivots[i].
    """
    pivots: list[int] = []
    basis: list[list[int]] = []
    for row in rows:
        r = list(row)
        for p, b in zip(pivots, basis, strict=True):
            if r[p]:
                a, c = b[p], r[p]
                g = gcd(a, c)
                a, c = a // g, c // g
                r = [a * x - c * y for x, y in zip(r, b, strict=True)]
        lead = next((i for i, x in enumerate(r) if x), None)
        if lead is None:
            continue
        r = _primitive(r)
        if r[lead] < 0:
            r = [-x for x in r]
        for i, b in enumerate(basis):
            if b[lead]:
                a, c = r[lead], b[lead]
                g = gcd(a, c)
                a, c = a // g, c // g
                nb = _primitive([a * x - c * y for x, y in zip(b, r, strict=True)])
                if nb[pivots[i]] < 0:
                    nb = [-x for x in nb]
                basis[i] = nb
        pivots.append(lead)
        basis.append(r)
    order = sorted(range(len(pivots)), key=lambda i: pivots[i])
    return [pivots[i] for i in order], [basis[i] for i in order]


def solve_dense(rows: list[list], rhs: list, zero):
    """Exact solution of a tall consistent system (rows x unknowns); None if inconsistent or
    not of full column rank."""
    m = len(rows[0]) if rows else 0
    A = [list(r) + [b] for r, b in zip(rows, rhs, strict=True)]
    piv_rows = []
    r = 0
    for c in range(m):
        p = next((i for i in range(r, len(A)) if A[i][c]), None)
        if p is None:
            return None
        A[r], A[p] = A[p], A[r]
        inv = 1 / A[r][c] if not isinstance(A[r][c], float) else 1.0 / A[r][c]
        A[r] = [x * inv for x in A[r]]
        for i in range(len(A)):
            if i != r and A[i][c]:
                f = A[i][c]
                A[i] = [x - f * y for x, y in zip(A[i], A[r], strict=True)]
        piv_rows.append(r)
        r += 1
    if any(A[i][m] for i in range(r, len(A))):
        return None
    return [A[i][m] for i in range(m)]
