"""Rows of Krutikov's Z from the recursion's short coordinates (``dynamics/projection.py``): the
maps Ψ_t, the count of rows the recursion produces, the dimension of the basis, and Z itself,
dense, for small chains."""

from __future__ import annotations

import numpy as np

from minparam_cli.chain import PRISMATIC, Chain
from minparam_cli.dynamics.projection import KINETIC, KINETIC_DIM, POTENTIAL, POTENTIAL_DIM, energy_blocks
from minparam_cli.dynamics.projection_terms import SYM_PAIRS, X_SIZE, Y_SIZE, ProjectionGeometry, float_geometry, phi_matrix
from minparam_cli.params import N_LINK_PARAMS


def row_maps(geom: ProjectionGeometry, t: int) -> tuple[np.ndarray, np.ndarray]:
    """(Ψ_kin, Ψ_pot) of node t: Z rows = Ψ @ coords, shapes (P, KINETIC_DIM) and (P, POTENTIAL_DIM).

    The kinetic rows hold ``geom.kinetic_scale`` times the Lagrangian
    coordinates, the potential rows ``geom.potential_scale`` times them (in
    the rescaled units of exact mode).
    """
    chain = geom.chain
    dtype = object if geom.exact else np.float64  # exact mode: Python integers, whatever the recursion used
    conv = _as_python_ints if geom.exact else (lambda a: np.asarray(a, dtype=np.float64))
    layout = chain.layout
    P = layout.size
    Phi = phi_matrix(dtype)
    kin16 = np.zeros((P, 16), dtype=dtype)
    pot4 = np.zeros((P, 4), dtype=dtype)
    # C⁰ products from t down to every link k below it (parents come before children)
    carry = {t: conv(np.eye(16))}
    vcarry = {t: conv(np.eye(4))}
    for k in chain.subtree(t):
        if k != t:
            p = chain.parents[k]
            carry[k] = conv(geom.maps[k]["A0"]).dot(carry[p])
            vcarry[k] = conv(geom.terms[k].A[0]).T.dot(vcarry[p])
        cols = slice(N_LINK_PARAMS * k, N_LINK_PARAMS * k + N_LINK_PARAMS)
        kin16[cols] = Phi @ carry[k]
        pot4[N_LINK_PARAMS * k + 6 : N_LINK_PARAMS * k + 10] = vcarry[k]
    kin = np.zeros((P, KINETIC_DIM), dtype=dtype)
    for i, (a, b) in enumerate(SYM_PAIRS):
        kin[:, i] = kin16[:, 4 * a + b]  # equals kin16[:, 4b + a]: ⟨H, ·⟩ and C⁰ commute with transposition
    pot = np.zeros((P, POTENTIAL_DIM), dtype=dtype)
    pot[:, :4] = pot4
    for c, (j, kind) in enumerate(layout.extra_columns):
        if j != t:
            continue
        col = layout.n_inertial + c
        if kind == "rotor_inertia":
            kin[col, -1] = geom.kinetic_scale  # Ia_t q̇_t²/2
        elif kind == "offset" and chain.types[t] == PRISMATIC:
            pot[col, -1] = -geom.potential_scale  # L ∋ -OFF_t q_t
    return kin, pot


def _as_python_ints(a) -> np.ndarray:
    a = np.asarray(a)
    out = np.empty(a.shape, dtype=object)
    for idx, v in np.ndenumerate(a):
        out[idx] = int(v)
    return out


def basis_dimension(chain: Chain) -> int:
    """dim B of the theorem: (N²+N)/2 · 5^v 3^(N-v) + 3^v 2^(N-v), constant function included."""
    n = chain.n
    y = x = 1
    for kind in chain.types:
        y *= Y_SIZE[kind]
        x *= X_SIZE[kind]
    return (n * n + n) // 2 * y + x


def produced_rows(chain: Chain) -> tuple[int, int]:
    """(kinetic, potential) rows the recursion produces: nonconstant basis functions that
    can carry a nonzero coordinate.  For a serial chain they sum to dim B - 1; a tree
    has fewer (functions mixing two branches never appear)."""
    prodY: dict[int, int] = {}
    prodX: dict[int, int] = {}
    for j in range(chain.n):  # parents come before children
        p = chain.parents[j]
        prodY[j] = (prodY[p] if p >= 0 else 1) * Y_SIZE[chain.types[j]]
        prodX[j] = (prodX[p] if p >= 0 else 1) * X_SIZE[chain.types[j]]
    kin = pot = 0
    for t in range(chain.n):
        p = chain.parents[t]
        before = prodY[p] if p >= 0 else 1
        depth = len(chain.ancestors(t))
        # seeds (t, j) for every j on the path: all functions over path(t)
        kin += depth * prodY[t]
        # pairs (i, j) seeded above t: functions with y_t != 1
        kin += (depth - 1) * depth // 2 * before * (Y_SIZE[chain.types[t]] - 1)
        pot += (prodX[p] if p >= 0 else 1) * (X_SIZE[chain.types[t]] - 1)
    return kin, pot


def decode_index(chain: Chain, path: tuple[int, ...], index: int, kind: str) -> tuple[int, ...]:
    """Per-joint basis indices (0 = the function 1) of one flat multi-index over ``path``."""
    sizes = Y_SIZE if kind == KINETIC else X_SIZE
    digits = [0] * chain.n
    for j in reversed(path):
        index, digits[j] = divmod(int(index), sizes[chain.types[j]])
    return tuple(digits)


def coordinate_matrix(chain: Chain, max_rows: int = 100_000) -> tuple[list[tuple], np.ndarray]:
    """Z itself, dense, in SI units, for small chains (tests and documentation).

    Returns (labels, Z): label ("kinetic", i, j, y) for basis function q̇_i q̇_j ·
    Π y (q̇_i²/2 · Π y when i == j; i, j 0-based) or ("potential", x), with y, x
    per-joint indices into Y_NAMES / X_NAMES.  Only energy rows: Coulomb,
    viscous and revolute offset columns are zero here.
    """
    kin, pot = produced_rows(chain)
    if kin + pot > max_rows:
        raise ValueError(f"Z has {kin + pot} rows, more than max_rows={max_rows}")
    geom = float_geometry(chain)
    maps = [row_maps(geom, t) for t in range(chain.n)]
    labels, rows = [], []
    for b in energy_blocks(geom):
        if not b.rows:
            continue
        psi = maps[b.node][0 if b.kind == KINETIC else 1]
        Z = (psi @ b.coords).T
        head: tuple
        if b.kind == KINETIC:
            Z = Z / geom.kinetic_scale
            assert b.pair is not None  # a kinetic block carries its pair
            head = (KINETIC, *b.pair)
        else:
            head = (POTENTIAL,)
        rows.append(Z)
        for ix in b.index:
            labels.append((*head, decode_index(chain, b.path, ix, b.kind)))
    return labels, np.concatenate(rows, axis=0)


__all__ = ["basis_dimension", "coordinate_matrix", "decode_index", "produced_rows", "row_maps"]
