"""The programs codegen writes out: the regressor, the base regressor and the inverse dynamics of a
chain, each one straight-line program recorded by running the Newton–Euler recursion on tracer
values (``trace.py``).

The recursion is the one of ``dynamics/_rnea.c`` and ``dynamics/regressor.py`` (Featherstone's
spatial vectors at the base origin; Khalil & Dombre 2002, ch. 9 for the regressor):

    V_j = V_p + S_j q̇_j,   A_j = A_p + S_j q̈_j + (V_j ×_m S_j) q̇_j,   A_0 = (0, −g),
    K_j  the wrench about link j's origin in link coordinates, linear in its 10 parameters,
    Y[k, 10 j + c] = S_kᵀ (X_j* K_j)[:, c]  for every joint k that carries link j,

then the declared extras (Ia q̈, Fc sign q̇ or tanh(q̇/v_c), Fv q̇, a constant) and, for mimic
joints, Y = Gᵀ·Y_joints.  The geometry enters as constants and is folded while recording, so the
program holds only the arithmetic that depends on the state.

Constants within ``SNAP`` of 0 or ±1 (the float rounding of cos 90°, 6e-17, and its products) are
written as exactly 0 or ±1; this changes the model by at most that relative amount and removes
the operations the rounding would otherwise cost.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from minparam_cli.chain import REVOLUTE, Chain
from minparam_cli.codegen.trace import Program, Sym

SNAP = 1e-15


@dataclass(frozen=True)
class Recorded:
    """A chain's regressor as a program: ``Y[k][c]`` (dof rows × P standard columns), each entry a
    ``Sym`` or a float constant, and the program's inputs q, qd, qdd (one per coordinate)."""

    prog: Program
    Y: list
    q: list
    qd: list
    qdd: list


def _snap(x: float, scale: float = 1.0) -> float:
    x = float(x)
    if abs(x) <= SNAP * scale:
        return 0.0
    for target in (1.0, -1.0):
        if abs(x - target) <= SNAP:
            return target
    return x


def _snapped(M: np.ndarray, scale: float) -> list:
    """A 4x4 transform-like matrix as nested lists of snapped floats (translations against ``scale``)."""
    return [[_snap(M[r][c], scale if c == 3 else 1.0) for c in range(4)] for r in range(4)]


def _cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def _link_wrench(w, d, a) -> list:
    """K (6 x 10): the wrench (moment; force) about the link origin in link coordinates, columns
    XX XY XZ YY YZ ZZ MX MY MZ M (as ``dynamics.regressor.link_wrench_regressor``)."""
    w11, w22, w33 = w[0] * w[0], w[1] * w[1], w[2] * w[2]
    w12, w13, w23 = w[0] * w[1], w[0] * w[2], w[1] * w[2]
    z = 0.0
    return [
        [d[0], d[1] - w13, d[2] + w12, -w23, w22 - w33, w23, z, a[2], -a[1], z],
        [w13, d[0] + w23, w33 - w11, d[1], d[2] - w12, -w13, -a[2], z, a[0], z],
        [-w12, w11 - w22, d[0] - w23, w12, d[1] + w13, d[2], a[1], -a[0], z, z],
        [z, z, z, z, z, z, -w22 - w33, w12 - d[2], w13 + d[1], a[0]],
        [z, z, z, z, z, z, w12 + d[2], -w11 - w33, w23 - d[0], a[1]],
        [z, z, z, z, z, z, w13 - d[1], w23 + d[0], -w11 - w22, a[2]],
    ]


def _dot(xs, ys):
    out = 0.0
    for x, y in zip(xs, ys):
        out = out + x * y
    return out


def record_regressor(chain: Chain) -> Recorded:
    """The full regressor Y(q, q̇, q̈) of ``chain`` (every standard column of ``chain.layout``)."""
    prog = Program()
    dof, n = chain.dof, chain.n
    q, qd, qdd = prog.input("q", dof), prog.input("qd", dof), prog.input("qdd", dof)
    if chain.coupling is None:
        qj, qdj, qddj = q, qd, qdd
    else:  # every joint's state from the coordinates: q_joint = G q + offset
        G, off = chain.coupling.G, chain.coupling.offset
        qj = [_dot([_snap(g) for g in G[j]], q) + _snap(off[j]) for j in range(n)]
        qdj = [_dot([_snap(g) for g in G[j]], qd) for j in range(n)]
        qddj = [_dot([_snap(g) for g in G[j]], qdd) for j in range(n)]
    L = chain.length_scale
    g = [_snap(x, 10.0) for x in chain.gravity]
    T, S, V, A = [], [], [], []
    Yj = [[0.0] * (10 * n) for _ in range(n)]
    for j, ((C0, C1, C2), axis, origin) in enumerate(chain.local_terms):
        c0, c1 = _snapped(C0, L), _snapped(C1, L)
        if chain.types[j] == REVOLUTE:
            c2 = _snapped(C2, L)
            sn, vc = prog.call("sin", qj[j]), 1.0 - prog.call("cos", qj[j])
            Lm = [[c0[r][c] + sn * c1[r][c] + vc * c2[r][c] for c in range(4)] for r in range(3)]
        else:
            Lm = [[c0[r][c] + qj[j] * c1[r][c] for c in range(4)] for r in range(3)]
        ax = [_snap(x) for x in axis]
        org = [_snap(x, L) for x in origin]
        p = chain.parents[j]
        if p < 0:
            Tj = Lm
            z, o = ax, org
        else:
            Tp = T[p]
            Tj = [[Tp[r][0] * Lm[0][c] + Tp[r][1] * Lm[1][c] + Tp[r][2] * Lm[2][c] + (Tp[r][3] if c == 3 else 0.0)
                   for c in range(4)] for r in range(3)]
            z = [Tp[r][0] * ax[0] + Tp[r][1] * ax[1] + Tp[r][2] * ax[2] for r in range(3)]
            o = [Tp[r][0] * org[0] + Tp[r][1] * org[1] + Tp[r][2] * org[2] + Tp[r][3] for r in range(3)]
        T.append(Tj)
        Sj = z + _cross(o, z) if chain.types[j] == REVOLUTE else [0.0, 0.0, 0.0] + z
        S.append(Sj)
        Vp = [0.0] * 6 if p < 0 else V[p]
        Ap = [0.0, 0.0, 0.0, -g[0], -g[1], -g[2]] if p < 0 else A[p]
        Vj = [Vp[i] + Sj[i] * qdj[j] for i in range(6)]
        c1v, c2v, c3v = _cross(Vj[:3], Sj[:3]), _cross(Vj[:3], Sj[3:]), _cross(Vj[3:], Sj[:3])
        Aj = [Ap[i] + Sj[i] * qddj[j] + c1v[i] * qdj[j] for i in range(3)]
        Aj += [Ap[3 + i] + Sj[3 + i] * qddj[j] + (c2v[i] + c3v[i]) * qdj[j] for i in range(3)]
        V.append(Vj)
        A.append(Aj)
        pos = [Tj[0][3], Tj[1][3], Tj[2][3]]
        t = _cross(Vj[:3], pos)
        vo = [Vj[3 + i] + t[i] for i in range(3)]
        t = _cross(Aj[:3], pos)
        ao = [Aj[3 + i] + t[i] for i in range(3)]
        t = _cross(Vj[:3], vo)
        ao = [ao[i] + t[i] for i in range(3)]

        def local(x):
            return [Tj[0][c] * x[0] + Tj[1][c] * x[1] + Tj[2][c] * x[2] for c in range(3)]

        K = _link_wrench(local(Vj[:3]), local(Aj[:3]), local(ao))
        for c in range(10):  # to the base origin in base coordinates: f0 = R Kf, n0 = R Kn + pos × f0
            f = [Tj[r][0] * K[3][c] + Tj[r][1] * K[4][c] + Tj[r][2] * K[5][c] for r in range(3)]
            m = [Tj[r][0] * K[0][c] + Tj[r][1] * K[1][c] + Tj[r][2] * K[2][c] for r in range(3)]
            t = _cross(pos, f)
            W = [m[r] + t[r] for r in range(3)] + f
            k = j
            while k >= 0:  # every joint from j back to the root carries link j
                Yj[k][10 * j + c] = _dot(S[k], W)
                k = chain.parents[k]
    layout = chain.layout
    cols = list(layout.inertial_columns)
    rows = [[Yj[k][c] for c in cols] + [0.0] * len(layout.extra_columns) for k in range(n)]
    for e, (k, kind) in enumerate(layout.extra_columns):
        col = layout.n_inertial + e
        if kind == "rotor_inertia":
            rows[k][col] = qddj[k]
        elif kind == "coulomb":
            rows[k][col] = coulomb(prog, qdj[k], chain.coulomb_smoothing)
        elif kind == "viscous":
            rows[k][col] = qdj[k]
        elif kind == "offset":
            rows[k][col] = 1.0
    if chain.coupling is not None:  # virtual work: Y = Gᵀ Y_joints
        G = chain.coupling.G
        rows = [[_dot([_snap(G[j, i]) for j in range(n)], [rows[j][c] for j in range(n)]) for c in range(layout.size)]
                for i in range(dof)]
    return Recorded(prog, rows, q, qd, qdd)


def coulomb(prog: Program, qd, smoothing: float):
    """sign(q̇), or tanh(q̇ / v_c) when the chain's Coulomb smoothing v_c > 0."""
    if smoothing > 0.0:
        return prog.call("tanh", qd * (1.0 / smoothing))
    return prog.call("sign", qd)


def base_columns(rec: Recorded, kept) -> list:
    """Y_b: the kept columns of the full regressor, (dof rows × n_base)."""
    return [[row[c] for c in kept] for row in rec.Y]


def effect_columns(prog: Program, effect: str, q, qd, qdd, tau_model, hyper, smoothing: float) -> list:
    """The columns of one identified effect on one joint (as ``identify.effects.EFFECTS``), traced.
    ``tau_model``: that joint's rigid-body model torque (for gain and load_coulomb)."""
    sgn = (lambda: coulomb(prog, qd, smoothing))
    if effect == "coulomb":
        return [sgn()]
    if effect == "viscous":
        return [qd]
    if effect == "offset":
        return [1.0]
    if effect == "rotor_inertia":
        return [qdd]
    if effect == "stribeck":
        x = qd * (1.0 / hyper)
        return [prog.call("exp", -(x * x)) * sgn()]
    if effect == "asymmetric_coulomb":
        if smoothing > 0.0:
            g = sgn()
            return [0.5 * (1.0 + g), -0.5 * (1.0 - g)]
        return [prog.call("pos", qd), -prog.call("negind", qd)]
    if effect == "spring":
        return [q, prog.call("sin", q), prog.call("cos", q)]
    if effect == "cogging":
        return [prog.call("sin", hyper * q), prog.call("cos", hyper * q)]
    if effect == "load_coulomb":
        return [sgn() * prog.call("abs", tau_model)]
    if effect == "gain":
        return [tau_model]
    raise ValueError(f"effect {effect!r} has no code form")


# effects a controller cannot evaluate from (q, q̇, q̈): left out of the generated torque, with a note
TIME_EFFECTS = ("drift",)


def inverse_dynamics(rec: Recorded, kept, theta, terms=(), theta_model=None, smoothing: float = 0.0):
    """τ = Y_b θ_b + Σ effect columns · their coefficients, traced.  ``theta``: the model's
    parameters (base parameters first, then each term's columns); ``terms``: the model's design
    terms (``identify.design.Term``).  Returns (τ per coordinate, the terms left out)."""
    prog = rec.prog
    Yb = base_columns(rec, kept)
    nb = len(kept)
    tau = [_dot(row, [float(t) for t in theta[:nb]]) for row in Yb]
    tau_model = None
    if theta_model is not None:
        tau_model = [_dot(row, [float(t) for t in theta_model[:nb]]) for row in Yb]
    from minparam_cli.identify.effects import EFFECTS

    c = nb
    omitted = []
    for term in terms:
        m = len(EFFECTS[term.effect].column_names)
        if term.effect in TIME_EFFECTS:
            omitted.append(term)
            c += m * len(term.joints)
            continue
        for j in term.joints:
            tm = None if tau_model is None else tau_model[j]
            cols = effect_columns(prog, term.effect, rec.q[j], rec.qd[j], rec.qdd[j], tm, term.hyper, smoothing)
            for x, coef in zip(cols, theta[c : c + m]):
                tau[j] = tau[j] + x * float(coef)
            c += m
    return tau, tuple(omitted)


def is_sym(x) -> bool:
    return isinstance(x, Sym)
