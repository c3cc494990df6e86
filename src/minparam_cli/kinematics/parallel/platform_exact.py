"""Every assembly mode of the octahedral 3-3 pattern, by elimination.

Three "base" nodes B_0, B_1, B_2 are fixed; each "top" node T_k is joined to
the two base nodes other than B_k (Dang 2013's legs B_i P_j, i != j), and the
top nodes are mutually at fixed distances (a rigid platform, or three more legs
of a free octahedral truss).

Method.  T_k lies on the circle where the spheres about its two base nodes
meet: T_k = C_k + rho_k (cos t_k u_k + sin t_k v_k), with u_k in the base plane
and v_k the base normal, so a reflection in the base plane is t -> -t.  The
three side conditions |T_j - T_k|^2 = d_jk^2 are, after the half-angle
substitution s = tan(t / 2), biquadratic in each pair (s_j, s_k).  Eliminating
s_3 and then s_2 with Sylvester resultants leaves one polynomial of degree 16
in s_1: the octahedral 3-3 problem has at most 16 complex solutions.  The
polynomial is sampled on the unit circle and interpolated by FFT, so it is
never expanded symbolically.  Each root is lifted to (s_1, s_2, s_3) through
the two quadratics it leaves, the lift is checked against the third
equation, and the real solutions are refined by Newton's method on the angles.

Certificate.  When all 16 roots (with multiplicity) lift to verified
solutions, the enumeration is complete: no real mode can be missing.  The
smallest relative imaginary part among the non-real ones (how close two more
real modes are to appearing) and the smallest singular value of the Jacobian
among the real ones (how close a mode is to a singularity) are reported with
it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

BEZOUT_BOUND = 16
_T = np.array([[1.0, 0.0, 1.0], [1.0, 0.0, -1.0], [0.0, 2.0, 0.0]])  # (1+s^2)(1, cos, sin) = T (1, s, s^2)
_PAIRS = ((0, 1), (1, 2), (0, 2))
_N_SAMPLES = 32  # > 16: the spare coefficients measure the interpolation error
_RTOL = 64 * np.finfo(float).eps
_LIFT_TOL = 1e3 * _RTOL  # relative residual that accepts a polished complex solution
_REAL_TOL = 1e-6  # relative imaginary part below which a solution is refined as real


@dataclass(frozen=True)
class OctahedralSolutions:
    """Real solutions (top node coordinates) and the completeness certificate."""

    points: np.ndarray  # (n_real, 3, 3): T_0, T_1, T_2 for each real mode
    n_complex: int  # roots of the eliminant lifted to verified solutions, with multiplicity
    imag_margin: float  # smallest relative |Im s| over non-real solutions (inf if none)
    min_singular: float  # smallest Jacobian singular value over real solutions, relative
    interpolation_error: float  # relative size of the coefficients beyond degree 16
    empty_circle: int | None = None  # top node whose two spheres do not meet, if any

    @property
    def complete(self) -> bool:
        return self.n_complex == BEZOUT_BOUND


def solve_octahedral(base: np.ndarray, legs: np.ndarray, sides: np.ndarray) -> OctahedralSolutions:
    """Solve the octahedral 3-3 position problem.

    ``base`` (3, 3): B_0..B_2.  ``legs`` (3, 3): legs[i, k] = |B_i - T_k| for
    i != k (the diagonal is ignored).  ``sides`` (3, 3): |T_j - T_k|.
    Returns every real solution for T_0..T_2 in the frame of ``base``.
    """
    base = np.asarray(base, dtype=float)
    centre = base.mean(axis=0)
    scale = float(max(np.abs(base - centre).max(), np.abs(legs).max(), np.abs(sides).max()))
    B = (base - centre) / scale
    L = np.asarray(legs, dtype=float) / scale
    D = np.asarray(sides, dtype=float) / scale
    normal = np.cross(B[1] - B[0], B[2] - B[0])
    nn = np.linalg.norm(normal)
    if nn <= _RTOL * max(float(np.linalg.norm(B[1] - B[0])), 1.0) ** 2:
        raise ValueError("the three base nodes are collinear")
    normal /= nn

    circles = []
    for k in range(3):
        a, b = [i for i in range(3) if i != k]
        axis = B[b] - B[a]
        dist = np.linalg.norm(axis)
        e = axis / dist
        h = (dist * dist + L[a, k] ** 2 - L[b, k] ** 2) / (2 * dist)
        rho2 = L[a, k] ** 2 - h * h
        if rho2 <= 0:
            return OctahedralSolutions(np.zeros((0, 3, 3)), 0, np.inf, np.nan, 0.0, empty_circle=k)
        u = np.cross(normal, e)
        circles.append((B[a] + h * e, np.sqrt(rho2), u, normal))
    W = [np.column_stack([C, r * u, r * v]) for C, r, u, v in circles]  # T_k = W_k (1, cos, sin)
    quad = {}
    for j, k in _PAIRS:
        aj = _linear_norm(*circles[j])
        ak = _linear_norm(*circles[k])
        M = -2.0 * W[j].T @ W[k]
        M[:, 0] += aj
        M[0, :] += ak
        M[0, 0] -= D[j, k] ** 2
        quad[j, k] = _T.T @ M @ _T  # coefficient of s_j^p s_k^q at [p, q]

    coeffs, interp_err = _univariate(quad)
    sols, n_complex, margin = _refine(_roots(coeffs), quad, circles, D)
    _, P = _residual(np.array(sols).reshape(-1, 3), circles, D)
    pts = np.stack(P, axis=1) if sols else np.zeros((0, 3, 3))
    min_sv = np.nan
    if sols:
        J = _jacobian(np.array(sols), circles).reshape(-1, 3, 3)
        min_sv = np.linalg.svd(J, compute_uv=False)[:, -1].min()
    return OctahedralSolutions(
        points=pts * scale + centre,
        n_complex=n_complex,
        imag_margin=margin,
        min_singular=float(min_sv),
        interpolation_error=interp_err,
    )


def _linear_norm(C, r, u, v):
    """|T|^2 as a linear form in (1, cos t, sin t)."""
    return np.array([C @ C + r * r, 2 * r * (C @ u), 2 * r * (C @ v)])



def _conv(a, b):
    """Batched polynomial product along the last axis (ascending coefficients)."""
    out = np.zeros(a.shape[:-1] + (a.shape[-1] + b.shape[-1] - 1,), dtype=np.result_type(a, b))
    for i in range(a.shape[-1]):
        out[..., i : i + b.shape[-1]] += a[..., i : i + 1] * b
    return out


def _resultant_t3(g, h):
    """Res_{s3}(g, h) for g = sum g_q s3^q (numbers, (..., 3)) and h_q(s2) polynomials (3, 3) -> (..., 5)."""
    h0, h1, h2 = h[:, 0], h[:, 1], h[:, 2]
    g0, g1, g2 = g[..., 0:1], g[..., 1:2], g[..., 2:3]
    A = g2 * h0 - g0 * h2
    Bq = g2 * h1 - g1 * h2
    C = g1 * h0 - g0 * h1
    return _conv(A, A) - _conv(Bq, C)


def _sylvester_det(f, r):
    """det of the Sylvester matrix of a quadratic f (..., 3) and a quartic r (..., 5)."""
    n = f.shape[:-1]
    S = np.zeros(n + (6, 6), dtype=np.result_type(f, r))
    for i in range(4):
        S[..., i, i : i + 3] = f
    for i in range(2):
        S[..., 4 + i, i : i + 5] = r
    return np.linalg.det(S)


def _univariate(quad):
    """Coefficients (ascending) of the degree-16 eliminant in s_1, by sampling on the unit circle."""
    z = np.exp(2j * np.pi * np.arange(_N_SAMPLES) / _N_SAMPLES)
    mz = np.stack([np.ones_like(z), z, z * z], axis=-1)
    f = mz @ quad[0, 1]  # E01 as a quadratic in s_2
    g = mz @ quad[0, 2]  # E02 as a quadratic in s_3
    r = _resultant_t3(g, quad[1, 2])  # E12 with s_3 eliminated: quartic in s_2
    values = _sylvester_det(f, r)
    c = np.fft.fft(values) / _N_SAMPLES
    top = max(np.abs(c).max(), 1e-300)
    err = float(np.abs(c[BEZOUT_BOUND + 1 :]).max() / top)
    return c[: BEZOUT_BOUND + 1].real, err


def _roots(c):
    """Roots of the ascending polynomial ``c``; tiny leading coefficients become roots at infinity."""
    top = np.abs(c).max()
    n = len(c) - 1
    while n > 0 and abs(c[n]) <= _RTOL * top:
        n -= 1
    r = np.roots(c[n::-1]) if n > 0 else np.zeros(0, complex)
    return np.concatenate([r.astype(complex), np.full(BEZOUT_BOUND - n, np.inf + 0j)])


def _quadratic_roots(c):
    """Both roots of c0 + c1 s + c2 s^2, vectorised, stable; inf where c2 = 0."""
    c0, c1, c2 = c[..., 0], c[..., 1], c[..., 2]
    disc = np.sqrt(c1 * c1 - 4 * c0 * c2 + 0j)
    flip = np.abs(c1 + disc) < np.abs(c1 - disc)
    disc = np.where(flip, -disc, disc)
    q = -0.5 * (c1 + disc)
    with np.errstate(divide="ignore", invalid="ignore"):
        r1 = np.where(c2 != 0, q / c2, np.inf)
        r2 = np.where(q != 0, c0 / q, np.inf)
    return np.stack([r1, r2], axis=-1)


def _lift(roots, quad):
    """Lift each root s_1 to (s_1, s_2, s_3).

    s_2 and s_3 are roots of E01(s_1, .) and E02(s_1, .); all four pairs are
    returned (m, 3), with the index of their root (m,) and their relative E12
    residual (m,).
    """
    fin = np.isfinite(roots)
    s1 = np.where(fin, roots, 0)
    m1 = np.stack([np.ones_like(s1), s1, s1 * s1], axis=-1)
    big = ~fin  # s_1 = inf: the leading coefficients
    f = np.where(big[:, None], quad[0, 1][2][None, :], m1 @ quad[0, 1])
    g = np.where(big[:, None], quad[0, 2][2][None, :], m1 @ quad[0, 2])
    s2 = _quadratic_roots(f)
    s3 = _quadratic_roots(g)
    cands = np.concatenate(
        [np.stack([roots, s2[:, i], s3[:, k]], axis=-1) for i in range(2) for k in range(2)], axis=0
    )
    owner = np.tile(np.arange(len(roots)), 4)
    rel = _biquadratic_rel(quad[1, 2], cands[:, 1], cands[:, 2])
    return cands, owner, rel


def _biquadratic_rel(Q, a, b):
    """|m(a)^T Q m(b)| / (|m(a)|^T |Q| |m(b)|); 1 where a value is not finite."""
    with np.errstate(all="ignore"):
        ma = np.stack([np.ones_like(a), a, a * a], axis=-1)
        mb = np.stack([np.ones_like(b), b, b * b], axis=-1)
        num = np.abs(np.einsum("ni,ij,nj->n", ma, Q, mb))
        den = np.einsum("ni,ij,nj->n", np.abs(ma), np.abs(Q), np.abs(mb))
        out = num / den
    return np.where(np.isfinite(out), out, 1.0)


def _residual(theta, circles, D):
    P = [
        C[None, :] + r * (np.cos(theta[:, k])[:, None] * u + np.sin(theta[:, k])[:, None] * v)
        for k, (C, r, u, v) in enumerate(circles)
    ]
    return np.stack([np.sum((P[j] - P[k]) ** 2, axis=1) - D[j, k] ** 2 for j, k in _PAIRS], axis=-1), P


def _jacobian(theta, circles):
    theta = np.atleast_2d(theta)
    P, dP = [], []
    for k, (C, r, u, v) in enumerate(circles):
        c, s = np.cos(theta[:, k])[:, None], np.sin(theta[:, k])[:, None]
        P.append(C + r * (c * u + s * v))
        dP.append(r * (-s * u + c * v))
    J = np.zeros(theta.shape[:1] + (3, 3), dtype=theta.dtype)
    for row, (j, k) in enumerate(_PAIRS):
        diff = P[j] - P[k]
        J[:, row, j] = 2 * np.sum(diff * dP[j], axis=1)
        J[:, row, k] = -2 * np.sum(diff * dP[k], axis=1)
    return J if J.shape[0] > 1 else J[0]


def _newton(theta, circles, D, iterations):
    """Newton on the three side conditions, row by row until each row's step is negligible."""
    theta = theta.copy()
    active = np.ones(len(theta), dtype=bool)
    for _ in range(iterations):
        if not np.any(active):
            break
        th = theta[active]
        F, _ = _residual(th, circles, D)
        J = _jacobian(th, circles).reshape(-1, 3, 3)
        ok = np.abs(np.linalg.det(J)) > 0
        step = np.zeros_like(th)
        if np.any(ok):
            step[ok] = np.linalg.solve(J[ok], F[ok][..., None])[..., 0]
        th = th - step
        theta[active] = th
        small = np.all(np.abs(step) <= 4 * _RTOL * (1 + np.abs(th)), axis=1) | ~ok | ~np.all(np.isfinite(th), axis=1)
        idx = np.flatnonzero(active)
        active[idx[small]] = False
    F, _ = _residual(theta, circles, D)
    return theta, np.max(np.abs(F), axis=1)


def _distinct(key, tol):
    """Indices of the first row of each cluster of rows closer than ``tol`` (max norm)."""
    keep: list[int] = []
    if len(key) == 0:
        return keep
    close = np.max(np.abs(key[:, None, :] - key[None, :, :]), axis=2) <= tol
    taken = np.zeros(len(key), dtype=bool)
    for i in range(len(key)):
        if not taken[i]:
            keep.append(i)
            taken |= close[i]
    return keep


def _newton_s(cands, quad):
    """Complex Newton on the three biquadratics in (s_1, s_2, s_3); returns the points and relative residuals."""
    s = cands.copy()
    pairs = [((0, 1), quad[0, 1]), ((1, 2), quad[1, 2]), ((0, 2), quad[0, 2])]
    active = np.ones(len(s), dtype=bool)
    for _ in range(12):
        if not np.any(active):
            break
        x = s[active]
        m = np.stack([np.ones_like(x), x, x * x], axis=-1)  # (n, 3 vars, 3 powers)
        dm = np.stack([np.zeros_like(x), np.ones_like(x), 2 * x], axis=-1)
        F = np.empty(x.shape, dtype=complex)
        J = np.zeros(x.shape + (3,), dtype=complex)
        for row, ((j, k), Q) in enumerate(pairs):
            left, right = m[:, j] @ Q, Q @ m[:, k, :, None]
            F[:, row] = np.sum(left * m[:, k], axis=1)
            J[:, row, j] = np.sum(dm[:, j] * right[..., 0], axis=1)
            J[:, row, k] = np.sum(left * dm[:, k], axis=1)
        with np.errstate(all="ignore"):
            ok = np.isfinite(J).all(axis=(1, 2)) & (np.abs(np.linalg.det(J)) > 0)
            step = np.zeros_like(x)
            if np.any(ok):
                step[ok] = np.linalg.solve(J[ok], F[ok][..., None])[..., 0]
            x = x - step
        s[active] = x
        done = ~ok | np.all(np.abs(step) <= _RTOL * (1 + np.abs(x)), axis=1)
        active[np.flatnonzero(active)[done]] = False
    rel = np.max([_biquadratic_rel(Q, s[:, j], s[:, k]) for (j, k), Q in pairs], axis=0)
    return s, rel


def _refine(roots, quad, circles, D):
    """Verify the lifted roots, then refine the real ones by real Newton on the angles.

    Returns (real angle triples, verified complex solutions, margin).
    """
    cands, owner, rel = _lift(roots, quad)
    fin = np.all(np.isfinite(cands), axis=1)
    best = np.full(len(roots), np.inf)
    np.minimum.at(best, owner, rel)
    fast = fin & (rel == best[owner])  # the best pair of each root first; all four if that falls short
    pol, prel = _newton_s(cands[fast], quad)
    if np.count_nonzero(prel <= _LIFT_TOL) < np.count_nonzero(np.isfinite(roots)):
        pol, prel = _newton_s(cands[fin], quad)
    pol = pol[prel <= _LIFT_TOL]
    # distinct solutions, compared through (cos t, sin t) = ((1 - s^2), 2 s) / (1 + s^2)
    with np.errstate(all="ignore"):
        key = np.concatenate([(1 - pol * pol) / (1 + pol * pol), 2 * pol / (1 + pol * pol)], axis=1)
    good = np.all(np.isfinite(key), axis=1)
    pol, key = pol[good], key[good]
    pol = pol[_distinct(key, 1e-8 * (1 + np.abs(key).max(initial=0.0)))]
    imag = np.max(np.abs(pol.imag) / (1.0 + np.abs(pol)), axis=1) if len(pol) else np.zeros(0)
    real = imag <= _REAL_TOL
    margin = float(imag[~real].min()) if np.any(~real) else np.inf
    starts = [2 * np.arctan(pol[real].real)]
    if not np.all(fin):  # a root at s = inf is an angle of pi
        c = cands[~fin]
        starts.append(np.where(np.isfinite(c) & (np.abs(c.imag) <= _REAL_TOL * (1 + np.abs(c))), 2 * np.arctan(c.real), np.pi))
    start = np.concatenate(starts, axis=0).astype(float)
    if len(start) == 0:
        return [], len(pol), margin
    rtheta, rres = _newton(start, circles, D, 30)
    rtheta = rtheta[rres <= 1e3 * _RTOL]
    key = np.concatenate([np.cos(rtheta), np.sin(rtheta)], axis=1)
    sols = [rtheta[i] for i in _distinct(key, 1e-9)]
    return sols, len(pol), margin
