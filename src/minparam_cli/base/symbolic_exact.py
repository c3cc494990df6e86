"""The exact regrouping: Khalil's rules generalised (stage 1), exact relations among what they
leave (stage 2), and the change to the numeric route's kept set (stage 3).

Stage 1 (exact by a theorem, no sampling).  For joint j about/along z of its joint frame
J'_j = F_parent · P_j · Motion_z(q_j), write link j's accumulated parameters in J'_j
(φ' = X(A_j) φ_j, ``params_to_frame``).  A body invariant under the joint's motion has the same
energy on link j as rigidly fixed to the parent, so it moves to the parent exactly:

* revolute: ψ = (YY', 0, 0, YY', 0, 0, 0, 0, MZ', M') is invariant under rotations about z;
  link j keeps XX'−YY', XY', XZ', YZ', ZZ', MX', MY';
* prismatic: ψ = (XX' … ZZ', 0, 0, 0, 0) (rotational inertia alone) is invariant under
  translations along z; link j keeps MX', MY', MZ', M';

ψ is added to the parent as X(P_j) ψ, and dropped at the fixed base (constant energy).  From
the last joint to the first, this is Gautier & Khalil's recursion for any axis placement.

Stage 2 (exact coefficients).  The Lagrangian is now Σ_k ℓ_k(φ) w_k(q, q̇) with ℓ_k the grouped
parameters (linear forms, coefficients in Q(symbols)) and w_k their energy coefficient
functions; a relation among the regressor's columns is a relation Σ c_k w_k = const.  Which
columns are dependent, and on which others, is decided at a random float geometry and random
states (the numeric route's rank decision).  The coefficients c_k are then the unique solution
of the exact linear system Σ c_k (w_k(s_i) − w_k(s_0)) = 0 at rational states s_i (cos/sin of
each angle from a rational point of the unit circle), solved in Q(symbols); one more state
than unknowns checks the relation exactly.  Each relation moves ℓ_d onto the others:
ℓ_k += c_k ℓ_d.

Stage 3.  The surviving forms span the same space as the numeric route's base parameters; for
its kept set the regrouping matrix is K = A_kept⁻¹ A, solved by sparse exact elimination.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any

import numpy as np

from minparam_cli.base.symbolic_frames import (
    MX,
    MY,
    MZ,
    XX,
    XY,
    XZ,
    YY,
    YZ,
    ZZ,
    Arith,
    M,
    energy_coefficients,
    transfer_matrix,
)
from minparam_cli.base.echelon import solve_dense
from minparam_cli.base.symbolic_coupled import Coupled
from minparam_cli.chain import PRISMATIC
from minparam_cli.errors import ComputationError
from minparam_cli.params import N_LINK_PARAMS

REVOLUTE_KEEP = (XX, XY, XZ, YZ, ZZ, MX, MY)
PRISMATIC_KEEP = (MX, MY, MZ, M)
RANK_RTOL = 1e-8  # a column of the energy differences is dependent below this residual (relative)
COEF_RTOL = 1e-9  # a relation's float coefficient below this (relative) is taken as absent


# --- linear forms: {standard column: coefficient} -----------------------------


def _axpy(out: dict, a, form: dict) -> None:
    for k, v in form.items():
        w = out.get(k)
        w = a * v if w is None else w + a * v
        if w:
            out[k] = w
        else:
            out.pop(k, None)


def _apply(Xm, forms: list[dict]) -> list[dict]:
    out = []
    for row in Xm:
        f: dict = {}
        for a, form in zip(row, forms, strict=True):
            if a:
                _axpy(f, a, form)
        out.append(f)
    return out


class Column:
    """One grouped column: its form ℓ (linear in the standard parameters) and where its
    energy function lives: ('link', j, kind), ('rotor', j), ('offset', j), ('motor', k, N_k,
    coordinates) for a motor's rotor, or ('free', name) for a column no energy term can produce
    (friction, joint or motor side: base/symbolic_friction.py)."""

    def __init__(self, form: dict, where: tuple, label: str):
        self.form, self.where, self.label = form, where, label


def stage1(desc, chain, ar: Arith, transforms) -> list[Column]:
    """Khalil's rules generalised, in the arithmetic ``ar``."""
    n = chain.n
    layout = chain.layout
    # a massless virtual link of a floating base has no columns: its forms start empty
    first = {j: N_LINK_PARAMS * k for k, j in enumerate(layout.links_with_columns)}
    acc = [[{first[j] + i: ar.one} if j in first else {} for i in range(N_LINK_PARAMS)] for j in range(n)]
    cols: list[Column] = []
    from minparam_cli.params import LINK_PARAMS

    per_link: dict[int, list[Column]] = {}
    psi_idx: tuple[int, ...]
    keep: tuple[int, ...]
    for j in range(n - 1, -1, -1):
        P, A = transforms[j]
        phi = _apply(transfer_matrix(A, ar), acc[j])
        if chain.types[j] == PRISMATIC:
            psi_idx, keep = (XX, XY, XZ, YY, YZ, ZZ), PRISMATIC_KEEP
            psi = [phi[i] if i in psi_idx else {} for i in range(N_LINK_PARAMS)]
        else:
            keep = REVOLUTE_KEEP
            psi = [{} for _ in range(N_LINK_PARAMS)]
            psi[XX], psi[YY], psi[MZ], psi[M] = phi[YY], phi[YY], phi[MZ], phi[M]
            xx = dict(phi[XX])
            _axpy(xx, -ar.one, phi[YY])
            phi = list(phi)
            phi[XX] = xx
        per_link[j] = [Column(phi[i], ("link", j, i), f"{LINK_PARAMS[i]}'{j + 1}") for i in keep]
        p = chain.parents[j]
        if p >= 0:
            moved = _apply(transfer_matrix(P, ar), psi)
            for i in range(N_LINK_PARAMS):
                _axpy(acc[p][i], ar.one, moved[i])
    for j in range(n):
        cols += per_link[j]
    from minparam_cli.base.symbolic_friction import exact_matrix
    from minparam_cli.dynamics.transmission import motor_matrix

    motor_rows = exact_matrix(motor_matrix(chain))
    for idx, (j, kind) in enumerate(layout.extra_columns):
        c = layout.n_inertial + idx
        name = layout.names[c]
        if kind == "rotor_inertia":
            cols.append(Column({c: ar.one}, ("rotor", j), name))
        elif kind == "offset":  # energy −q_j: a constant generalized force on joint j
            cols.append(Column({c: ar.one}, ("offset", j), name))
        elif kind == "motor_inertia":  # energy ½ (N_j · q̇)² of motor j's rotor (base/symbolic_friction.py: N exact)
            cols.append(Column({c: ar.one}, ("motor", j, tuple(motor_rows[j]), tuple(chain.coordinates)), name))
        else:
            cols.append(Column({c: ar.one}, ("free", name), name))
    return cols


def _link_of(c: Column) -> int:
    """The deepest link whose energy the column needs (-1: none)."""
    return c.where[1] if c.where[0] not in ("free", "motor") else -1


def column_values(desc, cols, ar: Arith, transforms, state, only=None) -> list:
    """w_k at one state (None for 'free' columns and for columns not in ``only``)."""
    cq, sq, q, qd = state
    upto = None if only is None else max((_link_of(cols[k]) for k in only), default=-1)
    e = energy_coefficients(desc, transforms, ar, cq, sq, q, qd, upto)
    out: list[Any] = []  # numbers of the arithmetic, or None
    half = ar.const(Fraction(1, 2))
    for k, c in enumerate(cols):
        w = c.where
        if only is not None and k not in only:
            out.append(None)
        elif w[0] == "link":
            out.append(e[w[1]][w[2]])
        elif w[0] == "rotor":
            out.append(half * qd[w[1]] * qd[w[1]])
        elif w[0] == "offset":
            out.append(-q[w[1]])
        elif w[0] == "motor":
            rate = sum((ar.const(x) * qd[j] for x, j in zip(w[2], w[3], strict=True) if x), ar.zero)
            out.append(half * rate * rate)
        else:
            out.append(None)
    return out


def numeric_relations(desc, chain, cols, far: Arith, ftrans, rng, plan: Coupled):
    """(independent column indices, {dependent: support}) decided at floats, scan order."""
    energy = [k for k, c in enumerate(cols) if c.where[0] != "free"]
    n_states = 2 * len(energy) + 10
    rows = []
    for _ in range(n_states):
        v = column_values(desc, cols, far, ftrans, plan.float_state(rng))
        rows.append([v[k] for k in energy])
    D = np.array(rows[1:]) - np.array(rows[0])
    norms = np.linalg.norm(D, axis=0)
    top = max(float(norms.max(initial=0.0)), 1e-300)
    basis: list[np.ndarray] = []
    indep, dep = [], []
    for i, k in enumerate(energy):
        col = D[:, i]
        if norms[i] <= 1e-10 * top:
            dep.append((k, i))
            continue
        res = col.copy()
        for b in basis:
            res -= (b @ res) * b
        if np.linalg.norm(res) > RANK_RTOL * norms[i]:
            basis.append(res / np.linalg.norm(res))
            indep.append((k, i))
        else:
            dep.append((k, i))
    relations: dict[int, list[int]] = {}
    Di = D[:, [i for _, i in indep]]
    for k, i in dep:
        if norms[i] <= 1e-10 * top:
            relations[k] = []
            continue
        coef, *_ = np.linalg.lstsq(Di, D[:, i], rcond=None)
        size = np.abs(coef) * np.linalg.norm(Di, axis=0)
        relations[k] = [indep[m][0] for m in range(len(indep)) if size[m] > COEF_RTOL * norms[i]]
    free = [k for k, c in enumerate(cols) if c.where[0] == "free"]
    return sorted([k for k, _ in indep] + free), relations


def exact_relations(desc, chain, cols, ar: Arith, transforms, relations, rng, rat: Arith, rat_transforms, plan: Coupled):
    """Stage 2: exact c for every numeric relation; the forms moved onto the independent ones.

    ``rat``: the rational arithmetic at a random rational geometry, where vanishing columns are
    checked (exactly, in Fractions)."""
    states: list = []  # rational states, shared by every relation

    def state(i):
        while len(states) <= i:
            states.append(plan.rational_state(rng, ar))
        return states[i]

    cache: dict = {}

    def values(i, only):
        key = (i, max(_link_of(cols[k]) for k in only))
        if key not in cache:
            cache[key] = column_values(desc, cols, ar, transforms, state(i), only={k for k in range(len(cols)) if _link_of(cols[k]) <= key[1]})
        return cache[key]

    forms = {k: dict(c.form) for k, c in enumerate(cols)}
    zero_cols = [d for d, support in relations.items() if not support]
    if zero_cols:
        rs = [plan.rational_state(rng, rat) for _ in range(2)]
        v1, v0 = (column_values(desc, cols, rat, rat_transforms, s, only=set(zero_cols)) for s in rs)
        for d in zero_cols:
            if v1[d] - v0[d]:
                raise ComputationError(f"{desc.source}: column {cols[d].label} vanishes at a random geometry but not exactly")
    for d, support in relations.items():
        if support:
            need = len(support) + 2
            rows, rhs = [], []
            only = set(support) | {d}
            for i in range(1, need):
                v, v0 = values(i, only), values(0, only)
                rows.append([v[k] - v0[k] for k in support])
                rhs.append(v[d] - v0[d])
            coef = solve_dense(rows, rhs, ar.zero)
            if coef is not None:  # without the common factors that carry the states' numbers (Frac.canonical)
                coef = [c.shorter_canonical() if c else c for c in coef]
            if coef is None:
                raise ComputationError(
                    f"{desc.source}: column {cols[d].label} is dependent at a random geometry but no exact relation "
                    f"on {', '.join(cols[k].label for k in support)} holds")
            for k, c in zip(support, coef, strict=True):
                if c:
                    _axpy(forms[k], c, forms[d])
        forms.pop(d)
    from minparam_cli.base.symbolic_friction import friction_relations

    for d, support in friction_relations(chain, cols, plan).items():
        for k, f in support:
            _axpy(forms[k], ar.const(f), forms[d])
        forms.pop(d)
    return forms


def regrouping(forms: dict, kept: tuple[int, ...], dependent: tuple[int, ...], unident: tuple[int, ...], ar: Arith, source: str):
    """Stage 3: {(base row i, dependent column): exact β} for the numeric route's kept set."""
    rows = [f for f in forms.values() if f]
    if len(rows) < len(kept):
        raise ComputationError(f"{source}: {len(rows)} exact base parameters against {len(kept)} of the numeric route")
    stray = {c for f in rows for c in f} & set(unident)
    if stray:
        raise ComputationError(f"{source}: a column without effect appears in an exact base parameter")
    kept_set = set(kept)
    rows = [dict(f) for f in rows]
    pivot_of: dict[int, int] = {}
    order = sorted(kept, key=lambda c: sum(1 for f in rows if c in f))
    done = set()
    for c in order:  # Gauss-Jordan on the kept columns, sparsest column first
        cand = [i for i in range(len(rows)) if i not in done and c in rows[i]]
        if not cand:
            raise ComputationError(f"{source}: the numeric route's kept set is singular for the exact base parameters")
        i = min(cand, key=lambda i: sum(1 for k in rows[i] if k in kept_set))
        inv = ar.one / rows[i][c]
        rows[i] = {k: v * inv for k, v in rows[i].items()}
        for r in range(len(rows)):
            if r != i and c in rows[r]:
                _axpy(rows[r], -rows[r][c], rows[i])
        done.add(i)
        pivot_of[c] = i
    # forms can be linearly dependent (a floating base: the free body's parameters reach the
    # virtual links through several rules); the base parameters are their span, so the rows
    # left after the kept pivots must vanish exactly
    extra = [i for i in range(len(rows)) if i not in done and rows[i]]
    if extra:
        raise ComputationError(f"{source}: {len(kept) + len(extra)} exact base parameters against {len(kept)} of the numeric route")
    out = {}
    for bi, c in enumerate(kept):
        row = rows[pivot_of[c]]
        for jj, d in enumerate(dependent):
            v = row.get(d)
            if v:
                out[bi, jj] = v
        if any(k in kept_set and k != c for k in row):
            raise ComputationError(f"{source}: exact elimination left a kept column in another row")
    return out
