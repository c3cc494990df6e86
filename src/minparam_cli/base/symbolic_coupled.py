"""Exact test states for joints that move together (URDF mimic joints, q_d = k·q_m + o) on the
exact symbolic route (``base/symbolic_exact.py``, docs/methods/symbolic.md, "Mimic joints").

A driven joint's angle is k times its master's: its cos/sin are not rational functions of the
master's unless k is an integer.  ``Coupled`` writes the driven angles θ = M·φ with an integer
matrix M built from the exact collisions of the multipliers (integer vectors δ with Σ δ_j k_j = 0),
so that every state it draws is a rational point for all joints at once and every energy
function the relations use takes exactly the value it has on the robot.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np

from minparam_cli.base.symbolic_frames import Arith
from minparam_cli.chain import PRISMATIC


class Coupled:
    """How every joint's state follows the independent coordinates (mimic joints: q_j = k_j q_m(j),
    the offset moved into the joint's fixed transform by ``joint_transforms``).

    Float states (the structure decision) follow the constraint itself.  Exact states use, per
    master coordinate, one rational value u for every polynomial occurrence (q_j = k_j u: prismatic
    positions, offset columns), and angles θ_j = Σ_l M_jl φ_l of its revolute joints (k_j ≠ 0) with
    φ_l independent rational points of the circle and M an integer matrix: cos and sin of θ_j are
    products of integer powers of (cos φ_l + i sin φ_l), exact.  Every energy coefficient has
    frequency at most 2 in each joint angle and is a polynomial in the prismatic positions, so a
    relation holds on the constraint exactly when it holds at these states if, for every integer
    δ ∈ [−4, 4]^m, Σ δ_j k_j = 0 ⟺ Mᵀδ = 0 (two modes a, b of [−2, 2]^m then merge on the
    constraint exactly when they merge in φ).  M spans the orthogonal complement of the
    collisions C = {δ : Σ δ_j k_j = 0}: then δ ∈ C gives Mᵀδ = 0, and Mᵀδ = 0 puts δ in the span
    of C, where Σ δ_j k_j = 0 (docs/methods/symbolic.md, mimic joints).  No collision: M = I (the
    angles free); k = (1, 2): M = (1, 2)ᵀ, one angle and its double."""

    def __init__(self, chain, source: str):
        n = chain.n
        self.master = list(range(n))
        self.k = [Fraction(1)] * n
        if chain.coupling is not None:
            G, coords = chain.coupling.G, chain.coupling.coordinates
            for j in range(n):
                i = int(np.flatnonzero(G[j])[0]) if np.any(G[j]) else None
                self.master[j] = coords[i] if i is not None else j
                self.k[j] = Fraction(repr(float(G[j, i]))) if i is not None else Fraction(0)
        self.revolute = [t != PRISMATIC for t in chain.types]
        self.lattice: dict[int, tuple[list[int], list[list[int]]]] = {}
        for m in sorted(set(self.master)):
            joints = [j for j in range(n) if self.master[j] == m and self.revolute[j] and self.k[j]]
            if len(joints) < 2:
                continue
            if len(joints) > MAX_COUPLED:  # the box search is 9^m vectors: take the constraint itself
                self.lattice[m] = (joints, _constraint_column([self.k[j] for j in joints]))
                continue
            C = _collisions([self.k[j] for j in joints])
            if C:
                self.lattice[m] = (joints, _complement(C, len(joints)))

    def float_state(self, rng):
        n = len(self.master)
        x = [rng.uniform(-np.pi, np.pi) if self.revolute[j] else rng.uniform(-1, 1) for j in range(n)]
        v = list(rng.uniform(-1, 1, n))
        x = [float(self.k[j]) * x[self.master[j]] for j in range(n)]
        v = [float(self.k[j]) * v[self.master[j]] for j in range(n)]
        return list(np.cos(x)), list(np.sin(x)), x, v

    def rational_state(self, rng, ar: Arith):
        """cos/sin from t ↦ ((1−t²)/(1+t²), 2t/(1+t²)) at rational t; rational q, q̇."""

        def r():
            return Fraction(int(rng.integers(-12, 13)), int(rng.integers(1, 12)))

        def circle():
            t = r()
            return (1 - t * t) / (1 + t * t), 2 * t / (1 + t * t)

        n = len(self.master)
        u, v = [r() for _ in range(n)], [r() for _ in range(n)]
        point: dict = {}
        for joints, lat in self.lattice.values():
            phis = [circle() for _ in lat[0]]
            for j, row in zip(joints, lat, strict=True):
                c, s = Fraction(1), Fraction(0)
                for (pc, ps), e in zip(phis, row, strict=True):
                    ec, es = _multiple_angle((pc, ps), e)
                    c, s = c * ec - s * es, c * es + s * ec
                point[j] = (c, s)
        cq, sq = [], []
        for j in range(n):
            if not self.k[j]:
                c, s = Fraction(1), Fraction(0)
            else:
                c, s = point.get(j) or circle()
            cq.append(ar.const(c))
            sq.append(ar.const(s))
        q = [ar.const(self.k[j] * u[self.master[j]]) for j in range(n)]
        qd = [ar.const(self.k[j] * v[self.master[j]]) for j in range(n)]
        return cq, sq, q, qd


MAX_COUPLED = 7  # revolute joints moved by one coordinate for the collision search (9^m vectors)


def _constraint_column(ks) -> list[list[int]]:
    """M = K / gcd(K) with K_j = k_j·D integers (D the common denominator): θ_j = K_j φ is the mimic
    constraint θ_j = k_j q itself (q = D φ / gcd), so Σ δ_j k_j = 0 ⟺ Mᵀδ = 0 for every integer δ.
    Exact for any number of joints; the angles are all multiples of one circle point, which makes the
    rationals larger than the collision search's M (used up to MAX_COUPLED joints)."""
    D = math.lcm(*(k.denominator for k in ks))
    K = [int(k * D) for k in ks]
    g = math.gcd(*K)
    return [[x // g] for x in K]


def _collisions(ks) -> list[tuple[int, ...]]:
    """Nonzero integer δ ∈ [−4, 4]^m with Σ δ_j k_j = 0 (exactly: k_j = K_j / D, integers)."""
    import itertools

    D = math.lcm(*(k.denominator for k in ks))
    K = np.array([int(k * D) for k in ks], dtype=object)
    out = []
    for delta in itertools.product(range(-4, 5), repeat=len(ks) - 1):
        # the last component is fixed by the others when it exists: δ_m = −Σ δ_j K_j / K_m
        rest = -sum(d * x for d, x in zip(delta, K[:-1], strict=True))
        if rest % K[-1] == 0 and abs(rest // K[-1]) <= 4:
            full = (*delta, int(rest // K[-1]))
            if any(full):
                out.append(full)
    return out


def _complement(C, m: int) -> list[list[int]]:
    """An integer m x L matrix whose columns span the vectors orthogonal to every δ of C."""
    import sympy as sp

    basis = sp.Matrix(C).nullspace()
    cols = []
    for b in basis:
        scale = math.lcm(*(int(sp.fraction(x)[1]) for x in b))
        cols.append([int(x * scale) for x in b])
    return [[c[j] for c in cols] for j in range(m)]


def _multiple_angle(point, p: int):
    """(cos pt, sin pt) from (cos t, sin t), exactly."""
    c, s = point
    if p < 0:
        c, s, p = c, -s, -p
    rc, rs = Fraction(1), Fraction(0)
    for _ in range(p):
        rc, rs = rc * c - rs * s, rc * s + rs * c
    return rc, rs
