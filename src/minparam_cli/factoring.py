"""sympy's factorisation into irreducible factors, with its random choices seeded.

sympy factors a multivariate polynomial by Wang's algorithm, which evaluates it at random integer
points drawn from sympy's global generator (``sympy.core.random.rng``, seeded from the system's
entropy when sympy is imported). The factors do not depend on the points; the time does, with a
long tail: ``derive --symbolic benchmarks/data/symbolic/skew_rprrrr_mdh.yaml`` took 1.7-2.9 s in
17 runs, 63 s in one and 267 s in another. Every factorisation here starts from the generator
seeded with ``FACTOR_SEED``, so that a given polynomial takes the same time on every run (1.5 s
for that arm), and the generator's state is put back after, so that a caller's own sympy draws
are not changed. Not thread-safe (the generator is sympy's global one); nothing here factors
from two threads."""

from __future__ import annotations

FACTOR_SEED = 0


def factor_list(poly):
    """``poly.factor_list()`` (a sympy Poly or a sparse-ring PolyElement) with sympy's generator seeded."""
    from sympy.core import random as sympy_random

    state = sympy_random.rng.getstate()
    sympy_random.rng.seed(FACTOR_SEED)
    try:
        return poly.factor_list()
    finally:
        sympy_random.rng.setstate(state)
