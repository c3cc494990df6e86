"""Symbolic regrouping (`derive --symbolic`): hand derivations, Khalil's rules, every robot."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
import sympy as sp

from conftest import ROBOT_FILES, ROBOT_IDS
from minparam_cli.base.qr import derive_qr
from minparam_cli.base.report import Derivation, RobotSummary
from minparam_cli.base.symbolic import add_symbolic, geometry_symbols, symbolic_base
from minparam_cli.chain import build_chain
from minparam_cli.describe import load_description
from minparam_cli.api.derivation import derive_file as _derive_file
from minparam_cli.api.options.derive import DeriveOptions


def derive_file(path, opts):
    """The derive JSON of one robot file (the API's base set, as a dict)."""
    return _derive_file(path, opts).to_dict()



def symbolic_set(path) -> dict[str, sp.Expr]:
    r = derive_file(path, DeriveOptions(symbolic=True))
    assert r["symbolic_verification"]["passed"]
    return {b["name"]: sp.sympify(b["symbolic"]) for b in r["base_parameters"]}


def same(a, b) -> bool:
    return sp.expand(sp.sympify(a) - sp.sympify(b)) == 0


# --- planar arms by hand ------------------------------------------------------
# Standard DH, all axes parallel and horizontal, gravity in the plane.  Frame j sits at
# the far end of link j, so a point of link j at r (frame j) is at distance |(a_j,0)+r|
# from axis j.  Kinetic energy of link j about its own axis:
#   ZZ_j + 2 a_j MX_j + a_j² M_j,
# the links after j add their mass at the end of link j: a_j² (M_{j+1} + …), and the
# coupling/gravity terms only see MX_j + a_j (M_j + M_{j+1} + …) and MY_j.
# So the identifiable combinations per link are
#   θ1 = ZZ_j + 2 a_j MX_j + a_j² (M_j + …),  θ2 = MX_j + a_j (M_j + …),  θ3 = MY_j,
# and in the kept-parameter form (keep ZZ_j, MX_j, MY_j; scan order):
#   ZZR_j = θ1 − 2 a_j θ2 = ZZ_j − a_j² (M_j + M_{j+1} + …)
#   MXR_j = θ2 = MX_j + a_j (M_j + M_{j+1} + …),  MY_j = MY_j.
def planar_hand(n):
    out = {}
    for j in range(1, n + 1):
        a = sp.Symbol(f"a{j}")
        mass = sum(sp.Symbol(f"M{k}") for k in range(j, n + 1))
        out[f"ZZR{j}"] = sp.Symbol(f"ZZ{j}") - a**2 * mass
        out[f"MXR{j}"] = sp.Symbol(f"MX{j}") + a * mass
        out[f"MY{j}"] = sp.Symbol(f"MY{j}")
    return out


@pytest.mark.parametrize("name, n", [("planar2r.yaml", 2), ("planar3r.yaml", 3)])
def test_planar_arms_match_hand_derivation(name, n):
    got = symbolic_set(f"robots/{name}")
    want = planar_hand(n)
    assert set(got) == set(want)
    for k in want:
        assert same(got[k], want[k]), (k, got[k], want[k])


# --- PUMA 560 (MDH) against Khalil's general rules ----------------------------
# Regrouping rules for a revolute joint j (Gautier & Khalil, "Direct calculation of
# minimum set of inertial parameters of serial robots", IEEE Trans. Robotics and
# Automation 6(3), 1990; Khalil & Dombre, "Modeling, Identification and Control of
# Robots", 2002, sec. 9.4 on the base inertial parameters), with r_j = d_j, in MDH:
#   XXR_j = XX_j − YY_j
#   XX_{j−1} += YY_j + 2 r_j MZ_j + r_j² M_j
#   XY_{j−1} += a_j Sα_j (MZ_j + r_j M_j)
#   XZ_{j−1} −= a_j Cα_j (MZ_j + r_j M_j)
#   YY_{j−1} += C²α_j YY_j + 2 r_j C²α_j MZ_j + (a_j² + r_j² C²α_j) M_j
#   YZ_{j−1} += Cα_j Sα_j (YY_j + 2 r_j MZ_j + r_j² M_j)
#   ZZ_{j−1} += S²α_j YY_j + 2 r_j S²α_j MZ_j + (a_j² + r_j² S²α_j) M_j
#   MX_{j−1} += a_j M_j,  MY_{j−1} −= Sα_j (MZ_j + r_j M_j),  MZ_{j−1} += Cα_j (MZ_j + r_j M_j),
#   M_{j−1} += M_j
# applied from j = n down to 2; link 1 (first axis along gravity) keeps only ZZR1.
PUMA_MDH = [  # alpha (deg), a, d — symbols as the loader names the nonzero values of puma560_mdh.yaml
    (0, 0, 0), (-90, 0, "d2"), (0, "a3", "d3"), (90, "a4", "d4"), (-90, 0, 0), (90, 0, 0),
]


def khalil_rules(table=PUMA_MDH):
    n = len(table)
    P = {(k, j): sp.Symbol(f"{k}{j}") for j in range(1, n + 1) for k in ("XX", "XY", "XZ", "YY", "YZ", "ZZ", "MX", "MY", "MZ", "M")}
    for j in range(n, 1, -1):
        al, a, d = table[j - 1]
        a = sp.Symbol(a) if a else sp.Integer(0)
        r = sp.Symbol(d) if d else sp.Integer(0)
        th = sp.Symbol(al) if isinstance(al, str) else sp.rad(al)
        S, C = sp.sin(th), sp.cos(th)
        YY, MZ, M = P["YY", j], P["MZ", j], P["M", j]
        i = j - 1
        P["XX", i] += YY + 2 * r * MZ + r**2 * M
        P["XY", i] += a * S * (MZ + r * M)
        P["XZ", i] -= a * C * (MZ + r * M)
        P["YY", i] += C**2 * YY + 2 * r * C**2 * MZ + (a**2 + r**2 * C**2) * M
        P["YZ", i] += C * S * (YY + 2 * r * MZ + r**2 * M)
        P["ZZ", i] += S**2 * YY + 2 * r * S**2 * MZ + (a**2 + r**2 * S**2) * M
        P["MX", i] += a * M
        P["MY", i] -= S * (MZ + r * M)
        P["MZ", i] += C * (MZ + r * M)
        P["M", i] += M
    out = {"ZZR1": P["ZZ", 1]}
    for j in range(2, n + 1):
        out[f"XXR{j}"] = P["XX", j] - P["YY", j]
        for k in ("XY", "XZ", "YZ", "ZZ", "MX", "MY"):
            out[f"{k}{j}"] = P[k, j]
    return out


def test_puma560_mdh_reproduces_khalil_regrouping_rules():
    got = {sp.sympify(k): v for k, v in symbolic_set("robots/puma560_mdh.yaml").items()}
    got_by_kept = {}
    for name, expr in got.items():
        kind = str(name).replace("R", "")  # XXR2 -> XX2
        got_by_kept[kind] = expr
    rules = khalil_rules()
    assert len(got) == len(rules) == 36
    for name, expr in rules.items():
        key = name.replace("R", "")
        assert key in got_by_kept, key
        assert same(got_by_kept[key], expr), (name, got_by_kept[key], sp.expand(expr))


SKEW_4R = """\
name: skew 4R (alpha3 not a right angle)
convention: mdh
units: {length: m, angle: deg}
gravity: [0, 0, -9.81]
joints:
  - {name: j1, type: revolute, alpha: 0, a: 0, d: 0, theta: 0}
  - {name: j2, type: revolute, alpha: -90, a: 0, d: 0.2, theta: 0}
  - {name: j3, type: revolute, alpha: 30, a: 0.4, d: -0.1, theta: 0}
  - {name: j4, type: revolute, alpha: 90, a: 0.1, d: 0.3, theta: 20}
"""


def test_symbolic_angle_follows_khalil_rules(tmp_path):
    # alpha3 = 30 deg becomes a symbol: the rules above with sin/cos of alpha3; theta4 (an
    # offset of a revolute MDH joint) only shifts q4 and must not appear.
    path = tmp_path / "skew.yaml"
    path.write_text(SKEW_4R)
    r = derive_file(path, DeriveOptions(symbolic=True))
    assert set(r["symbols"]) == {"d2", "alpha3", "a3", "d3", "a4", "d4", "theta4", "g"}
    got = {b["name"].replace("R", ""): sp.sympify(b["symbolic"]) for b in r["base_parameters"]}
    rules = khalil_rules([(0, 0, 0), (-90, 0, "d2"), ("alpha3", "a3", "d3"), (90, "a4", "d4")])
    assert len(got) == len(rules)
    for name, expr in rules.items():
        assert sp.simplify(got[name.replace("R", "")] - expr) == 0, name
    assert not any("theta4" in b["symbolic"] for b in r["base_parameters"])


# --- every robot: file values and 5 other geometries ---------------------------
def _coefficients(report):
    """{(base name, standard name): sympy coefficient} from the 'symbolic' strings."""
    out = {}
    for b in report["base_parameters"]:
        e = sp.expand(sp.sympify(b["symbolic"]))
        for t in report["standard_parameters"]:
            c = e.coeff(sp.Symbol(t))
            if c != 0:
                out[b["name"], t] = c
    return out


@pytest.mark.parametrize("path", ROBOT_FILES, ids=ROBOT_IDS)
def test_symbolic_coefficients_equal_numeric_beta(path):
    desc = load_description(path)
    chain = build_chain(desc)
    base = derive_qr(chain)
    report = replace(base, derivation=Derivation(RobotSummary.of(chain), symbolic=add_symbolic(desc, chain, base))).to_dict()
    assert report["generic_n_base"] == base.n_base and "symbolic_generic" not in report
    coef = _coefficients(report)
    symbols, pins = geometry_symbols(desc)
    assert set(report["symbols"]) == {s.name for s in symbols} | {"g"}

    def check(b, values):
        subs = {sp.Symbol(k): v for k, v in values.items()}
        for i, name in enumerate(b.base_names):
            terms = b.terms[i]
            for t in set(terms) | {t for (bn, t) in coef if bn == name}:
                want = terms.get(t, 0.0)
                got = float(coef.get((name, t), 0).subs(subs)) if (name, t) in coef else 0.0
                assert got == pytest.approx(want, rel=1e-8, abs=1e-10), (path.name, name, t, values)

    check(base, report["symbols"])
    rng = np.random.default_rng(2024)
    for _ in range(5):
        values = {s.name: (rng.uniform(-np.pi, np.pi) if s.is_angle else rng.uniform(0.2, 2.0) * rng.choice([-1, 1])) for s in symbols}
        other = derive_qr(build_chain(desc, values={**pins, **values}))
        assert other.kept == base.kept
        check(other, {**values, "g": report["symbols"]["g"]})


def test_json_fields_round_trip_and_named_symbols():
    r = derive_file("robots/puma560.yaml", DeriveOptions(symbolic=True))
    assert r["symbols"] == pytest.approx({"a2": 0.4318, "d2": 0.15, "a3": -0.0203, "d4": 0.4331, "d6": 0.07, "g": 9.81})
    names = {str(s) for b in r["base_parameters"] for s in sp.sympify(b["symbolic"]).free_symbols}
    assert {"a2", "a3", "d4"} <= names and not {"a1", "alpha1"} & names
    assert r["symbolic_latex"].count(r"\\") == r["n_base"] - 1
    assert all("terms" in b for b in r["base_parameters"])


def test_urdf_symbols_are_origin_components():
    r = derive_file("robots/ur5.urdf", DeriveOptions(symbolic=True))
    assert "shoulder_lift_y" in r["symbols"]
    assert any(n.startswith("shoulder_lift_pitch is given as 1.570796325") for n in r["symbolic_notes"])  # near-pi/2 pinned, said so


def test_latex_lines_parse_with_mathtext():
    from matplotlib.mathtext import MathTextParser

    r = derive_file("robots/ur5.urdf", DeriveOptions(symbolic=True))
    parser = MathTextParser("agg")
    for b in r["base_parameters"]:
        parser.parse(f"${b['symbolic_latex']}$")


def test_special_geometry_is_reported_not_printed_as_general_formula():
    # Reporting path: a file's set with fewer base parameters than the generic one.  The
    # shipped robots have no nonzero special values, so the file's set is taken with axes 1
    # and 2 made parallel (alpha2 = 0, a rank drop from 36 to 26) against the generic set.
    desc = load_description("robots/puma560_mdh.yaml")
    chain = build_chain(desc)
    special = derive_qr(build_chain(desc, values={"alpha2": 0.0}))
    generic = derive_qr(chain)
    assert special.n_base < generic.n_base
    out = replace(special, derivation=Derivation(RobotSummary.of(chain), symbolic=add_symbolic(desc, chain, special))).to_dict()
    assert out["generic_n_base"] == generic.n_base
    assert len(out["symbolic_generic"]) == generic.n_base
    assert any("special geometry" in n for n in out["symbolic_notes"])
    assert all("symbolic" not in b for b in out["base_parameters"])


def test_deterministic():
    desc = load_description("robots/planar3r.yaml")
    chain = build_chain(desc)
    base = derive_qr(chain)
    a, b = symbolic_base(desc, chain, base), symbolic_base(desc, chain, base)
    assert a["coefficients"] and a["coefficients"] == b["coefficients"]


def test_cli_symbolic_json_through_entry_point():
    from typer.testing import CliRunner

    from minparam_cli.cli.app import app

    res = CliRunner().invoke(app, ["derive", "robots/planar2r.yaml", "--symbolic", "--format", "json"])
    assert res.exit_code == 0, res.output
    r = json.loads(res.output)
    assert r["symbols"] == {"a1": 1.0, "a2": 0.8, "g": 9.81} and r["generic_n_base"] == 6
    zz1 = next(b for b in r["base_parameters"] if b["name"] == "ZZR1")
    assert same(zz1["symbolic"], "ZZ1 - a1**2*(M1 + M2)")
    plain = CliRunner().invoke(app, ["derive", "robots/planar2r.yaml", "--format", "json"])
    assert "symbols" not in json.loads(plain.output)  # off by default
