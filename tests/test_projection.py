"""The method of projections (Krutikov 2011, paper 000) against the QR route, the paper's PUMA table,
trees, extras, exact arithmetic and the up-front refusal."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

from minparam_cli.base.projection import MAX_ROWS, derive_projection, projection_cost
from minparam_cli.base.qr import derive_qr
from minparam_cli.chain import build_chain
from minparam_cli.describe import load_description
from minparam_cli.describe.yaml_dh import description_from_mapping
from minparam_cli.dynamics.projection import energy_blocks
from minparam_cli.dynamics.projection_rows import basis_dimension, produced_rows
from minparam_cli.dynamics.projection_terms import exact_geometry
from minparam_cli.dynamics.regressor import random_states, regressor
from minparam_cli.errors import ComputationError, UnsupportedError

ALL_EXTRAS = ("rotor_inertia", "coulomb", "viscous", "offset")


def chain_of(path, extras=(), values=None):
    desc = load_description(path)
    return build_chain(desc, values=values, extras=tuple(tuple(extras) for _ in desc.joints))


def dh_chain(joints, name="test", units=None, gravity=(0, 0, -9.81)):
    doc = {"name": name, "convention": "dh", "units": units or {"length": "m", "angle": "deg"}, "gravity": list(gravity), "joints": joints}
    return build_chain(description_from_mapping(doc, f"{name}.yaml"))


def assert_same_base_set(proj, qr):
    assert proj.method == "projection"
    assert proj.standard_names == qr.standard_names
    assert proj.n_base == qr.n_base
    assert proj.kept == qr.kept
    assert proj.unidentifiable == qr.unidentifiable
    scale = max(1.0, float(np.abs(qr.K).max()))
    assert np.allclose(proj.K, qr.K, rtol=0, atol=1e-9 * scale), np.abs(proj.K - qr.K).max()


# --- acceptance: the two routes agree on every robot file --------------------------------


@pytest.mark.parametrize("extras", [(), ALL_EXTRAS], ids=["rigid", "friction+rotor"])
def test_projection_agrees_with_qr_on_every_robot(robot_path, extras):
    chain = chain_of(robot_path, extras)
    if any(kind.startswith("motor_") for _, kind in chain.layout.extra_columns):
        # a transmission's motor-side columns (robots/tx40.yaml): refused by this route, compared without them
        with pytest.raises(UnsupportedError, match="motor-side"):
            derive_projection(chain)
        chain = chain.with_extras(tuple(tuple(k for k in e if not k.startswith("motor_")) for e in chain.layout.extras))
    proj = derive_projection(chain)
    assert_same_base_set(proj, derive_qr(chain))
    assert proj.exact == (chain.exact is not None)
    if proj.exact:
        # exact mode: K is the exact K_exact, rounded once
        assert proj.rank_margin == {"criterion": "exact rational elimination", "tolerance": 0}
        assert all(isinstance(x, Fraction) for row in proj.K_exact for x in row)
        assert np.array_equal(proj.K, np.array([[float(x) for x in row] for row in proj.K_exact]))
    else:
        m = proj.rank_margin
        assert m["last_kept"] > 1e3 * m["tolerance"] > m["first_dropped"]


def test_base_model_reproduces_full_model_torques():
    """Independent of both routes' internals: W φ = W_kept (K φ) on random states (Stanford, extras)."""
    chain = chain_of("robots/stanford.yaml", ALL_EXTRAS)
    b = derive_projection(chain)
    rng = np.random.default_rng(5)
    W = regressor(chain, *random_states(chain, 30, rng)).reshape(-1, chain.layout.size)
    for _ in range(10):
        phi = rng.standard_normal(chain.layout.size)
        assert np.linalg.norm(W @ phi - W[:, list(b.kept)] @ (b.K @ phi)) <= 1e-10 * np.linalg.norm(W @ phi)
    assert np.linalg.matrix_rank(W[:, list(b.kept)]) == b.n_base


# --- acceptance: Krutikov's PUMA 560 table (robots/puma560.yaml, mm in the file) ---------------


@pytest.fixture(scope="module")
def puma():
    chain = chain_of("robots/puma560.yaml")
    return chain, derive_projection(chain)


def _row(b, name):
    return b.K_exact[b.kept.index(b.standard_names.index(name))]


def _coef(b, row_name, col_name):
    return _row(b, row_name)[b.standard_names.index(col_name)]


MM = Fraction(1, 1000)


def test_puma560_has_36_base_parameters_in_exact_mode(puma):
    chain, b = puma
    assert chain.exact is not None
    assert b.exact and b.n_base == 36
    assert b.extra["basis_rows"] == 328_854  # the paper's dim B for six revolute joints


# (name in the paper's list, row, {column: coefficient in SI})
PUMA_GROUPINGS = [
    ("S2x + 431.8*(m2+...+m6)", "MX2", {f"M{k}": Fraction(4318, 10) * MM for k in range(2, 7)}),
    ("J2xz + 431.8*(S2z + S3y)", "XZ2", {"MZ2": -Fraction(4318, 10) * MM, "MY3": -Fraction(4318, 10) * MM}),
    ("431.8^2 = 186451 mm^2 * (m2+...+m6)", "XX2", {f"M{k}": (Fraction(4318, 10) * MM) ** 2 for k in range(2, 7)}),
    ("S3x - 20.3*(m3+...+m6)", "MX3", {f"M{k}": -Fraction(203, 10) * MM for k in range(3, 7)}),
    ("J3xy - 20.3*S3y", "XY3", {"MY3": Fraction(203, 10) * MM}),
    ("S3 - S4 + 433.1*(m4+m5+m6)", "MZ3", {"MY4": -1, **{f"M{k}": Fraction(4331, 10) * MM for k in range(4, 7)}}),
    ("866.2*S4 with 433.1^2 - 20.3^2 mm^2 * (m4+m5+m6)", "YY3",
     {"MY4": -Fraction(8662, 10) * MM, **{f"M{k}": (Fraction(4331, 10) * MM) ** 2 - (Fraction(203, 10) * MM) ** 2 for k in range(4, 7)}}),
    ("S5 + S6z + 70*m6", "MZ5", {"MZ6": 1, "M6": 70 * MM}),
    ("140*S6z + 4900*m6", "YY5", {"MZ6": 140 * MM, "M6": 4900 * MM**2}),
]


@pytest.mark.parametrize("label, row, coefficients", PUMA_GROUPINGS, ids=[g[0] for g in PUMA_GROUPINGS])
def test_puma560_grouping_of_the_paper(puma, label, row, coefficients):
    _, b = puma
    for col, value in coefficients.items():
        assert _coef(b, row, col) == value, f"{label}: coefficient of {col} in {row}R"


def test_puma560_grouping_J4zz_plus_J5yy(puma):
    """The paper's J are pseudo-inertias (J = tr(I)/2 E - I): only J4zz + J5yy is identifiable.

    Raising J4zz by 1 raises XX4 and YY4 by 1; lowering J5yy by 1 lowers XX5 and ZZ5 by 1.
    """
    _, b = puma
    names = b.standard_names
    v = np.zeros(len(names))
    for n, s in (("XX4", 1), ("YY4", 1), ("XX5", -1), ("ZZ5", -1)):
        v[names.index(n)] = s
    w = np.abs(v)
    assert np.all(b.K @ v == 0), "the exchange J4zz <-> J5yy must not change any base parameter"
    assert np.any(b.K @ w != 0), "the sum J4zz + J5yy must be identifiable"


def test_puma560_rotor_inertia_of_joint_1_regroups_with_link_1():
    b = derive_projection(chain_of("robots/puma560.yaml", ("rotor_inertia",)))
    assert b.n_base == 36 + 4
    assert _coef(b, "YY1", "Ia1") == 1  # both multiply q̈1 alone (NOTES.md)
    assert "Ia1" not in {b.standard_names[c] for c in b.kept}


def test_puma560_float_mode_matches_exact_mode(puma):
    """The same robot with its geometry given as floats (no exact values) runs in float64."""
    _, exact = puma
    chain = chain_of("robots/puma560.yaml", values={"a2": 0.4318})
    assert chain.exact is None
    b = derive_projection(chain)
    assert not b.exact and b.kept == exact.kept
    assert np.allclose(b.K, exact.K, rtol=0, atol=1e-12)
    assert set(b.rank_margin) >= {"criterion", "tolerance", "last_kept", "first_dropped"}


# --- trees, arbitrary axes, prismatic joints and extras -------------------------------------


def _urdf_tree(tmp_path, name, rpy, axes):
    def link(n):
        return f'<link name="{n}"><inertial><mass value="1"/><origin xyz="0.1 0 0"/>' \
               f'<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.03"/></inertial></link>\n'

    def joint(n, kind, parent, child, xyz, axis, r):
        return (f'<joint name="{n}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
                f'<origin xyz="{xyz}" rpy="{r}"/><axis xyz="{axis}"/>'
                f'<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>\n')

    body = '<link name="world"/>\n' + "".join(link(n) for n in ("torso", "l1", "l2", "r1", "r2", "r3"))
    body += joint("waist", "revolute", "world", "torso", "0 0 0.5", axes[0], rpy[0])
    body += joint("l_sh", "revolute", "torso", "l1", "0 0.3 0.2", axes[1], rpy[1])
    body += joint("l_el", "revolute", "l1", "l2", "0.3 0 0", axes[2], rpy[2])
    body += joint("r_sh", "revolute", "torso", "r1", "0 -0.3 0.2", axes[3], rpy[3])
    body += joint("r_slide", "prismatic", "r1", "r2", "0.25 0.05 0", axes[4], rpy[4])
    body += joint("r_wr", "revolute", "r2", "r3", "0.1 0 0.02", axes[5], rpy[5])
    p = tmp_path / f"{name}.urdf"
    p.write_text(f'<?xml version="1.0"?>\n<robot name="{name}">\n{body}</robot>\n')
    return p


@pytest.mark.parametrize(
    "rpy, axes, exact",
    [
        (["0 0 0"] * 6, ["0 0 1", "0 1 0", "0 1 0", "1 0 0", "0 0 -1", "0 1 0"], True),
        (["0 0 0", "0.3 -0.2 0.1", "0 0.4 0", "1.2 0 0.5", "0.1 0.2 0.3", "0 0 0.7"],
         ["0 0 1", "1 2 3", "0 1 0", "-0.3 0.5 0.8", "1 1 0", "0 0.6 0.8"], False),
    ],
    ids=["right-angles-exact", "arbitrary-axes-float"],
)
@pytest.mark.parametrize("extras", [(), ALL_EXTRAS], ids=["rigid", "friction+rotor"])
def test_branched_urdf_tree_agrees_with_qr(tmp_path, rpy, axes, exact, extras):
    chain = chain_of(_urdf_tree(tmp_path, "tree", rpy, axes), extras)
    assert chain.parents == (-1, 0, 1, 0, 3, 4)
    assert (chain.exact is not None) == exact
    proj = derive_projection(chain)
    assert proj.exact == exact
    assert_same_base_set(proj, derive_qr(chain))
    # a tree produces fewer rows than a serial chain of the same joints
    assert produced_rows(chain)[0] + produced_rows(chain)[1] < basis_dimension(chain) - 1


def test_offset_of_a_vertical_slide_regroups_with_its_mass_and_rotor_inertia():
    """Joint 1 of the Universal-15 arm slides along gravity, and links 1-3 only translate with it:
    their masses give exactly q̈1 + g on joint 1, Ia1 gives q̈1, OFF1 gives 1.  So friction columns are
    *not* always independent of the energy columns: OFF1 = (M1 + M2 + M3 - Ia1)/g, exactly."""
    chain = chain_of("robots/universal15_glazunov.yaml", ("rotor_inertia", "offset"))
    proj, qr = derive_projection(chain), derive_qr(chain)
    assert_same_base_set(proj, qr)
    names = proj.standard_names
    assert "OFF1" in {names[c] for c in proj.dependent}
    g = Fraction(981, 100)
    assert _coef(proj, "M1", "OFF1") == 1 / g
    assert _coef(proj, "Ia1", "OFF1") == -1 / g
    assert {f"OFF{j}" for j in range(2, 7)} <= {names[c] for c in proj.kept}


def test_python_integer_fallback_when_float64_could_round():
    """Lengths with 12 decimals make integers beyond 2**53: the recursion reruns on Python integers."""
    chain = dh_chain(
        [
            {"type": "revolute", "alpha": 90, "a": 0.123456789123, "d": 0.3, "theta": 0},
            {"type": "revolute", "alpha": 0, "a": 0.4, "d": 0.111111111111, "theta": 0},
            {"type": "prismatic", "alpha": -90, "a": 0.05, "d": 0, "theta": 90},
        ]
    )
    assert chain.exact is not None
    assert exact_geometry(chain).length_scale == 10**12
    proj = derive_projection(chain)
    assert proj.exact and proj.extra["arithmetic"] == "integers (Python)"
    assert_same_base_set(proj, derive_qr(chain))


# --- streaming, cost, refusal, progress ---------------------------------------------------------


def test_paper_dimensions_of_the_basis():
    six = dh_chain([{"type": "revolute", "alpha": 90, "a": 0, "d": 0, "theta": 0}] * 6)
    five = dh_chain([{"type": "revolute", "alpha": 90, "a": 0, "d": 0, "theta": 0}] * 5)
    assert basis_dimension(six) == 328_854  # NOTES.md
    assert basis_dimension(five) == 47_118  # "47,118 x 50 for a five-link arm"
    for chain in (six, five):
        assert sum(produced_rows(chain)) == basis_dimension(chain) - 1  # the constant is excluded


def test_blocks_are_bounded_by_the_chunk_and_do_not_depend_on_it():
    chain = chain_of("robots/puma560.yaml", ("rotor_inertia", "offset"))
    geom = exact_geometry(chain)

    def collect(chunk):
        out = {}
        for b in energy_blocks(geom, chunk=chunk):
            assert b.rows <= chunk
            for k, ix in enumerate(b.index):
                out[(b.kind, b.node, b.pair, int(ix))] = tuple(b.coords[:, k])
        return out

    small, default = collect(64), collect(8192)
    assert small == default  # the same rows, each once, however the recursion is cut
    # zero matrices are never produced; every nonzero row of Z comes from one produced entry
    assert all(any(v) for v in small.values())
    assert len(small) >= derive_projection(chain).extra["nonzero_rows"]


def test_refuses_beyond_the_practical_size_before_computing():
    chain = dh_chain([{"type": "revolute", "alpha": 30, "a": 0.1, "d": 0.1, "theta": 0}] * 12)
    assert projection_cost(chain)["rows"] > MAX_ROWS
    with pytest.raises(ComputationError, match=r"--method qr"):
        derive_projection(chain)


@pytest.mark.parametrize("name", ["puma560.yaml", "universal15_glazunov.yaml"])
def test_rows_produced_and_zeros_skipped_account_for_every_basis_row(name, tmp_path):
    chains = [chain_of(f"robots/{name}")]
    chains.append(chain_of(_urdf_tree(tmp_path, "tree", ["0 0 0"] * 6, ["0 0 1", "0 1 0", "0 1 0", "1 0 0", "0 0 -1", "0 1 0"])))
    for chain in chains:
        rows = skipped = 0
        for b in energy_blocks(exact_geometry(chain), chunk=256):
            rows, skipped = rows + b.rows, skipped + b.skipped
        assert rows + skipped == sum(produced_rows(chain))
        assert rows < skipped  # most of Z is zero


def test_progress_reports_from_zero_to_total():
    calls = []
    derive_projection(chain_of("robots/stanford.yaml"), progress=lambda done, total: calls.append((done, total)))
    total = calls[0][1]
    assert calls[0] == (0, total) and calls[-1] == (total, total)
    assert all(a[0] <= b[0] for a, b in zip(calls, calls[1:], strict=False))
    assert total == projection_cost(chain_of("robots/stanford.yaml"))["rows"]
