"""Base parameters with the robot's geometry as symbols (``derive --symbolic``).

Every nonzero length of the description and every angle offset that is not a
multiple of 90° becomes a symbol (named by ``GeomValue.symbol``); zeros and
right angles stay numbers.  Each regrouping coefficient β of the base set
(base = kept + β · dependent, Gautier & Khalil 1990) is then recovered as an
exact polynomial in those symbols, with cos/sin of symbolic angles.

Method (numeric structure, exact polynomial fit, verification):

1. Generic structure: the kept set of the QR route at two random geometries
   (same symbols, random values).  Both must agree; the file's own set is
   compared with it to detect special geometries (rank drops).
2. β at a geometry: rebuild the chain (``build_chain(desc, values=...)``),
   stack the regressor of seeded random states and solve W_kept β = W_dep
   by least squares for the *fixed* generic kept set.
3. Structure of each coefficient, numerically: which symbols it depends on
   (change one symbol at a time) and its degree in the lengths (scale every
   length by 2: the coefficient maps a parameter of dimension kg·m^p onto one
   of kg·m^r, so it is homogeneous of degree r − p).
4. Least-squares fit over the monomials of that degree in the relevant
   lengths times {1, c, s, c², c·s} per relevant angle (s² = 1 − c²), at
   random geometries; coefficients rounded to small-denominator rationals.
5. Verification at fresh random geometries and at the file's values, relative
   to the size of the evaluated terms (``VERIFY_RTOL``).  If any coefficient
   fails, the set is reported as failed and not printed as formulas.
"""

from __future__ import annotations

import itertools
import time
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from minparam_cli.base.qr import base_from_regressor, chain_scales, sample_rng, stacked_regressor
from minparam_cli.base.result import BaseSet
from minparam_cli.chain import build_chain
from minparam_cli.errors import ComputationError

# URDF files write pi/2 with ~10 digits (ur5.urdf: 1.570796325); closer than this is a right angle
RIGHT_ANGLE_TOL = 1e-8
# a symbolic coefficient must match the numeric beta to this, relative to the size of its terms
VERIFY_RTOL = 1e-9
# fitted coefficients are rationals with denominators up to this
MAX_DENOMINATOR = 720
SYMBOLIC_SEED = 12345
FRESH_POINTS = 5
MAX_LENGTH_DEGREE = 4


@dataclass(frozen=True)
class GeomSymbol:
    name: str
    value: float  # the file's value, SI
    is_angle: bool


@dataclass(frozen=True)
class Monomial:
    """prod lengths**exps · prod over angles of (1, c, s, c², c·s)[code]."""

    length_exps: tuple[int, ...]
    angle_codes: tuple[int, ...]


ANGLE_FACTORS = 5  # 1, c, s, c^2, c*s


def geometry_symbols(desc) -> tuple[tuple[GeomSymbol, ...], dict[str, float]]:
    """Symbols of a description and the right angles pinned to exact multiples of pi/2."""
    syms, pins = [], {}
    for name, g in desc.geometry().items():
        if g.value == 0.0:
            continue
        if g.is_angle:
            k = round(g.value / (np.pi / 2))
            if abs(g.value - k * np.pi / 2) <= RIGHT_ANGLE_TOL:
                pins[name] = k * np.pi / 2
                continue
        syms.append(GeomSymbol(name, float(g.value), bool(g.is_angle)))
    return tuple(syms), pins


class BetaSampler:
    """β of the fixed kept set at any values of the symbols."""

    def __init__(self, desc, chain, symbols, pins, kept, dependent, seed=SYMBOLIC_SEED):
        self.desc, self.symbols, self.pins = desc, symbols, pins
        self.extras = chain.layout.extras
        self.kept, self.dependent = list(kept), list(dependent)
        self.samples = max(2 * -(-chain.layout.size // chain.dof), 20)
        self.seed = seed
        self.calls = 0

    def chain_at(self, x):
        values = dict(self.pins)
        values.update({s.name: float(v) for s, v in zip(self.symbols, x)})
        return build_chain(self.desc, values=values or None, extras=self.extras)

    def regressor_at(self, x):
        return stacked_regressor(self.chain_at(x), self.samples, sample_rng(self.seed))

    def base_at(self, x):
        """The QR route's (kept, K, no effect, margin) at the values x of the symbols."""
        chain = self.chain_at(x)
        W = stacked_regressor(chain, self.samples, sample_rng(self.seed))
        return base_from_regressor(W, self.desc.source, *chain_scales(chain))

    def __call__(self, x) -> np.ndarray:
        self.calls += 1
        W = self.regressor_at(x)
        norms = np.linalg.norm(W[:, self.kept], axis=0)
        Wk = W[:, self.kept] / norms
        sol, *_ = np.linalg.lstsq(Wk, W[:, self.dependent], rcond=None)
        resid = np.linalg.norm(Wk @ sol - W[:, self.dependent]) / max(np.linalg.norm(W[:, self.dependent]), 1e-300)
        if resid > 1e-8:
            raise ComputationError(f"{self.desc.source}: the generic kept set does not span the regressor at a random geometry")
        return sol / norms[:, None]


def random_geometry(symbols, rng: np.random.Generator) -> np.ndarray:
    """Lengths of magnitude 0.5..1.5 with random sign, angles uniform on [-pi, pi)."""
    x = np.empty(len(symbols))
    for i, s in enumerate(symbols):
        x[i] = rng.uniform(-np.pi, np.pi) if s.is_angle else rng.uniform(0.5, 1.5) * rng.choice([-1.0, 1.0])
    return x


def monomial_basis(n_len: int, n_ang: int, degree: int | None) -> list[Monomial]:
    """Monomials of total length degree ``degree`` (all of degree <= 2 if None) times angle factors."""
    degrees = [degree] if degree is not None else [0, 1, 2]
    lens = [e for d in degrees for e in itertools.product(range(d + 1), repeat=n_len) if sum(e) == d]
    angs = list(itertools.product(range(ANGLE_FACTORS), repeat=n_ang))
    return [Monomial(tuple(e), tuple(a)) for e in lens for a in angs]


def evaluate_basis(basis, lengths: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """(N points, n basis) values; lengths (N, n_len), angles (N, n_ang)."""
    c, s = np.cos(angles), np.sin(angles)
    factors = np.stack([np.ones_like(c), c, s, c * c, c * s], axis=-1)  # (N, n_ang, 5)
    out = np.ones((lengths.shape[0], len(basis)))
    for k, m in enumerate(basis):
        for i, e in enumerate(m.length_exps):
            if e:
                out[:, k] *= lengths[:, i] ** e
        for i, a in enumerate(m.angle_codes):
            out[:, k] *= factors[:, i, a]
    return out


@dataclass
class CoefficientFit:
    length_vars: tuple[int, ...]  # indices into symbols
    angle_vars: tuple[int, ...]
    terms: list[tuple[Monomial, Fraction]]

    def evaluate(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(value, sum of |terms|) at points X (N, n_symbols)."""
        if not self.terms:
            z = np.zeros(X.shape[0])
            return z, z
        basis = [m for m, _ in self.terms]
        B = evaluate_basis(basis, X[:, list(self.length_vars)], X[:, list(self.angle_vars)])
        c = np.array([float(f) for _, f in self.terms])
        return B @ c, np.abs(B) @ np.abs(c)


def _structure(sampler, symbols, rng):
    """β at a random point, which symbols each entry depends on, and its length degree."""
    x0 = random_geometry(symbols, rng)
    b0 = sampler(x0)
    scale = 1.0 + np.abs(b0)
    depends = np.zeros(b0.shape + (len(symbols),), dtype=bool)
    nonzero = np.abs(b0) > 1e-10 * scale
    for k in range(len(symbols)):
        x1 = x0.copy()
        x1[k] = random_geometry(symbols[k : k + 1], rng)[0]
        b1 = sampler(x1)
        depends[..., k] = np.abs(b1 - b0) > 1e-9 * (scale + np.abs(b1))
        nonzero |= np.abs(b1) > 1e-10 * (1.0 + np.abs(b1))
    is_len = np.array([not s.is_angle for s in symbols], dtype=bool)
    x2 = np.where(is_len, 2.0 * x0, x0)
    b2 = sampler(x2)
    degree = np.full(b0.shape, -1)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = b2 / b0
    for idx in zip(*np.nonzero(nonzero)):
        r = ratio[idx]
        if np.isfinite(r) and r > 0:
            d = int(round(np.log2(r)))
            if 0 <= d <= MAX_LENGTH_DEGREE and abs(r - 2.0**d) <= 1e-8 * 2.0**d:
                degree[idx] = d
    return nonzero, depends, degree


def fit_coefficients(sampler, symbols, rng) -> tuple[dict, dict]:
    """{(row, col): CoefficientFit} for every generically nonzero β entry, plus fit statistics."""
    nonzero, depends, degree = _structure(sampler, symbols, rng)
    is_ang = [s.is_angle for s in symbols]
    plans = {}
    for idx in zip(*np.nonzero(nonzero)):
        lv = tuple(k for k in range(len(symbols)) if depends[idx][k] and not is_ang[k])
        av = tuple(k for k in range(len(symbols)) if depends[idx][k] and is_ang[k])
        d = int(degree[idx]) if degree[idx] >= 0 else None
        plans[idx] = (lv, av, monomial_basis(len(lv), len(av), d))
    n_max = max((len(p[2]) for p in plans.values()), default=1)
    n_fit = 2 * n_max + 6
    X = np.array([random_geometry(symbols, rng) for _ in range(n_fit)]).reshape(n_fit, len(symbols))
    B = np.array([sampler(x) for x in X])  # (n_fit, rows, cols)
    fits = {}
    for idx, (lv, av, basis) in plans.items():
        A = evaluate_basis(basis, X[:, list(lv)], X[:, list(av)])
        y = B[(slice(None),) + idx]
        c, *_ = np.linalg.lstsq(A, y, rcond=None)
        terms = []
        for m, v in zip(basis, c):
            f = Fraction(float(v)).limit_denominator(MAX_DENOMINATOR)
            if f != 0:
                terms.append((m, f))
        fits[idx] = CoefficientFit(lv, av, terms)
    return fits, {"fit_points": n_fit, "largest_basis": n_max}


def verify(fits, beta_of, X) -> float:
    """Largest error of the fits against numeric β at points X, relative to the size of the terms."""
    worst = 0.0
    B = np.array([beta_of(x) for x in X])
    for idx, fit in fits.items():
        val, size = fit.evaluate(X)
        num = B[(slice(None),) + idx]
        err = np.abs(val - num) / (np.maximum(size, np.abs(num)) + 1e-300)
        worst = max(worst, float(err.max()))
    return worst


def generic_structure(desc, chain, symbols, pins, rng):
    """Kept set, K and no-effect columns at random values of the symbols (checked at two points)."""
    probe = BetaSampler(desc, chain, symbols, pins, [], [])
    out = []
    for _ in range(2):
        kept, K, unident, _ = probe.base_at(random_geometry(symbols, rng))
        out.append((tuple(kept), K, tuple(unident)))
    if out[0][0] != out[1][0] or out[0][2] != out[1][2]:
        raise ComputationError(f"{desc.source}: the base set differs between two random geometries")
    return out[0]


def symbolic_base(desc, chain, base: BaseSet, seed: int = SYMBOLIC_SEED) -> dict:
    """The symbolic regrouping of ``chain``'s base set, as plain data (see ``add_symbolic``)."""
    t0 = time.perf_counter()
    rng = np.random.default_rng(seed)
    symbols, pins = geometry_symbols(desc)
    kept, K, unident = generic_structure(desc, chain, symbols, pins, rng)
    generic = BaseSet(chain.layout.names, kept, K, unident, "qr", {})
    dependent = generic.dependent
    sampler = BetaSampler(desc, chain, symbols, pins, kept, dependent, seed)
    fits, stats = fit_coefficients(sampler, symbols, rng)
    fresh = np.array([random_geometry(symbols, rng) for _ in range(FRESH_POINTS)]).reshape(FRESH_POINTS, len(symbols))
    err_fresh = verify(fits, sampler, fresh)
    x_file = np.array([s.value for s in symbols])
    special = base.n_base != generic.n_base or tuple(base.kept) != tuple(kept)
    err_file = None
    if not special:
        Kf = base.K[:, list(dependent)]
        err_file = verify(fits, lambda x: Kf, x_file[None, :])
    return {
        "symbols": symbols,
        "pins": pins,
        "adjusted": {
            k: (desc.geometry()[k].value, round(np.degrees(v)))
            for k, v in pins.items()
            if abs(desc.geometry()[k].value - v) > 1e-12
        },
        "generic": generic,
        "fits": fits,
        "special": special,
        "verification": {
            "fresh_points": FRESH_POINTS,
            "max_rel_error_fresh": err_fresh,
            "max_rel_error_file": err_file,
            "tolerance": VERIFY_RTOL,
            "passed": err_fresh <= VERIFY_RTOL and (err_file is None or err_file <= VERIFY_RTOL),
            "seed": seed,
            "beta_evaluations": sampler.calls,
            **stats,
        },
        "conditions": special_conditions(sampler, symbols, generic.n_base, rng) if special else [],
        "elapsed_s": time.perf_counter() - t0,
    }


def special_conditions(sampler, symbols, generic_n, rng) -> list[str]:
    """Which of the file's values lower the rank: single symbols, then x = ±y relations."""
    x_file = np.array([s.value for s in symbols])

    def rank_at(x):
        return len(sampler.base_at(x)[0])

    out = []
    for k, s in enumerate(symbols):
        x = random_geometry(symbols, rng)
        x[k] = x_file[k]
        if rank_at(x) < generic_n:
            out.append(f"{s.name} = {s.value:g}")
    for i, j in itertools.combinations(range(len(symbols)), 2):
        if symbols[i].is_angle or symbols[j].is_angle:
            continue
        for sign in (1.0, -1.0):
            if abs(x_file[i] - sign * x_file[j]) <= 1e-12 * abs(x_file[i]):
                x = random_geometry(symbols, rng)
                x[j] = sign * x[i]
                if rank_at(x) < generic_n:
                    out.append(f"{symbols[j].name} = {'-' if sign < 0 else ''}{symbols[i].name}")
    return out


def add_symbolic(report: dict, desc, chain, base: BaseSet) -> dict:
    """A copy of the derive report with the symbolic fields added (see docs/methods/symbolic.md)."""
    from minparam_cli.base.symbolic_render import symbolic_fields

    return symbolic_fields(report, symbolic_base(desc, chain, base))
