"""Exact symbolic regrouping (issue 18): robots the fitted ansatz refused, compared with the numeric
QR route at random geometries (and random gravity) to 1e-12 relative."""

from __future__ import annotations

import re
from dataclasses import replace

import numpy as np
import pytest
import sympy as sp

from minparam_cli.base.qr import derive_qr, sample_rng, stacked_regressor
from minparam_cli.base.symbolic import RIGHT_ANGLE_TOL, geometry_symbols
from minparam_cli.base.symbolic_urdf import axes_at, symbolic_description
from minparam_cli.chain import build_chain
from minparam_cli.robot import load_chain
from minparam_cli.api.derivation import derive_file as _derive_file
from minparam_cli.api.options.derive import DeriveOptions


def derive_file(path, opts):
    """The derive JSON of one robot file (the API's base set, as a dict)."""
    return _derive_file(path, opts).to_dict()


RTOL = 1e-12  # the identity W_dep = W_kept·β at the numeric regressor (rounding: ~1e-15)
BETA_RTOL = 1e-9  # against the QR route's β (its own accuracy at skewed geometries: ~1e-11)

SKEW_DH = """\
name: skew DH 4R (twists 60, -45, 30 deg)
convention: dh
units: {length: m, angle: deg}
gravity: [0, 0, -9.81]
joints:
  - {name: j1, type: revolute, alpha: 60, a: 0.1, d: 0.3, theta: 0}
  - {name: j2, type: revolute, alpha: -45, a: 0.4, d: 0.05, theta: 10}
  - {name: j3, type: revolute, alpha: 30, a: 0.3, d: -0.1, theta: 0}
  - {name: j4, type: revolute, alpha: 90, a: 0.1, d: 0.2, theta: 0}
"""

SKEW_MDH_PRISMATIC = """\
name: skew MDH RRPR (skewed twist before a prismatic joint)
convention: mdh
units: {length: m, angle: deg}
gravity: [0, 0, -9.81]
joints:
  - {name: j1, type: revolute, alpha: 0, a: 0, d: 0.3, theta: 0}
  - {name: j2, type: revolute, alpha: 60, a: 0.2, d: 0.1, theta: 0}
  - {name: j3, type: prismatic, alpha: -45, a: 0.3, d: 0, theta: 30}
  - {name: j4, type: revolute, alpha: 90, a: 0.1, d: 0.2, theta: 0}
"""

TWO_PRISMATIC = """\
name: two consecutive prismatic joints (first slide vertical)
convention: dh
units: {length: m, angle: deg}
gravity: [0, 0, -9.81]
joints:
  - {name: lift, type: prismatic, alpha: -90, a: 0.1, d: 0, theta: 0}
  - {name: reach, type: prismatic, alpha: 90, a: 0.05, d: 0, theta: 90}
  - {name: wrist, type: revolute, alpha: 0, a: 0.2, d: 0.1, theta: 0}
"""

ARM7 = """\
name: 7R arm with theta offsets and parallel axes 2-3-4
convention: mdh
units: {length: m, angle: deg}
gravity: [0, 0, -9.80665]
joints:
  - {name: j1, type: revolute, alpha: 0, a: 0, d: 0.333, theta: 15}
  - {name: j2, type: revolute, alpha: -90, a: 0, d: 0.05, theta: -20}
  - {name: j3, type: revolute, alpha: 0, a: 0.4, d: 0, theta: 0}
  - {name: j4, type: revolute, alpha: 0, a: 0.35, d: 0.1, theta: 35}
  - {name: j5, type: revolute, alpha: -90, a: 0.0825, d: 0.384, theta: 0}
  - {name: j6, type: revolute, alpha: 90, a: 0, d: 0, theta: 10}
  - {name: j7, type: revolute, alpha: 90, a: 0.088, d: 0.1, theta: 0}
"""


def _file(tmp_path, text):
    p = tmp_path / "robot.yaml"
    p.write_text(text)
    return p


def symbolic_coefficients(report) -> dict[tuple[str, str], sp.Expr]:
    """{(base name, standard name): coefficient} from the 'symbolic' strings (linear: d/dparam)."""
    out = {}
    for b in report["base_parameters"]:
        e = sp.sympify(b["symbolic"])
        for t in report["standard_parameters"]:
            P = sp.Symbol(t)
            if e.has(P):
                out[b["name"], t] = sp.diff(e, P)
    return out


def unmark(name: str) -> str:
    """'XXR2' -> 'XX2' (the R says the parameter is regrouped)."""
    return re.sub(r"R(\d+)$", r"\1", name)


def compare_with_numeric(path, opts, n_geometries=2, seed=18, file_kept=False):
    """At random geometries and random gravity magnitudes: (1) the numeric QR route keeps the same
    parameters; (2) the symbolic β, evaluated there, annihilates the numeric regressor:
    W_dep − W_kept·β = 0 to rounding, relative to the columns' sizes; (3) it equals the QR
    route's β to that route's own accuracy.  Returns (report, coefficients, worst of (2), worst of (3))."""
    report = derive_file(path, opts)
    assert report["symbolic_verification"]["passed"], report.get("symbolic_notes")
    assert "symbolic_generic" not in report
    coef = symbolic_coefficients(report)
    desc, chain = load_chain(path, opts)
    desc = symbolic_description(desc, RIGHT_ANGLE_TOL)  # URDF: lumped fixed joints and oblique axes as symbols
    symbols, pins = geometry_symbols(desc)
    symbols = [s for s in symbols if s.name in report["symbols"]]  # --symbolic-numbers: the rest at the file's values
    g_file = float(np.linalg.norm(chain.gravity))
    names = list(report["standard_parameters"])
    keys = list(coef)
    f = sp.lambdify([sp.Symbol(s.name) for s in symbols] + [sp.Symbol("g")], [coef[k] for k in keys], "math")
    rng = np.random.default_rng(seed)
    worst_identity = worst_beta = 0.0
    for _ in range(n_geometries):
        values = {s.name: (rng.uniform(-np.pi, np.pi) if s.is_angle else rng.uniform(0.3, 1.5) * rng.choice([-1, 1])) for s in symbols}
        g = rng.uniform(3.0, 20.0)
        other = build_chain(axes_at(desc, {**pins, **values}), values={**pins, **values}, extras=chain.layout.extras)
        other = replace(other, gravity=chain.gravity * (g / g_file))
        num = derive_qr(other, seed=int(rng.integers(1 << 30)))
        if file_kept:  # the report regroups on the file's kept set: the QR β of that set at this geometry
            num = _on_kept(num, [names.index(unmark(b["name"])) for b in report["base_parameters"]],
                           stacked_regressor(other, 60, sample_rng(int(rng.integers(1 << 30)))))
        # the same kept parameters (a name gains or loses its R where a coefficient is exactly 0 or,
        # as with CAD numbers of 1e-17, below the numeric route's cut at the file's values)
        report_names = [b["name"] for b in report["base_parameters"]]
        assert [unmark(n) for n in num.base_names] == [unmark(n) for n in report_names]
        got = dict(zip(keys, (float(v) for v in f(*[values[s.name] for s in symbols], g)), strict=True))
        W = stacked_regressor(other, 60, sample_rng(int(rng.integers(1 << 30))))
        norms = np.linalg.norm(W, axis=0)
        for i, name in enumerate(report_names):
            terms = num.terms[i]
            for t in set(terms) | {t for (bn, t) in coef if bn == name}:
                want, have = terms.get(t, 0.0), got.get((name, t), 0.0)
                worst_beta = max(worst_beta, abs(have - want) / max(abs(have), abs(want)))
        kept = [names[k] for k in num.kept]
        for d in num.dependent:
            beta = np.array([got.get((bn, names[d]), 0.0) for bn in report_names])
            r = W[:, d] - W[:, list(num.kept)] @ beta
            scale = norms[d] + np.abs(beta) @ norms[list(num.kept)]
            worst_identity = max(worst_identity, float(np.linalg.norm(r) / scale))
        assert kept
    return report, coef, worst_identity, worst_beta


def _on_kept(num, kept, W):
    """The numeric base set ``num`` re-expressed on another kept set of the same rank (least squares
    on the unit-scaled kept columns of W)."""
    from minparam_cli.base.result import BaseSet

    dropped = [c for c in range(W.shape[1]) if c not in set(kept) and c not in set(num.unidentifiable)]
    norms = np.linalg.norm(W, axis=0)
    Wk = W[:, kept] / norms[kept]
    beta, *_ = np.linalg.lstsq(Wk, W[:, dropped] / norms[dropped], rcond=None)
    beta[np.abs(beta) < 1e-10] = 0.0  # the QR route's cut of rounding-level entries (unit columns)
    beta = beta * norms[dropped] / norms[kept][:, None]
    P = W.shape[1]
    K = np.zeros((len(kept), P))
    for i, k in enumerate(kept):
        K[i, k] = 1.0
        K[i, dropped] = beta[i]
    return BaseSet(num.standard_names, tuple(kept), K, tuple(num.unidentifiable), "qr", {})


def test_skewed_dh_twists(tmp_path):
    # alpha = 60, -45, 30 deg: coefficients such as cot(alpha1) and 1/sin²(alpha2), which the
    # trigonometric-polynomial ansatz could not represent
    report, coef, worst, worst_beta = compare_with_numeric(_file(tmp_path, SKEW_DH), DeriveOptions(symbolic=True))
    assert worst <= RTOL and worst_beta <= BETA_RTOL, (worst, worst_beta)
    c = coef["YYR1", "YZ1"]
    a1 = sp.Symbol("alpha1")
    assert sp.simplify(c - 2 * sp.cos(a1) / sp.sin(a1)) == 0  # 2·cot(alpha1), exactly
    assert not any("theta2" in b["symbolic"] for b in report["base_parameters"])  # a shift of q2
    assert not any("tan" in b["symbolic"] or "cot" in b["symbolic"] for b in report["base_parameters"])  # sin/cos quotients
    from matplotlib.mathtext import MathTextParser

    parser = MathTextParser("agg")
    for b in report["base_parameters"]:
        parser.parse(f"${b['symbolic_latex']}$")


def test_skewed_mdh_twist_before_prismatic(tmp_path):
    _report, coef, worst, worst_beta = compare_with_numeric(_file(tmp_path, SKEW_MDH_PRISMATIC), DeriveOptions(symbolic=True))
    assert worst <= RTOL and worst_beta <= BETA_RTOL, (worst, worst_beta)
    names = {str(s) for c in coef.values() for s in c.free_symbols}
    assert {"alpha3", "theta3"} <= names  # theta of a prismatic joint is geometry, not a shift


def test_prismatic_along_gravity_with_offset_needs_one_over_g():
    opts = DeriveOptions(symbolic=True, friction=("offset",), rotor_inertia=True)
    report, coef, worst, worst_beta = compare_with_numeric("robots/universal15_glazunov.yaml", opts)
    assert worst <= RTOL and worst_beta <= BETA_RTOL, (worst, worst_beta)
    g = sp.Symbol("g")
    assert report["symbols"]["g"] == pytest.approx(9.81)
    # slide 1 is vertical: its offset and the weight of everything it carries are one column
    assert sp.simplify(coef["MR1", "OFF1"] - 1 / g) == 0
    assert sp.simplify(coef["IaR1", "OFF1"] + 1 / g) == 0


def test_two_consecutive_prismatic_joints(tmp_path):
    opts = DeriveOptions(symbolic=True, friction=("offset",), rotor_inertia=True)
    report, _coef, worst, worst_beta = compare_with_numeric(_file(tmp_path, TWO_PRISMATIC), opts)
    assert worst <= RTOL and worst_beta <= BETA_RTOL, (worst, worst_beta)
    assert report["n_base"] == 8


def test_seven_joint_arm_with_theta_offsets_and_parallel_axes(tmp_path):
    opts = DeriveOptions(symbolic=True, friction=("viscous", "offset"), rotor_inertia=True)
    report, _coef, worst, worst_beta = compare_with_numeric(_file(tmp_path, ARM7), opts)
    assert worst <= RTOL and worst_beta <= BETA_RTOL, (worst, worst_beta)
    assert not any(f"theta{k}" in b["symbolic"] for b in report["base_parameters"] for k in (1, 2, 4, 6))
    assert any("only shift" in n for n in report["symbolic_notes"])


def test_panda(tmp_path):
    report, _coef, worst, worst_beta = compare_with_numeric("robots/panda.yaml", DeriveOptions(symbolic=True))
    assert worst <= RTOL and worst_beta <= BETA_RTOL, (worst, worst_beta)
    assert report["n_base"] == 43


def _link(name, m=1.0):
    return (f'<link name="{name}"><inertial><origin xyz="0.01 0.02 0.03"/><mass value="{m}"/>'
            f'<inertia ixx="0.1" ixy="0.01" ixz="0" iyy="0.12" iyz="0" izz="0.09"/></inertial></link>')


def _joint(name, kind, parent, child, xyz="0 0 0", rpy="0 0 0", axis=None):
    ax = "" if axis is None else f'<axis xyz="{axis}"/>'
    lim = "" if kind == "fixed" else '<limit lower="-3" upper="3" effort="1" velocity="1"/>'
    return (f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
            f'<origin xyz="{xyz}" rpy="{rpy}"/>{ax}{lim}</joint>')


# oblique axes (one in a coordinate plane: one angle symbol; one general: two), a prismatic
# joint on an oblique axis, and moving joints after lumped fixed joints (a flange turned by
# π/2 written with 10 digits, and a fixed joint with a skew rotation)
URDF_OBLIQUE_FIXED = "\n".join([
    '<robot name="oblique and fixed">', '<link name="base"/>', _link("l1"), _link("l2"), _link("l3"),
    _link("flange", 0.3), _link("tilt", 0.2), _link("l4"), _link("l5"),
    _joint("j1", "revolute", "base", "l1", "0 0 0.3", axis="0 0 1"),
    _joint("j2", "revolute", "l1", "l2", "0.3 0 0.2", axis="0.6 0.8 0"),
    _joint("j3", "prismatic", "l2", "l3", "0.1 0.2 0", "0 0.4 0", axis="1 2 2"),
    _joint("fix1", "fixed", "l3", "flange", "0 0 0.15", "1.5707963268 0 0"),
    _joint("fix2", "fixed", "flange", "tilt", "0.05 0 0", "0.3 0 -0.2"),
    _joint("j4", "revolute", "tilt", "l4", "0 0.1 0.1", axis="0 1 0"),
    _joint("fix3", "fixed", "l4", "l4b", "0.02 0 0", "0 0 1.57079632679"), _link("l4b", 0.1),
    _joint("j5", "revolute", "l4b", "l5", "0 0 0.12", axis="1 0 0"),
    "</robot>", ""])


def test_urdf_oblique_axes_and_joints_after_fixed_joints(tmp_path):
    p = tmp_path / "oblique_fixed.urdf"
    p.write_text(URDF_OBLIQUE_FIXED)
    opts = DeriveOptions(symbolic=True, friction=("viscous",), rotor_inertia=True)
    report, coef, worst, worst_beta = compare_with_numeric(p, opts, n_geometries=2)
    assert worst <= RTOL and worst_beta <= BETA_RTOL, (worst, worst_beta)
    names = {str(s) for c in coef.values() for s in c.free_symbols}
    # (0.6, 0.8, 0) lies in the xy plane: its polar angle is a right angle, its azimuth a symbol
    assert "j2_axis_phi" in report["symbols"] and "j2_axis_theta" not in report["symbols"]
    assert {"j3_axis_theta", "j3_axis_phi"} <= set(report["symbols"])
    assert report["symbols"]["j2_axis_phi"] == pytest.approx(np.arctan2(0.8, 0.6), abs=1e-15)
    # j4 after fix1 and fix2: one rigid transform in j4's origin symbols (fix1's π/2 a number)
    assert any(n.startswith("j4_") for n in names)
    assert "j4_roll" in report["symbols"] and "j5_yaw" not in report["symbols"]
    assert not any("symbolic_generic" in k for k in report)


def test_oblique_axis_file_is_no_longer_refused():
    r = derive_file("benchmarks/data/symbolic/oblique_axis.urdf", DeriveOptions(symbolic=True))
    assert r["symbolic_verification"]["passed"], r.get("symbolic_notes")
    assert all("symbolic" in b for b in r["base_parameters"])
    assert any("j2_axis_phi" in b["symbolic"] for b in r["base_parameters"])


def test_symbolic_numbers_keep_the_files_exact_lengths_and_rational_axes(tmp_path):
    # --symbolic-numbers: lengths are the file's decimals, an axis with rational components gives
    # rational cos/sin; only other angles and g stay symbols
    from fractions import Fraction

    opts = DeriveOptions(symbolic_numbers=True)
    report, coef, worst, worst_beta = compare_with_numeric("robots/puma560.yaml", opts, n_geometries=1)
    assert worst <= RTOL and worst_beta <= BETA_RTOL, (worst, worst_beta)
    assert set(report["symbols"]) == {"g"} and set(report["symbolic_numbers"]) == {"a2", "a3", "d2", "d4", "d6"}
    a2 = Fraction("0.4318")
    assert coef["XXR2", "M2"] == sp.Rational(a2.numerator, a2.denominator) ** 2  # a2², exactly
    p = tmp_path / "oblique_fixed.urdf"
    p.write_text(URDF_OBLIQUE_FIXED)
    report, coef, worst, worst_beta = compare_with_numeric(p, DeriveOptions(symbolic_numbers=True), n_geometries=1)
    assert worst <= RTOL and worst_beta <= BETA_RTOL, (worst, worst_beta)
    assert coef["MXR2", "MY2"] == sp.Rational(-3, 4)  # -cot(phi) of the axis (0.6, 0.8, 0), exactly
    # (1 2 2)/3 has sin(theta) = sqrt(5)/3: not rational, so j3's axis angles stay symbols;
    # j4's origin is composed with a fixed rotation by 0.3 rad: irrational, symbols too
    assert {"j3_axis_theta", "j3_axis_phi", "j4_x", "j3_pitch"} <= set(report["symbols"])
    assert {"j2_axis_phi", "j2_x", "j5_x", "j5_z"} <= set(report["symbolic_numbers"])


def test_file_values_reproduce_the_reported_numeric_terms():
    # The exact coefficients are rational functions; at the file's values they must reproduce the
    # numeric β of derive itself (already in the report) to rounding.
    r = derive_file("robots/stanford.yaml", DeriveOptions(symbolic=True))
    coef = symbolic_coefficients(r)
    subs = {sp.Symbol(k): v for k, v in r["symbols"].items()}
    for b in r["base_parameters"]:
        assert {t for (bn, t) in coef if bn == b["name"]} == set(b["terms"]), b["name"]
        for t, want in b["terms"].items():
            got = float(coef[b["name"], t].subs(subs))
            assert got == pytest.approx(want, rel=1e-12, abs=1e-14), (b["name"], t)


def test_exact_numbers_normal_form_and_zero_test():
    # the term-wise normal form equals division by the basis {sin² + cos² − 1}; a value that is
    # zero on the circle (sin² + cos² − 1, built by arithmetic) tests as zero, exactly
    import random

    from minparam_cli.base.symbolic_poly import ExactContext

    ctx = ExactContext(["a", "sin_x", "cos_x", "sin_y", "cos_y"], [("sin_x", "cos_x"), ("sin_y", "cos_y")])
    a, s, c, t, d = ctx.R.gens
    rnd = random.Random(18)
    for _ in range(40):
        p = sum(rnd.randint(-3, 3) * a ** rnd.randint(0, 2) * s ** rnd.randint(0, 4) * c ** rnd.randint(0, 3)
                * t ** rnd.randint(0, 3) * d ** rnd.randint(0, 2) for _ in range(6))
        assert ctx.reduce(p) == p.rem(ctx.circle)
    S, C, A = ctx.var("sin_x"), ctx.var("cos_x"), ctx.var("a")
    assert not (S * S + C * C - 1)
    q = (A * S + C) / (S * S * C + C)  # = (a s + c) / (c (s² + 1)) with s² = 1 − c²: (a s + c)/(c (2 − c²))
    assert not (q * (C * (2 - C * C)) - (A * S + C))
    assert not (q * 0) and not (q - q) and q


def test_exact_quotient_agrees_with_sympys_division():
    # the heap division (symbolic_poly.exact_quotient) against sympy's div on random products with
    # and without a remainder: the quotient when the remainder is zero, None otherwise
    import random

    from sympy import QQ
    from sympy.polys.rings import ring

    from minparam_cli.base.symbolic_poly import exact_quotient

    R, a, s, c = ring("a,s,c", QQ)
    rnd = random.Random(34)

    def poly():
        return sum(QQ(rnd.randint(-5, 5), rnd.randint(1, 4)) * a ** rnd.randint(0, 3) * s ** rnd.randint(0, 2)
                   * c ** rnd.randint(0, 3) for _ in range(rnd.randint(1, 7)))

    exact = inexact = 0
    for _ in range(200):
        f = poly()
        if not f:
            continue
        n = poly() * f + (poly() if rnd.random() < 0.5 else R.zero)
        if not n:
            continue
        (q,), r = n.div([f])
        got = exact_quotient(n, f)
        if r:
            assert got is None
            inexact += 1
        else:
            assert got == q and got * f == n
            exact += 1
    assert exact > 50 and inexact > 50


def test_canonical_form_removes_factors_shared_on_the_circles():
    # H = k·a·s + m·(c² − 1) is an irreducible polynomial but s·(k·a − m·s) on the circle: a value
    # multiplied above and below by H (as the exact solve at rational states multiplied stage 2's
    # coefficients by factors carrying the states' numbers: k, m = 87309, 89559 on the DH RPRR) keeps
    # it after cancelling polynomial factors, and loses it in the canonical form, which depends on
    # the value only
    from minparam_cli.base.symbolic_poly import ExactContext

    ctx = ExactContext(["a", "sin_x", "cos_x", "sin_y", "cos_y"], [("sin_x", "cos_x"), ("sin_y", "cos_y")])
    A, S, C, T, D = (ctx.var(n) for n in ("a", "sin_x", "cos_x", "sin_y", "cos_y"))
    for p, q, h in ((A * C + S, C * T + D, 7 * A * S + 5 * (C * C - 1)),
                    (C * D - S * T, A * A + C, 87309 * A * S - 89559 * (C * C - 1)),
                    (A + T, C * D + A, 13 * A * T + 11 * (D * D - 1))):
        v = (p / q).canonical()
        for w in ((p * h) / (q * h), (p * h * h) / (q * h * h)):
            assert not (w - v)  # the same value, exactly
            assert w.cancelled().length() > v.length()  # cancelling polynomial factors leaves H
            c = w.canonical()
            assert c.n == v.n and ctx.power(c.d) == ctx.power(v.d)  # one representation per value
            assert w.shorter_canonical().length() == v.length()
    # a sine-free denominator can be longer: (a + s·d)/(s·c) = (a + s·d)·s/(c·(1 − c²)); kept as it is
    w = (A + S * D) / (S * C)
    assert w.canonical().length() > w.length() and w.shorter_canonical() is w
    assert not (w.canonical() - w)


@pytest.mark.parametrize("name", ["skew_rprr_dh", "skew_rprr_mdh"])
def test_skewed_rprr_with_prismatic_joint_passes_the_exact_check(name):
    # issue 34: the DH RPRR's stage-2 coefficients carried factors with the rational states' numbers
    # (16-digit integers, 4340-term numerators): its identity check failed (1.4e-9, float cancellation)
    # and nothing was printed; the MDH RPRR printed integers of 10 digits.  Every integer of the
    # printed set is now small, and the set regroups the numeric regressor at random geometries
    path = f"benchmarks/data/symbolic/{name}.yaml"
    report, _coef, worst, worst_beta = compare_with_numeric(path, DeriveOptions(symbolic=True))
    assert worst <= RTOL and worst_beta <= BETA_RTOL, (worst, worst_beta)
    assert report["symbolic_verification"]["max_identity_error_fresh"] <= 1e-12
    numbers = [int(m) for b in report["base_parameters"] for m in re.findall(r"(?<![\w.])\d+(?![\w.])", b["symbolic"])]
    assert numbers and max(numbers) < 100, max(numbers)


def test_rpy_of_inverts_the_urdf_rotation_including_gimbal_lock():
    # the composed fixed transform is written back as roll, pitch, yaw: R = Rz(yaw)·Ry(pitch)·Rx(roll)
    from minparam_cli.base.symbolic_urdf import _rot, rpy_of

    rng = np.random.default_rng(18)
    worst = 0.0
    for k in range(600):
        a = rng.uniform(-np.pi, np.pi, 3)
        if k % 3:  # at and near pitch = ±90°, where roll and yaw share one rotation
            a[1] = np.pi / 2 * rng.choice([-1, 1]) + (0.0 if k % 3 == 1 else rng.choice([1e-6, 1e-9, 1e-13]))
        R = _rot(*a)
        worst = max(worst, float(np.abs(_rot(*rpy_of(R)) - R).max()))
    assert worst <= 1e-12, worst


def _uncollected(coef, lengths) -> list:
    """Printed terms that put several length monomials over one trigonometric denominator."""
    bad = []
    for c in coef.values():
        for t in sp.Add.make_args(c):
            num, den = sp.fraction(sp.factor_terms(t))
            if num.is_Add and den.has(sp.sin, sp.cos):
                monos = {sp.Poly(a, *lengths).monoms()[0] for a in num.args if a.free_symbols & set(lengths)}
                if len(monos) > 1:
                    bad.append(t)
    return bad


def test_skewed_coefficients_are_collected_by_the_lengths(tmp_path):
    # issue 18 point 4: a1²/sin²α1 − a2²/sin²α2 + d2², not (a1² sin²α2 − a2² sin²α1 + d2² sin²α1 sin²α2)/(sin²α1 sin²α2)
    report, coef, worst, _ = compare_with_numeric(_file(tmp_path, SKEW_DH), DeriveOptions(symbolic=True))
    assert worst <= RTOL
    lengths = [sp.Symbol(s) for s in report["symbols"] if s[0] in "ad" and s[1:].isdigit()]
    assert not _uncollected(coef, lengths)
    # and the check can fail: the same coefficient written over a common denominator is caught
    joint = {k: sp.together(v) for k, v in coef.items()}
    assert _uncollected(joint, lengths)
