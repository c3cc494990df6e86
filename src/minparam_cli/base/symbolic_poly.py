"""Exact numbers of the symbolic route: fractions N / D over Q[lengths, sin/cos of angles, g].

* N is a polynomial kept in normal form modulo sin²θ + cos²θ − 1 for every angle θ (its
  degree in sin θ at most 1).  {sin²θ + cos²θ − 1} is a Gröbner basis (distinct variables),
  so the normal form is unique and N vanishes on the circles exactly when it is the zero
  polynomial: the zero test is exact.
* D is a product of powers of irreducible polynomials from one table (the pivots' factors),
  so sums need no polynomial gcd: the common denominator is the largest power of each factor.
  A factor of a normal form has degree at most 1 in each sin θ, so it does not vanish on
  the circles, and the values are defined at generic geometries.

This is what makes the elimination of ``symbolic_exact`` fast: no gcd per operation (sympy's
rational function field spends nearly all of its time there).
"""

from __future__ import annotations

import heapq
from fractions import Fraction

from minparam_cli.factoring import factor_list


class ExactContext:
    def __init__(self, names: list[str], angle_pairs: list[tuple[str, str]]):
        from sympy import QQ
        from sympy.polys.rings import ring

        R, *gens = ring(",".join(names), QQ) if names else ring("_unused", QQ)
        self.R, self.QQ = R, QQ
        self.gen = dict(zip(names, gens, strict=True))
        self.circle = [self.gen[s] ** 2 + self.gen[c] ** 2 - 1 for s, c in angle_pairs]
        self.sin_index = [names.index(s) for s, _ in angle_pairs]
        self.cos_index = [names.index(c) for _, c in angle_pairs]
        self.factors: list = []
        self.index: dict = {}
        self.one = Frac(self, R.one, {})
        self.zero = Frac(self, R.zero, {})

    def reduce(self, p):
        """Normal form modulo sin² + cos² − 1 (a no-op when no sin appears squared)."""
        if not self.circle or not p:
            return p
        degs = p.degrees()
        if all(degs[i] < 2 for i in self.sin_index):
            return p
        # s^k -> s^(k mod 2)·(1 − c²)^(k div 2), term by term (the same as division by the basis)
        from math import comb

        terms = dict(p.items())
        for si, ci in zip(self.sin_index, self.cos_index, strict=True):
            if degs[si] < 2:
                continue
            out: dict = {}
            for mon, coef in terms.items():
                k = mon[si]
                if k < 2:
                    _accumulate(out, mon, coef)
                    continue
                h = k // 2
                for j in range(h + 1):
                    m = list(mon)
                    m[si] = k % 2
                    m[ci] += 2 * j
                    _accumulate(out, tuple(m), coef * (comb(h, j) if j % 2 == 0 else -comb(h, j)))
            terms = {m: c for m, c in out.items() if c}
        return self.R.from_dict(terms) if terms else self.R.zero

    def const(self, x) -> Frac:
        x = Fraction(x)
        return Frac(self, self.R(self.QQ(x.numerator, x.denominator)), {})

    def var(self, name: str) -> Frac:
        return Frac(self, self.gen[name], {})

    def factor_id(self, f) -> int:
        k = self.index.get(f)
        if k is None:
            k = len(self.factors)
            self.factors.append(f)
            self.index[f] = k
        return k

    def power(self, d: dict):
        p = self.R.one
        for k, e in d.items():
            p = p * self.factors[k] ** e
        return p


class Frac:
    __slots__ = ("ctx", "d", "n")

    def __init__(self, ctx: ExactContext, n, d: dict):
        self.ctx, self.n, self.d = ctx, n, d

    def _coerce(self, o) -> Frac:
        return o if isinstance(o, Frac) else self.ctx.const(o)

    def __bool__(self):
        return bool(self.n)

    def __neg__(self):
        return Frac(self.ctx, -self.n, self.d)

    def __add__(self, o):
        o = self._coerce(o)
        if not o.n:
            return self
        if not self.n:
            return o
        if self.d == o.d:
            return Frac(self.ctx, self.n + o.n, self.d)
        L = dict(self.d)
        for k, e in o.d.items():
            L[k] = max(L.get(k, 0), e)
        ctx = self.ctx
        a = self.n * ctx.power({k: e - self.d.get(k, 0) for k, e in L.items() if e > self.d.get(k, 0)})
        b = o.n * ctx.power({k: e - o.d.get(k, 0) for k, e in L.items() if e > o.d.get(k, 0)})
        return Frac(ctx, ctx.reduce(a + b), L)

    __radd__ = __add__

    def __sub__(self, o):
        return self + (-self._coerce(o))

    def __rsub__(self, o):
        return self._coerce(o) + (-self)

    def __mul__(self, o):
        o = self._coerce(o)
        if not self.n or not o.n:
            return self.ctx.zero
        d = dict(self.d)
        for k, e in o.d.items():
            d[k] = d.get(k, 0) + e
        n = self.n * o.n
        if self.ctx.circle and not (self.n.is_ground or o.n.is_ground):
            n = self.ctx.reduce(n)
        return Frac(self.ctx, n, d)

    __rmul__ = __mul__

    def __truediv__(self, o):
        o = self._coerce(o)
        if not o.n:
            raise ZeroDivisionError("exact division by zero")
        ctx = self.ctx
        n = self.n * ctx.power(o.d)
        if ctx.circle and o.d:
            n = ctx.reduce(n)
        d = dict(self.d)
        if o.n.is_ground:
            return Frac(ctx, n * ctx.QQ(1) / o.n.LC, d)
        coeff, facs = factor_list(o.n)
        n = n * ctx.QQ(1) / ctx.QQ(coeff)
        for f, e in facs:
            if f.LC < 0:
                f, n = -f, -n if e % 2 else n
            for _ in range(e):
                q = exact_quotient(n, f)
                if q is not None:  # cancels against the numerator
                    n = q
                else:
                    k = ctx.factor_id(f)
                    d[k] = d.get(k, 0) + 1
        return Frac(ctx, n, d)

    def __rtruediv__(self, o):
        return self._coerce(o) / self

    def cancelled(self) -> Frac:
        """The same value with every denominator factor that divides the numerator removed."""
        n, d = self.n, dict(self.d)
        for k in list(d):
            f = self.ctx.factors[k]
            while d[k]:
                q = exact_quotient(n, f)
                if q is None:
                    break
                n, d[k] = q, d[k] - 1
            if not d[k]:
                del d[k]
        return Frac(self.ctx, n, d)

    def canonical(self) -> Frac:
        """The same value with a denominator free of sines and reduced: Σ_e (P_e / Q) s^e.

        The ring of the circles A = Q[c, s]/(s² + c² − 1) is not a unique factorisation domain
        (s·s = (1 − c)(1 + c)), so cancelling the irreducible polynomial factors of N and D, as
        ``cancelled`` does, can leave a common factor of N and D in A: a factor a·s + b·(c² − 1)
        is irreducible as a polynomial but is s·(a − b·s) in A.  A is, however, a free module over
        the polynomial ring B = Q[cosines, lengths, g] with basis the products s^e of distinct
        sines (e ∈ {0, 1}^n), so every element of Frac(A) is uniquely Σ_e r_e s^e with r_e in
        Frac(B), a field of fractions of a UFD.  Multiplying N and D by the conjugates of D
        (each sine's sign flipped) makes D a norm in B; dividing by the gcd of D and the
        coefficients P_e of N gives that unique form, so its denominator is determined by the
        value alone (up to a constant), not by how the value was computed."""
        ctx = self.ctx
        if not self.d:
            return self
        n, den = self.n, ctx.power(self.d)
        for si in ctx.sin_index:
            if not den.degrees()[si]:
                continue
            conj = den.ring.from_dict({m: (-c if m[si] % 2 else c) for m, c in den.items()})
            n, den = ctx.reduce(n * conj), ctx.reduce(den * conj)
        parts: dict = {}
        for m, c in n.items():
            parts.setdefault(tuple(m[i] for i in ctx.sin_index), {})[m] = c
        g = den
        for p in parts.values():
            g = g.gcd(ctx.R.from_dict(p))
            if g.is_ground:
                break
        if not g.is_ground:
            n, den = exact_quotient(n, g), exact_quotient(den, g)
        out = Frac(ctx, n, {})
        return out / Frac(ctx, den, {})

    def length(self) -> int:
        """Terms of the numerator and of the denominator's factors (with multiplicity)."""
        return len(self.n.terms()) + sum(len(self.ctx.factors[k].terms()) * e for k, e in self.d.items())

    def shorter_canonical(self) -> Frac:
        """``canonical`` where it is shorter, else the value as it is: a sine-free denominator can
        also be longer (1/(a + s) is (a − s)/(a² − 1 + c²))."""
        c = self.canonical()
        return c if c.length() < self.length() else self

    def size(self, values: dict) -> float:
        """Σ|terms of N| / |D| at {generator name: float}: the scale rounding is measured against."""
        x = [values[s.name] for s in self.ctx.R.symbols]  # str() of a generator goes through sympy's printer
        den = 1.0
        for k, e in self.d.items():
            den *= abs(_float_eval(self.ctx.factors[k], x, False)) ** e
        return _float_eval(self.n, x, True) / den


def _accumulate(terms: dict, mon, coef) -> None:
    """terms[mon] += coef, with no sum with 0 (each rational operation costs: ``reduce`` runs over
    10⁵ terms on a skewed 4-joint arm)."""
    old = terms.get(mon)
    terms[mon] = coef if old is None else old + coef


def exact_quotient(n, f):
    """n / f when f divides n exactly, else None (polynomials of one sympy ring, f nonzero).

    The division algorithm in the ring's lex order with the dividend's terms in a heap: each step
    takes the remainder's leading term once, where sympy's ``div`` searches all remaining terms
    for it (quadratic in the terms: minutes on the 10⁴-term numerators of a skewed arm with a
    prismatic joint).  It stops at the first leading term that the leading monomial of f does not
    divide: then f does not divide n."""
    if not n:
        return n
    lm, lc = f.LM, f.LC
    tail = [(m, c) for m, c in f.items() if m != lm]
    rem = dict(n.items())
    heap = [tuple(-e for e in m) for m in rem]  # max-heap of monomials (lex: tuple order)
    heapq.heapify(heap)
    quotient = {}
    while heap:
        m = tuple(-e for e in heapq.heappop(heap))
        c = rem.pop(m, None)
        if c is None:  # a stale entry: the term cancelled
            continue
        qm = tuple(a - b for a, b in zip(m, lm, strict=True))
        if min(qm) < 0:
            return None
        qc = c / lc
        quotient[qm] = qc
        for fm, fc in tail:
            t = tuple(a + b for a, b in zip(qm, fm, strict=True))
            v = rem.get(t)
            if v is None:
                rem[t] = -qc * fc
                heapq.heappush(heap, tuple(-e for e in t))
            else:
                v = v - qc * fc
                if v:
                    rem[t] = v
                else:
                    del rem[t]
    return n.ring.from_dict(quotient)


def _float_eval(p, x, absolute: bool) -> float:
    """A polynomial's value (or the sum of its terms' absolute values) at floats x."""
    tot = 0.0
    for mon, c in p.terms():
        t = float(c)
        for xi, e in zip(x, mon, strict=True):
            if e:
                t *= xi**e
        tot += abs(t) if absolute else t
    return tot
