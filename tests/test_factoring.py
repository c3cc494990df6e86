"""sympy's factorisation (minparam_cli.factoring): its random evaluation points come from a seeded
generator, the caller's generator is left as it was, and the factors are sympy's own."""

from __future__ import annotations

import random

import sympy as sp
from sympy.core import random as sympy_random
from sympy.polys import factortools

from minparam_cli.factoring import FACTOR_SEED, factor_list

x, y, z = sp.symbols("x y z")
# multivariate and reducible, so that sympy goes through Wang's algorithm and its random points
POLY = sp.Poly(sp.expand((x * y + z**2 + 3) * (x**2 - y * z + 2 * x) * (x + y + z + 1)), x, y, z)


def test_factors_are_sympys():
    assert factor_list(POLY) == POLY.factor_list()
    R, a, b = sp.ring("a,b", sp.ZZ)
    p = (a**2 + b + 1) * (a * b - 2)
    assert factor_list(p) == p.factor_list()


def test_wangs_points_come_from_the_seeded_generator_and_the_callers_state_is_kept(monkeypatch):
    seen = []
    real = factortools.dmp_zz_wang

    def spy(*args, **kwargs):
        seen.append(sympy_random.rng.getstate())
        return real(*args, **kwargs)

    monkeypatch.setattr(factortools, "dmp_zz_wang", spy)
    sympy_random.rng.seed(12345)
    sympy_random.rng.random()
    before = sympy_random.rng.getstate()
    factor_list(POLY)
    assert seen and seen[0] == random.Random(FACTOR_SEED).getstate()
    assert sympy_random.rng.getstate() == before
    seen.clear()
    POLY.factor_list()  # sympy's own call draws from wherever its generator stands
    assert seen and seen[0] != random.Random(FACTOR_SEED).getstate()
