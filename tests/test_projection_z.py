"""Z of the method of projections, checked independently.

* the trigonometric decomposition of every joint kind reproduces the chain's own transforms;
* the recursion's linear maps reproduce Lᵀ X R re-expanded on Y;
* the DFT check of NOTES.md: every energy coefficient, sampled on 5 (kinetic) or 3 (potential)
  equally spaced angles per revolute joint (3 or 2 points per prismatic joint) with the
  independent Euler–Lagrange code of tests/reference_dynamics.py and transformed to the basis B,
  equals the Z that the forward recursion produces.
"""

from __future__ import annotations

import itertools
from dataclasses import replace

import numpy as np
import pytest
import reference_dynamics as ref

from minparam_cli.chain import PRISMATIC, REVOLUTE, build_chain, motion
from minparam_cli.describe import load_description
from minparam_cli.describe.records import GeomValue, JointRecord, RobotDescription
from minparam_cli.dynamics.projection import KINETIC, POTENTIAL
from minparam_cli.dynamics.projection_rows import coordinate_matrix
from minparam_cli.dynamics.projection_terms import PRODUCT_RULES, Y_SIZE, joint_terms, kron_map


def x_functions(kind, q):
    return np.array([1.0, np.cos(q), np.sin(q)]) if kind == REVOLUTE else np.array([1.0, q])


def y_functions(kind, q):
    c, s = np.cos(q), np.sin(q)
    return np.array([1.0, c, s, c * c, s * c]) if kind == REVOLUTE else np.array([1.0, q, q * q])


def random_joint(rng, kind):
    """Pre, unit axis, Post of a URDF-like joint: arbitrary rotations and offsets on both sides."""

    def pose():
        a, b, c = rng.uniform(-np.pi, np.pi, 3)
        T = np.eye(4)
        T[:3, :3] = motion(REVOLUTE, np.array([0, 0, 1.0]), np.array([a]))[0, :3, :3] @ motion(
            REVOLUTE, np.array([1.0, 0, 0]), np.array([b])
        )[0, :3, :3] @ motion(REVOLUTE, np.array([0, 1.0, 0]), np.array([c]))[0, :3, :3]
        T[:3, 3] = rng.standard_normal(3)
        return T

    axis = rng.standard_normal(3)
    return pose(), axis / np.linalg.norm(axis), pose()


@pytest.mark.parametrize("kind", [REVOLUTE, PRISMATIC])
def test_decomposition_reproduces_the_joint_transform_and_its_derivative(kind):
    rng = np.random.default_rng(1)
    for _ in range(5):
        pre, axis, post = random_joint(rng, kind)
        terms = joint_terms(kind, pre, axis, post)
        for q in rng.uniform(-3, 3, 4):
            A = pre @ motion(kind, axis, np.array([q]))[0] @ post
            x = x_functions(kind, q)
            assert np.allclose(sum(c * m for c, m in zip(x, terms.A, strict=True)), A, atol=1e-12)
            h = 1e-6
            dA = (pre @ (motion(kind, axis, np.array([q + h]))[0] - motion(kind, axis, np.array([q - h]))[0]) @ post) / (2 * h)
            dsum = sum(c * m for c, m in zip(x, terms.D, strict=True) if m is not None)
            assert np.allclose(dsum, dA, atol=1e-7)


@pytest.mark.parametrize("kind", [REVOLUTE, PRISMATIC])
@pytest.mark.parametrize("left, right", [("A", "A"), ("D", "A"), ("A", "D"), ("D", "D")])
def test_linear_maps_are_the_products_re_expanded_on_Y(kind, left, right):
    rng = np.random.default_rng(2)
    pre, axis, post = random_joint(rng, kind)
    t = joint_terms(kind, pre, axis, post)
    L, R = getattr(t, left), getattr(t, right)
    M = kron_map(kind, L, R, np.float64)
    X = rng.standard_normal((4, 4))
    out = (M @ X.reshape(16, 1)).reshape(Y_SIZE[kind], 4, 4)
    for q in rng.uniform(-3, 3, 4):
        x = x_functions(kind, q)
        Lq = sum(c * m for c, m in zip(x, L, strict=True) if m is not None)
        Rq = sum(c * m for c, m in zip(x, R, strict=True) if m is not None)
        expanded = np.einsum("c,cij->ij", y_functions(kind, q), out)
        assert np.allclose(expanded, Lq.T @ X @ Rq, atol=1e-12)
    assert set(PRODUCT_RULES[kind]) == set(itertools.product(range(len(x)), repeat=2))


# --- the DFT check -----------------------------------------------------------------------------

NODES = {  # sample points and basis on them, per joint kind: kinetic (degree 2) and potential (degree 1)
    (REVOLUTE, KINETIC): 2 * np.pi * np.arange(5) / 5,
    (REVOLUTE, POTENTIAL): 2 * np.pi * np.arange(3) / 3,
    (PRISMATIC, KINETIC): np.array([-0.5, 0.0, 0.5]),
    (PRISMATIC, POTENTIAL): np.array([0.0, 0.5]),
}


def _transform(samples, kinds, part):
    """Sampled values on the product grid -> coordinates on the per-joint basis (axis by axis)."""
    coef = samples
    for axis, kind in enumerate(kinds):
        nodes = NODES[(kind, part)]
        f = y_functions if part == KINETIC else x_functions
        B = np.array([f(kind, q) for q in nodes])  # B[node, basis function]
        coef = np.moveaxis(np.tensordot(np.linalg.inv(B), coef, axes=([1], [axis])), 0, axis)
    return coef


def z_by_sampling(chain):
    """Z from energy samples: {label: row} for every basis function, the constant excluded."""
    n, P = chain.n, 10 * chain.n
    kinds = chain.types
    eye = np.eye(P)
    out = {}
    for part in (KINETIC, POTENTIAL):
        grids = [NODES[(k, part)] for k in kinds]
        shape = tuple(len(g) for g in grids)
        values = np.zeros(shape + ((n, n, P) if part == KINETIC else (P,)))
        for idx in itertools.product(*[range(s) for s in shape]):
            q = np.array([g[i] for g, i in zip(grids, idx, strict=True)])
            for c in range(P):
                if part == KINETIC:
                    values[idx + (slice(None), slice(None), c)] = ref.mass_matrix(chain, eye[c], q).real
                else:
                    values[idx + (c,)] = -np.real(ref.potential(chain, eye[c], q))  # L = K - Π
        coef = _transform(values, kinds, part)
        for idx in itertools.product(*[range(s) for s in coef.shape[:n]]):
            if part == KINETIC:
                for i in range(n):
                    for j in range(i + 1):
                        out[(KINETIC, i, j, idx)] = coef[idx + (i, j)]  # q̇_i q̇_j (j < i) or q̇_i²/2
            elif any(idx):
                out[(POTENTIAL, idx)] = coef[idx]
    return out


def _records_chain(joints):
    """A URDF-like chain built from records: arbitrary origins and axes, any joint kinds."""
    recs = []
    for k, (kind, xyz, rpy, axis) in enumerate(joints):
        origin = {key: GeomValue(v, f"{key}{k}") for key, v in zip("xyz", xyz, strict=True)}
        origin.update({key: GeomValue(v, f"{key}{k}", True) for key, v in zip(("roll", "pitch", "yaw"), rpy, strict=True)})
        recs.append(JointRecord(name=f"j{k}", type=kind, parent=k - 1, link_name=f"l{k}", origin=origin, axis=axis))
    desc = RobotDescription("records", "records", "urdf", tuple(recs), gravity=(0.3, -1.2, -9.7))
    return build_chain(desc)


def _first_joints(desc, k):
    return replace(desc, joints=desc.joints[:k])


CHAINS = {
    "planar2r.yaml": lambda: build_chain(load_description("robots/planar2r.yaml")),
    "planar3r.yaml": lambda: build_chain(load_description("robots/planar3r.yaml")),
    "stanford-RRP": lambda: build_chain(_first_joints(load_description("robots/stanford.yaml"), 3)),
    "urdf-like-RPR": lambda: _records_chain(
        [
            (REVOLUTE, (0.1, 0.0, 0.3), (0.2, -0.4, 0.1), (0.3, 0.4, 0.866)),
            (PRISMATIC, (0.0, 0.2, 0.1), (1.1, 0.3, -0.7), (0.6, 0.0, 0.8)),
            (REVOLUTE, (0.25, -0.05, 0.0), (-0.3, 0.5, 0.9), (0.0, 0.6, -0.8)),
        ]
    ),
}


@pytest.mark.parametrize("name", list(CHAINS))
def test_recursion_z_equals_sampled_and_transformed_energy(name):
    chain = CHAINS[name]()
    assert chain.n in (2, 3)
    labels, Z = coordinate_matrix(chain)
    Z = Z[:, : 10 * chain.n]
    rec = {}
    for lab, row in zip(labels, Z, strict=True):
        key = lab[:3] + (lab[3],) if lab[0] == KINETIC else lab
        assert key not in rec, f"row {key} produced twice"
        rec[key] = row
    sampled = z_by_sampling(chain)
    scale = max(np.abs(Z).max(), max(np.abs(v).max() for v in sampled.values()))
    assert set(rec) <= set(sampled), "the recursion produced a row outside the basis"
    assert (POTENTIAL, (0,) * chain.n) not in rec, "the constant basis function is excluded"
    nonzero = 0
    for key, want in sampled.items():
        got = rec.get(key, np.zeros_like(want))  # rows the recursion never produced are zero
        assert np.allclose(got, want, rtol=0, atol=1e-10 * scale), (key, got, want)
        nonzero += bool(np.any(np.abs(want) > 1e-10 * scale))
    assert nonzero > 0
