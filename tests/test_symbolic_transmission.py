"""Exact symbolic regrouping with a declared transmission (issues 16 and 18): motor-side rotor inertia
(energy ½ (N_k·q̇)²) and motor friction (v = N_k) regroup with the joints' own columns exactly, compared
with the numeric QR route at random geometries and random gravity."""

from __future__ import annotations

import re

import sympy as sp
import yaml
from conftest import ROBOTS
from test_symbolic_exact import BETA_RTOL, RTOL, compare_with_numeric

from minparam_cli.base.symbolic_friction import _combination
from minparam_cli.api.options.derive import DeriveOptions

RATIOS = [62.6, 107.8, 53.7, 76.0, 71.9, 76.7]
FULL = DeriveOptions(symbolic=True, friction=("coulomb", "viscous"), rotor_inertia=True)


def _puma(tmp_path, **transmission):
    doc = yaml.safe_load((ROBOTS / "puma560_mdh.yaml").read_text())
    doc["transmission"] = {"motor_friction": ["coulomb", "viscous"], "motor_inertia": True, **transmission}
    path = tmp_path / "puma_transmission.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


def test_coupled_wrist_with_joint_friction_and_rotor_inertia(tmp_path):
    """Motor 6 turns with q5 + q6 (as on the TX40): its three columns stay; every uncoupled motor's
    regroup with its joint's: Iam_k with r² Ia, Fvm_k with r² Fv, Fcm_k with |r| Fc."""
    path = _puma(tmp_path, ratios=RATIOS, coupling=[[6, 5, 13.25]])
    report, coef, worst, worst_beta = compare_with_numeric(path, FULL, file_kept=True)
    assert worst <= RTOL and worst_beta <= BETA_RTOL, (worst, worst_beta)
    kept = {b["name"] for b in report["base_parameters"]}
    assert {"Iam6", "Fcm6", "Fvm6"} <= kept  # coupled: functions of q̇5 + q̇6 no joint column has
    r = sp.Rational(str(RATIOS[2]))
    assert sp.simplify(coef["FvmR3", "Fv3"] - 1 / r**2) == 0
    assert sp.simplify(coef["FcmR3", "Fc3"] - 1 / r) == 0
    assert sp.simplify(coef["IamR3", "Ia3"] - 1 / r**2) == 0


def test_differential_wrist_viscous_relation_spans_two_motors(tmp_path):
    """Rows r(e5 + e6) and r(e5 − e6): the two motors' viscous matrices sum to 2r²(E55 + E66), so with
    joint viscous friction one of the four is a combination of the others: an exact relation the
    pairwise (one column is a multiple of another) rule would miss."""
    N = [[0.0] * 6 for _ in range(6)]
    for k in range(4):
        N[k][k] = RATIOS[k]
    N[4][4], N[4][5], N[5][4], N[5][5] = 50.0, 50.0, 50.0, -50.0
    path = _puma(tmp_path, matrix=N)
    report, coef, worst, worst_beta = compare_with_numeric(path, FULL, file_kept=True)
    assert worst <= RTOL and worst_beta <= BETA_RTOL, (worst, worst_beta)
    viscous = [b["name"] for b in report["base_parameters"] if re.fullmatch(r"Fvm?R?[56]", b["name"])]
    assert len(viscous) == 3, viscous  # of Fv5, Fv6, Fvm5, Fvm6
    # M5 + M6 = 2·50²(E55 + E66) for the motors' v vᵀ: the Fv6 column is −Fv5 + (Fvm5 + Fvm6)/5000
    assert sp.simplify(coef["FvR5", "Fv6"] + 1) == 0
    assert sp.simplify(coef["FvmR5", "Fv6"] - sp.Rational(1, 5000)) == 0
    assert sp.simplify(coef["FvmR6", "Fv6"] - sp.Rational(1, 5000)) == 0


def test_exact_combination_solver():
    from fractions import Fraction as F

    basis = [[F(1), F(0), F(1)], [F(0), F(1), F(1)]]
    assert _combination(basis, [F(2), F(3), F(5)]) == [F(2), F(3)]
    assert _combination(basis, [F(1), F(1), F(0)]) is None
    assert _combination([], [F(0), F(0)]) == []
