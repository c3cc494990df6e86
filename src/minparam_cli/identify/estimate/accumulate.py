"""Streaming per-joint triangular factors: R_jᵀR_j = A_jᵀA_j for the rows A_j = [X_j | y_j] seen so far.

A block of rows A updates R to R' with R'ᵀR' = RᵀR + AᵀA.  Householder QR of
[R; A] does this in O(N·c²) at level-2 BLAS speed.  The update used here does the
same in two level-3 BLAS calls, several times faster, and as accurately: with
the current factor as preconditioner, B = A R⁻¹ (a triangular solve), then

    R'ᵀR' = Rᵀ (I + BᵀB) R,   so   R' = L R   with   LᵀL = I + BᵀB

(a c x c Cholesky factorisation of a matrix whose eigenvalues are ≥ 1).  The
errors are those of the triangular solve and of BᵀB, small relative to each
column when ‖B‖ is of order one, which holds when the block resembles the data
seen so far.  A column that so far is (nearly) a combination of the others
(|R_ii| < FLOOR·‖R_i‖, e.g. a rotor inertia that regroups with a base
parameter) gets a floored diagonal in the preconditioner P, and R' = K P with
KᵀK = (RP⁻¹)ᵀ(RP⁻¹) + BᵀB.  A block whose B has a column larger than LIMIT
(new content in a direction the data had not excited), the first block, and
any failure fall back to Householder QR.

Only the columns of joint j that have held a non-zero value are factored (the
regressor of joint j is zero in the columns of the links it does not carry), so
a joint near the tip costs a fraction of the base joint.

``add_columns`` may also return the Gram matrices A_sᵀA_s of row segments s (the
time blocks of ``uncertainty.BlockGrams``): on the fast path they come from the
products the update forms anyway, BᵀB = Σ_s B_sᵀB_s and A_sᵀA_s = Pᵀ B_sᵀB_s P,
so the rows are multiplied once, not twice.  A row that is not finite (or
whose square overflows) makes the factor non-finite: ``NonFiniteRows`` is
raised, naming the joint, and the accumulator is not to be used further.
"""

from __future__ import annotations

import numpy as np

from minparam_cli.identify.estimate.nogil_lapack import qr_r, solve_right_upper

FLOOR = 1e-10  # relative floor of the preconditioner's diagonal
LIMIT = 16.0  # largest squared column norm of A P⁻¹ the fast update takes


class NonFiniteRows(ArithmeticError):
    """The rows just added made a factor non-finite (a NaN, an infinity, or an overflow)."""

    def __init__(self, joint: int):
        super().__init__(f"joint {joint + 1}: non-finite regressor rows")
        self.joint = joint


def _segment_grams(A: np.ndarray, segments) -> list[np.ndarray]:
    return [A[s:e].T @ A[s:e] for s, e in segments]


def _fast(R: np.ndarray, A: np.ndarray, segments=None):
    norms = np.sqrt(np.einsum("ij,ij->j", R, R))
    if not np.all(norms > 0):
        return None
    d = np.diagonal(R)
    low = np.flatnonzero(np.abs(d) < FLOOR * norms)
    P = R
    if len(low):
        P = R.copy()
        P[low, low] = np.where(d[low] < 0, -FLOOR, FLOOR) * norms[low]
    B = solve_right_upper(P, A)  # A P⁻¹
    parts = None
    if segments is None:
        M = B.T @ B
    else:  # the segments' Grams of B sum to BᵀB
        parts = _segment_grams(B, segments)
        M = np.zeros((B.shape[1], B.shape[1]))
        for G in parts:
            M += G
    one = np.ones(len(M))
    if len(low):  # S = R P⁻¹: R's rows are P's but in the floored rows, so S is the identity but in those
        S = solve_right_upper(P, R[low])
        M += S.T @ S
        one[low] = 0.0
    M[np.diag_indices_from(M)] += one  # SᵀS's identity rows (0.0 where floored: exact, tiny entries keep their bits)
    if not np.all(np.isfinite(M)) or np.max(np.diagonal(M)) > LIMIT + 1.0:
        return None
    try:
        K = np.linalg.cholesky(M).T
    except np.linalg.LinAlgError:  # a floored direction that is singular to rounding
        w, V = np.linalg.eigh(M)
        K = np.linalg.qr((V * np.sqrt(np.clip(w, 0.0, None))).T, mode="r")
    if parts is not None:  # back to the rows' own coordinates: A_sᵀA_s = Pᵀ (B_sᵀB_s) P
        parts = [P.T @ G @ P for G in parts]
    return K @ P, parts


def update(R: np.ndarray, A: np.ndarray, segments=None):
    """R' with R'ᵀR' = RᵀR + AᵀA, for the rows A (N x c, best Fortran-ordered), and with
    ``segments`` ((start, end) row ranges) the Grams A_sᵀA_s of those rows (else None)."""
    if R.shape[0] == R.shape[1] == A.shape[1] and len(A):
        out = _fast(R, A, segments)
        if out is not None:
            return out
    return qr_r(R, A), None if segments is None else _segment_grams(A, segments)


def _lines(cols: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """cols[idx] for sorted indices: a view when they are a run (a joint's active columns are: the
    links it carries, then the slots and τ), so BLAS reads the rows where they lie, else a copy."""
    if len(idx) and idx[-1] - idx[0] == len(idx) - 1:
        return cols[idx[0] : idx[-1] + 1]
    return cols[idx]


class Accumulator:
    """Streaming per-joint factors of [X_j | y_j]; ``R`` gives them at full width (zero columns where unseen)."""

    def __init__(self, n: int, p: int):
        self.n, self.p = n, p
        self._R = [np.zeros((0, 0)) for _ in range(n)]  # factor over the active columns of joint j
        self._cols = [np.zeros(0, dtype=int) for _ in range(n)]  # those columns (sorted; y = p once seen)
        # and the others, kept beside them: a set difference a joint and block cost 0.5 s of the
        # 1 M-sample Panda run's factor thread (1,683 calls)
        self._unseen = [np.arange(p + 1) for _ in range(n)]
        self.rows = np.zeros(n, dtype=int)

    def add(self, X: np.ndarray, y: np.ndarray) -> None:
        """X: (N, n, p) design rows, y: (N, n) measured torques."""
        self.add_rows(np.concatenate([X, y[:, :, None]], axis=2))

    def add_rows(self, rows: np.ndarray) -> None:
        """rows: (N, n, p + 1), joint j's rows [X_j | y_j] in rows[:, j]."""
        self.add_columns(np.ascontiguousarray(rows.transpose(1, 2, 0)))

    def add_columns(self, cols: np.ndarray, segments=None) -> list | None:
        """The same rows joint-major: cols (n, p + 1, N) C-contiguous, joint j's rows transposed in
        cols[j] (the layout ``slots.block_rows`` builds): a joint's active columns are then a gather
        of contiguous lines, and their transpose the Fortran-ordered block the update takes.

        With ``segments`` ((start, end) ranges of the N rows), returns per joint (its active
        columns, [A_sᵀA_s over those columns for each segment]) (see the module's note).
        Raises NonFiniteRows when the rows make a factor non-finite."""
        out: list | None = [] if segments is not None else None
        for j in range(self.n):
            cj = cols[j]
            active = self._cols[j]
            rest = self._unseen[j]
            seen: np.ndarray | tuple[()] = ()
            if len(rest) and _lines(cj, rest).any():  # one pass; which columns only when some are non-zero
                seen = rest[_lines(cj, rest).any(axis=1)]
            if len(seen):  # columns non-zero for the first time: widen the factor
                new = np.union1d(active, seen)
                R = np.zeros((self._R[j].shape[0], len(new)))
                R[:, np.searchsorted(new, active)] = self._R[j]
                self._cols[j], self._R[j], active = new, R, new
                self._unseen[j] = np.setdiff1d(rest, seen, assume_unique=True)
            grams = None
            if len(active):
                R, grams = update(self._R[j], _lines(cj, active).T, segments)
                if not np.isfinite(R).all():
                    raise NonFiniteRows(j)
                self._R[j] = R
            if out is not None:
                out.append((active, grams))
            self.rows[j] += cols.shape[2]
        return out

    @property
    def R(self) -> list[np.ndarray]:
        out = []
        for Rc, cols in zip(self._R, self._cols, strict=True):
            R = np.zeros((Rc.shape[0], self.p + 1))
            R[:, cols] = Rc
            out.append(R)
        return out

    @classmethod
    def from_factors(cls, factors: list[np.ndarray], rows: np.ndarray) -> "Accumulator":
        out = cls(len(factors), factors[0].shape[1] - 1)
        for j, R in enumerate(factors):
            cols = np.flatnonzero(np.any(R != 0, axis=0))
            out._R[j], out._cols[j] = R[:, cols], cols
            out._unseen[j] = np.setdiff1d(np.arange(R.shape[1]), cols, assume_unique=True)
        out.rows = np.array(rows, dtype=int).copy()
        return out

    def rss(self, theta: np.ndarray) -> np.ndarray:
        v = np.concatenate([theta, [-1.0]])
        return np.array([float(np.sum((R @ v[cols]) ** 2)) for R, cols in zip(self._R, self._cols, strict=True)])

    def y_norm2(self) -> np.ndarray:
        """‖y_j‖² from the factors: the last column of R_j carries it."""
        return np.array([float(np.sum(R[:, -1] ** 2)) for R in self.R])

    def transform(self, maps: list[np.ndarray]) -> "Accumulator":
        """The same rows with new columns [X_j | y_j] M_j (M_j: (p + 1) x (p' + 1), re-triangularised)."""
        return Accumulator.from_factors([np.linalg.qr(R @ M, mode="r") for R, M in zip(self.R, maps, strict=True)], self.rows)  # type: ignore[misc]  # numpy stubs: qr() gives QRResult for every mode; mode="r" returns R

    def restrict(self, cols: list[int]) -> "Accumulator":
        """The same data with only the columns ``cols`` of X (re-triangularised)."""
        M = np.zeros((self.p + 1, len(cols) + 1))
        M[list(cols) + [self.p], np.arange(len(cols) + 1)] = 1.0
        return self.transform([M] * self.n)

    def stacked(self, weights: np.ndarray) -> np.ndarray:
        return np.vstack([R / w for R, w in zip(self.R, weights, strict=True)])
