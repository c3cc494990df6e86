"""Exact relations among the friction columns (joint and motor side) on the symbolic route.

Every friction column d acts on the independent coordinates through one direction v_d (exact
rationals): the generalized force of a unit parameter is v_d · f(v_d · q̇).  A joint's friction has
v = k_j e_m (its master coordinate m and mimic multiplier k_j; k_j = 1 without mimic joints); a
motor's has v = N_k, the motor's row of the transmission matrix (θ̇_m = N q̇, τ = Nᵀ τ_m).

* Viscous (f(x) = x): the column is the matrix v vᵀ applied to q̇, so viscous columns are dependent
  exactly when their matrices are: exact elimination over Q on the entries of v vᵀ, in column order
  (the numeric route's keep rule), gives every relation, including a viscous motor of a coupled
  wrist against the joints' (v vᵀ has off-diagonal entries: independent) or two coupled motors whose
  matrices sum to diagonal ones.
* Coulomb (f = sign): sign functions of non-parallel directions are linearly independent; for
  v_d = λ v_r, v_d sign(v_d · q̇) = |λ| v_r sign(v_r · q̇).  An uncoupled motor on joint j with
  ratio r is |r| times the joint's Coulomb column.  Smoothed Coulomb (f = tanh(x / s)) gives the
  same only for |λ| = 1.

Sign and tanh columns are independent of the viscous ones and of every energy column (their
functions are not polynomial in q̇), so these relations are all there are among the friction
columns.  Decimals of the file (ratios, multipliers) are taken as the exact rationals they print
as, as for mimic multipliers.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np

FRICTION = {"coulomb": "coulomb", "viscous": "viscous", "motor_coulomb": "coulomb", "motor_viscous": "viscous"}


def exact_matrix(N) -> list[list[Fraction]]:
    """The transmission matrix as exact rationals (each double as the shortest decimal it prints as)."""
    return [[Fraction(repr(float(x))) for x in row] for row in np.asarray(N, dtype=float)]


def _direction(chain, plan, j: int, kind: str, N) -> list[Fraction]:
    dof = chain.dof
    coords = list(chain.coordinates)
    if kind.startswith("motor_"):
        return list(N[j])
    v = [Fraction(0)] * dof
    k = plan.k[j]
    if k:
        v[coords.index(plan.master[j])] = k
    return v


def friction_relations(chain, cols, plan) -> dict[int, list[tuple[int, Fraction]]]:
    """{friction column d: [(column k, c_k), ...]} with column d = Σ c_k column k exactly, over the
    columns before d that stay (an empty list: column d is zero).  ``cols``: the symbolic route's
    columns (``Column.where[0] == 'free'`` for friction); ``plan``: its ``Coupled`` (masters, k)."""
    from minparam_cli.dynamics.transmission import motor_matrix

    layout = chain.layout
    N = exact_matrix(motor_matrix(chain))
    smooth = chain.coulomb_smoothing > 0.0
    out: dict[int, list[tuple[int, Fraction]]] = {}
    classes: dict[tuple, tuple[int, Fraction]] = {}  # Coulomb: normalised direction -> (column, scale)
    kept_visc: list[tuple[int, list[Fraction]]] = []  # viscous columns kept, with their v vᵀ entries
    for d, c in enumerate(cols):
        if c.where[0] != "free":
            continue
        j, kind = layout.extra_columns[next(iter(c.form)) - layout.n_inertial]
        law = FRICTION.get(kind)
        if law is None:
            continue
        v = _direction(chain, plan, j, kind, N)
        pivot = next((x for x in v if x), None)
        if pivot is None:
            out[d] = []
            continue
        if law == "coulomb":
            if smooth:  # tanh(λ x / s) = λ tanh(x / s) only for |λ| = 1: the key is the direction up to sign
                sign = 1 if pivot > 0 else -1
                key, scale = tuple(x * sign for x in v), Fraction(1)
            else:
                key, scale = tuple(x / pivot for x in v), abs(pivot)
            if key in classes:
                r, s_r = classes[key]
                out[d] = [(r, scale / s_r)]
            else:
                classes[key] = (d, scale)
            continue
        entries = [v[a] * v[b] for a in range(len(v)) for b in range(a, len(v))]
        coef = _combination([e for _, e in kept_visc], entries)
        if coef is None:
            kept_visc.append((d, entries))
        else:
            out[d] = [(k, x) for (k, _), x in zip(kept_visc, coef, strict=True) if x]
    return out


def _combination(basis: list[list[Fraction]], target: list[Fraction]) -> list[Fraction] | None:
    """x with Σ x_i basis_i = target exactly, or None (the basis is independent by construction)."""
    from minparam_cli.base.echelon import solve_dense

    if not basis:
        return None if any(target) else []
    rows = [[b[r] for b in basis] for r in range(len(target))]
    return solve_dense(rows, target, Fraction(0))
