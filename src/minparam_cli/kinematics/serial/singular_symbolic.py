"""Symbolic conditions for singular positions: the vanishing minors of matrix (3) (Glazunov 1985).

k screws lie in a (k-1)-system exactly when every k × k minor of their
6 × k sub-matrix vanishes (the paper, after Dimentberg).  For the whole arm
(n = 6) that is the determinant; for n < 6 the n-minors; for a group of two
or three joints its 2- or 3-minors.

How the conditions are obtained:

1. The joint screws are written in the frame of link 2 (rank and minors do
   not depend on the frame), with c_j = cos q_j, s_j = sin q_j for revolute
   joints and q_j for prismatic ones, and exact rational geometry (the
   file's decimals, read exactly).  Joint 1 and the last joint drop out, as
   the paper notes.
2. A minor is a polynomial in (c_j, s_j), which does not factor uniquely
   because c² + s² = 1.  The half-angle substitution t_j = tan(q_j / 2)
   turns it into a polynomial over the rationals, which does; the factors
   1 + t_j² (never zero) are dropped, and a missing top degree in t_j is a
   root at q_j = 180° (t_j = ∞).
3. Each factor is written back in cos/sin (a factor of even degree 2e in t_j
   is a trigonometric polynomial of degree e in q_j); a factor in one joint
   is solved numerically for its values in (-180°, 180°].
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from itertools import combinations
from typing import Any

import numpy as np

from minparam_cli.chain import REVOLUTE, Chain
from minparam_cli.factoring import factor_list
from minparam_cli.errors import UnsupportedError
from minparam_cli.kinematics.serial.plucker import require_serial

MAX_JOINTS = 6
MAX_GROUP = 3


@dataclass(frozen=True)
class Condition:
    """One factor that vanishes on a branch of the singular set."""

    expression: str  # "... = 0" in q1 … qn
    joints: tuple[int, ...]  # 0-based joints it involves
    solutions: tuple[float, ...] | None  # values of the single joint (rad or m), when it involves one
    multiplicity: int = 1


@dataclass(frozen=True)
class GroupCondition:
    group: tuple[int, ...]  # 0-based joints
    minors: int
    status: str  # "never" | "always" | "when" | "system"
    conditions: tuple[Condition, ...]


@dataclass(frozen=True)
class SymbolicResult:
    robot: str
    what: str  # "det" for six joints, "n-minors" otherwise
    conditions: tuple[Condition, ...]
    groups: tuple[GroupCondition, ...]
    exact_geometry: bool


def _rational(x) -> "object":
    import sympy as sp

    if isinstance(x, Fraction):
        return sp.Rational(x.numerator, x.denominator)
    return sp.Rational(repr(float(x)))


def symbolic_matrix(chain: Chain):
    """Matrix (3) in the frame of link 2 as a sympy Matrix, with its symbols.

    Returns (J, cos symbols, sin symbols, prismatic symbols), each symbol list indexed by joint
    (None where it does not apply).
    """
    import sympy as sp

    n = chain.n
    if chain.exact is not None:
        pre = [sp.Matrix([[_rational(v) for v in r] for r in e[0]]) for e in chain.exact]
        axes = [sp.Matrix([_rational(v) for v in e[1]]) for e in chain.exact]
        post = [sp.Matrix([[_rational(v) for v in r] for r in e[2]]) for e in chain.exact]
    else:
        pre = [sp.Matrix([[_rational(v) for v in r] for r in m]) for m in chain.pre]
        axes = [sp.Matrix([_rational(v) for v in a]) for a in chain.axes]
        post = [sp.Matrix([[_rational(v) for v in r] for r in m]) for m in chain.post]
    c = [sp.Symbol(f"c{j + 1}") if chain.types[j] == REVOLUTE else None for j in range(n)]
    s = [sp.Symbol(f"s{j + 1}") if chain.types[j] == REVOLUTE else None for j in range(n)]
    d = [sp.Symbol(f"q{j + 1}") if chain.types[j] != REVOLUTE else None for j in range(n)]

    def motion(j):
        T = sp.eye(4)
        k = axes[j]
        if chain.types[j] == REVOLUTE:
            K = sp.Matrix([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
            T[:3, :3] = sp.eye(3) + s[j] * K + (1 - c[j]) * K * K
        else:
            T[:3, 3] = d[j] * k
        return T

    def inverse(T):
        R, p = T[:3, :3], T[:3, 3]
        out = sp.eye(4)
        out[:3, :3] = R.T
        out[:3, 3] = -R.T * p
        return out

    m = min(1, n - 1)  # reference: link 2's frame
    cols = []
    for j in range(n):
        if j > m:
            A = sp.eye(4)
            for i in range(m + 1, j):
                A = A * pre[i] * motion(i) * post[i]
            A = A * pre[j]
        else:  # joint j's own motion leaves its axis in place
            B = post[j]
            for i in range(j + 1, m + 1):
                B = B * pre[i] * motion(i) * post[i]
            A = inverse(B)
        A = A.applyfunc(sp.expand)
        z = A[:3, :3] * axes[j]
        o = A[:3, 3]
        col = list(z) + list(o.cross(z)) if chain.types[j] == REVOLUTE else [0, 0, 0] + list(z)
        cols.append([sp.expand(v) for v in col])
    return sp.Matrix(cols).T, c, s, d


class _HalfAngle:
    """Polynomials in (c_j, s_j) -> polynomials in t_j = tan(q_j/2), and factors back to cos/sin."""

    def __init__(self, chain: Chain, c, s, d):
        import sympy as sp

        self.sp = sp
        self.n = chain.n
        self.rev = [j for j in range(self.n) if chain.types[j] == REVOLUTE]
        self.c, self.s, self.d = c, s, d
        self.t = [sp.Symbol(f"t{j + 1}") for j in range(self.n)]
        self.gens_cs = [c[j] for j in self.rev] + [s[j] for j in self.rev] + [d[j] for j in range(self.n) if d[j] is not None]
        self.gens_t = [self.t[j] for j in self.rev] + [d[j] for j in range(self.n) if d[j] is not None]
        self.q = [sp.Symbol(f"q{j + 1}") for j in range(self.n)]

    def to_t(self, expr):
        """(numerator polynomial in t, formal degree per revolute joint)."""
        sp = self.sp
        P = expr if isinstance(expr, sp.Poly) else sp.Poly(expr, *self.gens_cs)
        k = len(self.rev)
        deg = {}
        for i, j in enumerate(self.rev):
            deg[j] = max((m[i] + m[k + i] for m in P.monoms()), default=0)
        n_rev = len(self.rev)
        prism = [j for j in range(self.n) if self.d[j] is not None]
        cache: dict = {}
        acc: dict = {}
        for mono, coef in P.terms():
            factors = []  # per revolute joint: list of (exponent of t_j, coefficient)
            for i, j in enumerate(self.rev):
                key = (j, mono[i], mono[k + i])
                if key not in cache:
                    a, b = mono[i], mono[k + i]
                    t = self.t[j]
                    uni = sp.Poly((1 - t**2) ** a * (2 * t) ** b * (1 + t**2) ** (deg[j] - a - b), t)
                    cache[key] = [(e[0], cf) for e, cf in uni.terms()]
                factors.append(cache[key])
            tail = tuple(mono[2 * k + p_i] for p_i in range(len(prism)))
            partial: list[tuple[tuple[int, ...], Any]] = [((), coef)]
            for fl in factors:
                partial = [(ex + (e,), cf * c2) for ex, cf in partial for e, c2 in fl]
            for ex, cf in partial:
                key = ex + tail
                acc[key] = acc.get(key, 0) + cf
        acc = {m: v for m, v in acc.items() if v != 0}
        out = sp.Poly.from_dict(acc, *self.gens_t) if acc else sp.Poly(0, *self.gens_t)
        assert n_rev == k
        return out, {j: 2 * deg[j] for j in self.rev}

    def conditions(self, poly, formal: dict) -> list[Condition]:
        """Factor a t-polynomial into conditions written in cos/sin (with roots at 180° when degree is missing)."""
        _, factors = factor_list(poly)
        copies = []
        for f, mult in factors:
            if all(f.degree(self.t[j]) == 0 for j in self.rev) and f.total_degree() == 0:
                continue
            if self._is_unit_circle(f):
                for j in self.rev:
                    formal[j] -= mult * f.degree(self.t[j])
                continue
            copies.extend([f] * mult)
        deficiency = dict(formal)
        for f in copies:
            for j in self.rev:
                deficiency[j] -= f.degree(self.t[j])
        # pair factors of odd degree in a joint so that each becomes a trigonometric polynomial
        for j in self.rev:
            odd = [f for f in copies if f.degree(self.t[j]) % 2]
            while len(odd) >= 2:
                f1, f2 = odd.pop(), odd.pop()
                copies.remove(f1)
                copies.remove(f2)
                prod = f1 * f2
                copies.append(prod)
                odd = [f for f in copies if f.degree(self.t[j]) % 2]
        out: dict[str, list] = {}
        for f in copies:
            degs = {}
            for j in self.rev:
                e = f.degree(self.t[j])
                if e % 2 and deficiency[j] > 0:
                    deficiency[j] -= 1
                    e += 1
                degs[j] = e
            cond = self._condition(f, degs)
            key = cond.expression
            if key in out:
                out[key][1] += 1
            else:
                out[key] = [cond, 1]
        for j in self.rev:
            if deficiency[j] >= 2 or deficiency[j] == 1:
                cond = Condition(f"cos(q{j + 1}/2) = 0", (j,), (np.pi,), 1)
                out.setdefault(cond.expression, [cond, 0])[1] += max(deficiency[j] // 2, 1)
        return [Condition(c.expression, c.joints, c.solutions, m) for c, m in out.values()]

    def _is_unit_circle(self, f) -> bool:
        sp = self.sp
        for j in self.rev:
            if f.as_expr() == sp.expand(1 + self.t[j] ** 2):
                return True
        return False

    def _condition(self, f, degs: dict) -> Condition:
        sp = self.sp
        expr = 0
        joints = tuple(j for j in range(self.n) if (j in degs and degs[j] > 0) or (self.d[j] is not None and f.degree(self.d[j]) > 0))
        half = [j for j in self.rev if degs.get(j, 0) % 2]
        k = len(self.rev)
        for mono, coef in f.terms():
            term = coef
            for i, j in enumerate(self.rev):
                kk, e = mono[i], degs[j]
                if j in half:
                    term = term * sp.tan(self.q[j] / 2) ** kk
                elif kk <= e // 2:
                    term = term * sp.sin(self.q[j]) ** kk * (1 + sp.cos(self.q[j])) ** (e // 2 - kk)
                else:
                    term = term * sp.sin(self.q[j]) ** (e - kk) * (1 - sp.cos(self.q[j])) ** (kk - e // 2)
            for p_i, j in enumerate(j for j in range(self.n) if self.d[j] is not None):
                term = term * self.q[j] ** mono[k + p_i]
            expr = expr + term
        expr = sp.expand(expr)
        expr = _tidy(sp, expr)
        sols = _solve_single(sp, expr, joints, self.q, self.d) if len(joints) == 1 else None
        return Condition(f"{sp.sstr(expr)} = 0", joints, sols)


def _tidy(sp, expr):
    """Shorter trigonometric form when sympy finds one quickly; integer coefficients without a common factor."""
    try:
        simpler = sp.trigsimp(expr)
        if sp.count_ops(simpler) < sp.count_ops(expr):
            expr = simpler
    except Exception:  # noqa: BLE001 - simplification is cosmetic
        pass
    num, _ = sp.fraction(sp.together(expr))
    content, prim = sp.factor_terms(num).as_coeff_Mul()
    return prim if content != 0 else num


def _solve_single(sp, expr, joints, q, d) -> tuple[float, ...]:
    """Values of the single joint in (-180°, 180°] (revolute) or the real roots (prismatic)."""
    j = joints[0]
    x = q[j]
    if d[j] is not None:
        roots = sp.Poly(expr, x).nroots() if sp.Poly(expr, x).degree() > 0 else []
        return tuple(sorted(float(sp.re(r)) for r in roots if abs(sp.im(r)) < 1e-12))
    f = sp.lambdify(x, expr, "numpy")
    grid = np.linspace(-np.pi, np.pi, 7201) + 0.37 * (2 * np.pi / 7200)  # roots at ±180° fall inside
    with np.errstate(all="ignore"):
        v = np.asarray(f(grid), dtype=float) * np.ones_like(grid)
    scale = max(np.nanmax(np.abs(v)), 1e-300)
    found = []
    for i in range(grid.size - 1):
        a, b = v[i], v[i + 1]
        if not (np.isfinite(a) and np.isfinite(b)):
            continue
        if a == 0:
            found.append(grid[i])
        elif a * b < 0:
            lo, hi = grid[i], grid[i + 1]
            for _ in range(80):
                mid = 0.5 * (lo + hi)
                fm = float(f(mid))
                if (fm < 0) == (float(f(lo)) < 0):
                    lo = mid
                else:
                    hi = mid
            found.append(0.5 * (lo + hi))
        elif i > 0 and abs(a) < 1e-9 * scale and abs(a) <= abs(v[i - 1]) and abs(a) <= abs(b):
            found.append(grid[i])  # a double root touching zero
    out: list[float] = []
    for r in found:
        r = float(np.angle(np.exp(1j * r)))
        if r <= -np.pi + 1e-12:
            r = np.pi
        if abs(r) < 1e-12:
            r = 0.0
        if not any(abs(r - o) < 1e-9 for o in out):
            out.append(r)
    return tuple(sorted(out))


def symbolic_conditions(chain: Chain, max_group: int = MAX_GROUP) -> SymbolicResult:
    """Conditions for the singular set: the determinant (n = 6) or the n-minors, and small groups' minors."""
    import sympy as sp

    require_serial(chain)
    n = chain.n
    if n > MAX_JOINTS:
        raise UnsupportedError(f"--symbolic handles arms with at most {MAX_JOINTS} joints; this one has {n}", chain.source)
    J, c, s, d = symbolic_matrix(chain)
    H = _HalfAngle(chain, c, s, d)

    P = [[sp.Poly(J[r, col], *H.gens_cs) for col in range(n)] for r in range(6)]

    memo: dict = {}

    def minor(rows, cols):
        """k × k minor by Laplace expansion along the first column, in polynomial arithmetic (memoised)."""
        if len(cols) == 1:
            return P[rows[0]][cols[0]]
        if (rows, cols) in memo:
            return memo[rows, cols]
        out = sp.Poly(0, *H.gens_cs)
        for i, r in enumerate(rows):
            if not P[r][cols[0]].is_zero:
                term = P[r][cols[0]] * minor(rows[:i] + rows[i + 1 :], cols[1:])
                out = out - term if i % 2 else out + term
        memo[rows, cols] = out
        return out

    def common(minors):
        """Common conditions of several minors (gcd in t), or the status."""
        polys = []
        for M in minors:
            if M.is_zero:
                continue
            if M.total_degree() == 0:
                return "never", []
            p, f = H.to_t(M)
            polys.append((p.clear_denoms(convert=True)[1], f))
        if not polys:
            return "always", []
        polys.sort(key=lambda pf: len(pf[0].terms()))
        g = polys[0][0]
        for p, _ in polys[1:]:
            g = g.gcd(p)
            if g.total_degree() == 0:
                return "system", []
        # the multiplicity of a root at 180° (t_j = ∞) common to every minor
        formal = {j: g.degree(H.t[j]) + min(f[j] - p.degree(H.t[j]) for p, f in polys) for j in H.rev}
        conds = H.conditions(g, formal)
        return ("when" if conds else "system"), conds

    if n == 6:
        what = "det"
        _, conds = common([minor(tuple(range(6)), tuple(range(6)))])
    else:
        what = f"{n}-minors"
        _, conds = common([minor(rows, tuple(range(n))) for rows in combinations(range(6), n)])
    groups: list[GroupCondition] = []
    for k in range(2, min(max_group, n - 1) + 1):
        for S in combinations(range(n), k):
            minors = [minor(rows, tuple(S)) for rows in combinations(range(6), k)]
            status, gc = common(minors)
            implied = any(
                set(g.group) < set(S) and g.status == "when" and {c.expression for c in g.conditions} >= {c.expression for c in gc}
                for g in groups
            )
            if status == "when" and implied:
                continue  # a smaller group already vanishes under the same conditions
            groups.append(GroupCondition(S, len(minors), status, tuple(gc)))
    return SymbolicResult(
        robot=chain.name,
        what=what,
        conditions=tuple(conds),
        groups=tuple(groups),
        exact_geometry=chain.exact is not None,
    )
