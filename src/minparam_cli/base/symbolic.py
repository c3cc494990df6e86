"""Base parameters with the robot's geometry as symbols (``derive --symbolic``).

Every nonzero length of the description and every angle that is not a multiple of 90° is a
symbol (named by ``GeomValue.symbol``); zeros and right angles stay numbers; gravity is the
symbol ``g``.  Each regrouping coefficient β of the base set (base = kept + β · dependent,
Gautier & Khalil 1990) is derived exactly, as an element of the rational function field of
the symbols (docs/methods/symbolic.md):

1. Generic structure: the kept set of the QR route at two random geometries (same symbols,
   random values).  Both must agree; the file's own set is compared with it to detect special
   geometries (rank drops).
2. ``symbolic_exact``: Khalil's regrouping rules generalised to any joint placement (exact by
   construction), exact relations among the columns they leave (exact linear algebra over
   Q(symbols) at rational states), and the change to the kept set of step 1.
3. Check, not method: the expressions are evaluated at fresh random geometries and at the
   file's values and compared with the numeric β of the QR route there (``VERIFY_RTOL``).
"""

from __future__ import annotations

import itertools
import time
from dataclasses import dataclass

import numpy as np

from minparam_cli.base.qr import (
    base_from_regressor,
    chain_scales,
    sample_rng,
    stacked_regressor,
)
from minparam_cli.base.report import Symbolic
from minparam_cli.base.result import BaseSet
from minparam_cli.base.symbolic_urdf import axes_at, symbolic_description
from minparam_cli.chain import build_chain
from minparam_cli.errors import ComputationError

# URDF files write pi/2 with ~10 digits (ur5.urdf: 1.570796325); closer than this is a right angle
RIGHT_ANGLE_TOL = 1e-8
# the exact coefficients must match the numeric beta to this, relative to the size of the evaluated terms
VERIFY_RTOL = 1e-9
# ... and the numeric β of a least-squares solve at a fresh geometry to this: that β is itself only
# accurate to cond(W_kept)·eps (3e-10 seen on a skewed RRPR arm whose identity error is 5e-15), so
# the comparison catches a wrong expression, while the identity above measures to rounding
FORWARD_RTOL = 1e-6
SYMBOLIC_SEED = 12345
FRESH_POINTS = 5


@dataclass(frozen=True)
class GeomSymbol:
    name: str
    value: float  # the file's value, SI
    is_angle: bool


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
        values.update({s.name: float(v) for s, v in zip(self.symbols, x, strict=True)})
        return build_chain(axes_at(self.desc, values), values=values or None, extras=self.extras)

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


def _float_values(fs, rng) -> dict:
    """Random values of the field's symbols: lengths 0.5..1.5 with random sign, angles on [-pi, pi),
    gravity terms 5..15 (sign kept by the symbol's axis sign)."""
    out = {}
    for name in fs.lengths:
        out[name] = rng.uniform(0.5, 1.5) * rng.choice([-1.0, 1.0])
    for name in fs.angles:
        out[name] = rng.uniform(-np.pi, np.pi)
    for name, _, _ in fs.gravity:
        out[name] = rng.uniform(5.0, 15.0) * (np.sign(fs.gravity_values[name]) or 1.0)
    return out


def _rational_values(fs, rng) -> dict:
    """Random rational values: lengths and gravity terms p/q, angles by their half-angle tangent."""
    from fractions import Fraction

    def r(lo, hi):  # wide enough that a special value (0, a right angle, a = ±d) is a rare draw
        x = Fraction(int(rng.integers(lo, hi)), int(rng.integers(1, 98)))
        return x if x not in (0, 1, -1) else Fraction(37, 41)

    out = {name: r(-400, 401) for name in fs.lengths}
    out.update({name: r(-400, 401) for name in fs.angles})
    out.update({name: r(50, 200) for name, _, _ in fs.gravity})
    return out


def exact_forms(desc, chain, symbols, pins, rng, numbers=None):
    """Stages 1 and 2 (``symbolic_exact``): the grouped forms with every exact relation applied,
    independent of the kept set; (forms, arithmetic, field symbols, stats)."""
    from minparam_cli.base.symbolic_exact import Coupled, exact_relations, numeric_relations, stage1
    from minparam_cli.base.symbolic_frames import Arith, field_symbols, joint_transforms

    fs = field_symbols(desc, [s for s in symbols if s.name not in (numbers or {})])
    ar = Arith(fs, pins, numbers=numbers)
    transforms = joint_transforms(desc, ar)
    cols = stage1(desc, chain, ar, transforms)
    plan = Coupled(chain, desc.source)
    far = Arith(fs, pins, _float_values(fs, rng), numbers=numbers)
    _, relations = numeric_relations(desc, chain, cols, far, joint_transforms(desc, far), rng, plan)
    rat = Arith(fs, pins, _rational_values(fs, rng), rational=True, numbers=numbers)
    forms = exact_relations(desc, chain, cols, ar, transforms, relations, rng, rat, joint_transforms(desc, rat), plan)
    stats = {"grouped_columns": len(cols), "relations": len(relations),
             "largest_relation": max((len(v) for v in relations.values()), default=0)}
    return forms, ar, fs, stats


def _generator_values(symbols, gravity_values, x) -> dict:
    out = dict(gravity_values)
    for s, v in zip(symbols, x, strict=True):
        if s.is_angle:
            out[f"sin_{s.name}"], out[f"cos_{s.name}"] = np.sin(v), np.cos(v)
        else:
            out[s.name] = v
    return out


def _evaluator(exprs, symbols, gravity_values):
    """(keys, f): f(*x) gives the printed expressions' values, in the order of keys, at the values x
    of the symbols (gravity at the file's value)."""
    import sympy as sp

    names = [sp.Symbol(s.name) for s in symbols]
    gsubs = {sp.Symbol(k): v for k, v in gravity_values.items()}
    keys = list(exprs)
    return keys, sp.lambdify(names, [exprs[k].subs(gsubs) for k in keys], "math")


def verify(exprs, exact, symbols, gravity_values, beta_of, X, evaluator=None) -> float:
    """Largest error of the printed expressions against numeric β at points X (gravity at the
    file's value), relative to the size of the exact coefficient's terms there (so that a
    coefficient that happens to vanish at a point is measured against its parts); an entry the
    exact set lacks counts as error 1.  ``evaluator``: ``_evaluator``'s result for exprs, if built."""
    keys, f = evaluator or _evaluator(exprs, symbols, gravity_values)
    worst = 0.0
    for x in X:
        B = beta_of(x)
        vals = f(*x)
        gv = _generator_values(symbols, gravity_values, x)
        for k, v in zip(keys, vals, strict=True):
            num = B[k]
            size = max(abs(float(v)), abs(num), exact[k].size(gv))
            worst = max(worst, abs(float(v) - num) / (size + 1e-300))
        nz = np.abs(B) > 1e-9 * (1.0 + np.abs(B).max())
        for idx in zip(*np.nonzero(nz), strict=True):
            if tuple(int(i) for i in idx) not in exprs:
                worst = max(worst, 1.0)
    return worst


def identity_error(exprs, symbols, gravity_values, W_of, kept, dependent, X, evaluator=None) -> float:
    """Largest backward error of the printed β at points X: for each dependent column d,
    ‖W_d − Σ_i β_id W_kept(i)‖ / (‖W_d‖ + Σ_i |β_id| ‖W_kept(i)‖) on the numeric regressor there.

    Unlike the comparison with the QR route's β (whose entries are cut below 1e−10 of the
    normalised scale and rounded to 12 digits, and whose small entries are only as accurate as
    the columns' conditioning allows), this measures whether the expressions regroup the
    regressor, to the rounding of one evaluation: the check used at the file's values, where CAD
    numbers (5.55e−17 m, 1.57079 rad) give true coefficients of 1e−17 or 5e−7."""
    keys, f = evaluator or _evaluator(exprs, symbols, gravity_values)
    worst = 0.0
    for x in X:
        W = W_of(x)
        B = np.zeros((len(kept), len(dependent)))
        for k, v in zip(keys, f(*x), strict=True):
            B[k] = float(v)
        Wk, Wd = W[:, list(kept)], W[:, list(dependent)]
        nk, nd = np.linalg.norm(Wk, axis=0), np.linalg.norm(Wd, axis=0)
        R = np.linalg.norm(Wd - Wk @ B, axis=0)
        scale = nd + np.abs(B).T @ nk
        worst = max(worst, float(np.max(R / np.maximum(scale, 1e-300), initial=0.0)))
    return worst


def symbolic_base(desc, chain, base: BaseSet, seed: int = SYMBOLIC_SEED, numbers: bool = False) -> dict:
    """The symbolic regrouping of ``chain``'s base set, as plain data (see ``add_symbolic``).

    ``numbers``: lengths (and axes with rational components) as the file's exact numbers, only
    angles that have no rational cosine and sine, and gravity, as symbols.

    Raises UnsupportedError (a property of the robot) before any work when the route does not
    apply, ComputationError when the exact relations contradict the numeric structure."""
    from minparam_cli.base.symbolic_frames import refuse_unsupported

    t0 = time.perf_counter()
    desc = symbolic_description(desc, RIGHT_ANGLE_TOL)
    refuse_unsupported(desc, chain)
    from minparam_cli.base.symbolic_coupled import Coupled

    Coupled(chain, desc.source)  # mimic multipliers it cannot draw exact states for: refused before any work
    rng = np.random.default_rng(seed)
    symbols, pins = geometry_symbols(desc)
    exact_nums = None
    if numbers:  # the exact numbers leave the symbols: every random geometry keeps them at the file's values
        from minparam_cli.base.symbolic_frames import shift_symbols
        from minparam_cli.base.symbolic_urdf import exact_numbers

        exact_nums = exact_numbers(desc, symbols, shift_symbols(desc))
        symbols = tuple(s for s in symbols if s.name not in exact_nums)
    kept, K, unident = generic_structure(desc, chain, symbols, pins, rng)
    forms, ar, fs, stats = exact_forms(desc, chain, symbols, pins, rng, exact_nums)
    generic = BaseSet(chain.layout.names, tuple(kept), K, unident, "qr", {})
    if (base.n_base == len(kept) and tuple(base.kept) != tuple(kept)
            and tuple(base.unidentifiable) == tuple(unident)):
        # Same rank, another kept set (the keep rule weighs columns by their size, which gear ratios
        # and the file's lengths change): the file's kept set is independent at the file's values, so
        # its minor is a nonzero polynomial in the symbols and the set is a generic one too; regroup
        # on it, so that the printed set is the file's (the generic one if that fails or does not verify).
        on_file = BaseSet(chain.layout.names, tuple(base.kept), base.K, unident, "qr", {})
        try:
            out = _exact_on(desc, chain, base, on_file, forms, ar, fs, stats, symbols, pins, exact_nums, rng, seed, t0)
            if out["verification"]["passed"]:
                return out
        except ComputationError:
            pass
    return _exact_on(desc, chain, base, generic, forms, ar, fs, stats, symbols, pins, exact_nums, rng, seed, t0)


def _exact_on(desc, chain, base: BaseSet, generic: BaseSet, forms, ar, fs, stats, symbols, pins, exact_nums, rng, seed,
              t0) -> dict:
    """Stage 3 on the kept set of ``generic`` (its K: the numeric regrouping, for the names) and the
    verification (``symbolic_base``)."""
    from minparam_cli.base.symbolic_exact import regrouping
    from minparam_cli.base.symbolic_render import field_to_sympy

    kept, dependent = generic.kept, generic.dependent
    coef = regrouping(forms, kept, dependent, generic.unidentifiable, ar, desc.source)
    exprs = {idx: field_to_sympy(v, fs) for idx, v in coef.items()}
    t_exact = time.perf_counter() - t0
    sampler = BetaSampler(desc, chain, symbols, pins, kept, dependent, seed)
    fresh = np.array([random_geometry(symbols, rng) for _ in range(FRESH_POINTS)]).reshape(FRESH_POINTS, len(symbols))
    # one evaluator for the three checks: substituting g into and lambdifying 10³-term expressions
    # takes 20 s each on a skewed RPRR arm
    ev = _evaluator(exprs, symbols, fs.gravity_values)
    err_fresh = verify(exprs, coef, symbols, fs.gravity_values, sampler, fresh, ev)
    x_file = np.array([s.value for s in symbols])
    special = base.n_base != generic.n_base or tuple(base.kept) != tuple(kept)
    err_file = None
    err_identity = identity_error(exprs, symbols, fs.gravity_values, sampler.regressor_at, kept, dependent, fresh, ev)
    if not special:  # the file's (right angles pinned) regressor, regrouped by the printed β
        err_file = identity_error(exprs, symbols, fs.gravity_values, sampler.regressor_at, kept, dependent, x_file[None, :], ev)
    gravity = {k: v for k, v in fs.gravity_values.items()}
    return {
        "symbols": symbols,
        "gravity": gravity,
        "pins": pins,
        "shifts": fs.shifts,
        "numbers": sorted(exact_nums or ()),
        "adjusted": {
            k: (desc.geometry()[k].value, round(np.degrees(v)))
            for k, v in pins.items()
            if abs(desc.geometry()[k].value - v) > 1e-12
        },
        "generic": generic,
        "coefficients": exprs,
        "exact": coef,
        "special": special,
        "verification": {
            "method": "exact",
            "fresh_points": FRESH_POINTS,
            "max_rel_error_fresh": float(err_fresh),
            "max_identity_error_fresh": float(err_identity),
            "max_rel_error_file": None if err_file is None else float(err_file),
            "file_check": "regressor identity",
            "tolerance": VERIFY_RTOL,
            "forward_tolerance": FORWARD_RTOL,
            "passed": bool(err_fresh <= FORWARD_RTOL and err_identity <= VERIFY_RTOL
                           and (err_file is None or err_file <= VERIFY_RTOL)),
            "seed": seed,
            "exact_s": round(t_exact, 6),
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


def add_symbolic(desc, chain, base: BaseSet, numbers: bool = False) -> Symbolic:
    """The symbolic set of a derived base set (see docs/methods/symbolic.md): the report's symbolic
    fields, or why there is none."""
    from minparam_cli.base.symbolic_render import refused_fields, symbolic_fields
    from minparam_cli.errors import UnsupportedError

    t0 = time.perf_counter()
    try:
        result = symbolic_base(desc, chain, base, numbers=numbers)
    except (UnsupportedError, ComputationError) as exc:
        return refused_fields(str(exc), time.perf_counter() - t0)
    return symbolic_fields(chain.name, base.n_base, result)
