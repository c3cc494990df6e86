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

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from minparam_cli.chain import REVOLUTE, Chain
from minparam_cli.codegen.trace import Program
from minparam_cli.dynamics.transmission import motor_matrix
from minparam_cli.params import MOTOR_KINDS

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
    # for the torque at given parameters (``torque``): per link j, K_j and {k: u_kj}; the chain
    # column of each layout inertial column; per joint, its rows before the coupling; G or None
    links: list = field(default_factory=list)
    inertial_columns: tuple = ()
    joint_rows: list = field(default_factory=list)
    G: list[list[float]] | None = None


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
    for x, y in zip(xs, ys, strict=True):
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
    # entries are float constants or Sym nodes of ``prog`` (Any: the two mix in one arithmetic)
    V: list[list[Any]] = []
    A: list[list[Any]] = []
    U: list[dict[int, list[Any]]] = []
    links: list[tuple[list[list[Any]], dict[int, list[Any]]]] = []
    Yj: list[list[Any]] = [[0.0] * (10 * n) for _ in range(n)]
    for j, ((C0, C1, C2), _, _) in enumerate(chain.local_terms):
        c0, c1 = _snapped(C0, L), _snapped(C1, L)
        if chain.types[j] == REVOLUTE:
            c2 = _snapped(C2, L)
            # C0 + s C1 + (1 − c) C2 written (C0 + C2) + s C1 − c C2: the constant part folds, and an
            # entry cos q stays cos q (not 1 − (1 − cos q))
            sn, cs = prog.call("sin", qj[j]), prog.call("cos", qj[j])
            Lm = [[_snap(C0[r][c] + C2[r][c], L if c == 3 else 1.0) + sn * c1[r][c] - cs * c2[r][c] for c in range(4)]
                  for r in range(3)]
        else:
            Lm = [[c0[r][c] + qj[j] * c1[r][c] for c in range(4)] for r in range(3)]
        pL = [Lm[0][3], Lm[1][3], Lm[2][3]]

        def to_child(u, Lm=Lm, pL=pL):
            """A motion vector (ω; v at the parent's origin, parent coordinates) in link j's frame."""
            t = _cross(u[:3], pL)
            v = [u[3 + i] + t[i] for i in range(3)]
            return [Lm[0][c] * u[0] + Lm[1][c] * u[1] + Lm[2][c] * u[2] for c in range(3)] + \
                [Lm[0][c] * v[0] + Lm[1][c] * v[1] + Lm[2][c] * v[2] for c in range(3)]

        # joint j's screw in link j's frame, a constant: the axis a passes through the origin of
        # F_parent·Pre, the motion leaves it in place, and Post moves it: (R_postᵀ a, R_postᵀ (a × p_post))
        post = chain.post[j]
        Rp = [[_snap(post[r][c]) for c in range(3)] for r in range(3)]
        pp = [_snap(post[r][3], L) for r in range(3)]
        a = [_snap(x) for x in chain.axes[j]]
        a_post = [Rp[0][c] * a[0] + Rp[1][c] * a[1] + Rp[2][c] * a[2] for c in range(3)]
        if chain.types[j] == REVOLUTE:
            t = _cross(a, pp)
            own = a_post + [Rp[0][c] * t[0] + Rp[1][c] * t[1] + Rp[2][c] * t[2] for c in range(3)]
        else:
            own = [0.0, 0.0, 0.0] + a_post
        # forward pass in link frames (Luh, Walker & Paul 1980; Khalil & Kleinfinger 1987):
        # V_j = X V_p + s q̇,  A_j = X A_p + s q̈ + (V_j ×_m s) q̇,  A_0 = (0, −g) in the base frame
        p = chain.parents[j]
        Vp = [0.0] * 6 if p < 0 else V[p]
        Ap = [0.0, 0.0, 0.0, -g[0], -g[1], -g[2]] if p < 0 else A[p]
        XV, XA = to_child(Vp), to_child(Ap)
        Vj = [XV[i] + own[i] * qdj[j] for i in range(6)]
        c1v, c2v, c3v = _cross(Vj[:3], own[:3]), _cross(Vj[:3], own[3:]), _cross(Vj[3:], own[:3])
        Aj = [XA[i] + own[i] * qddj[j] + c1v[i] * qdj[j] for i in range(3)]
        Aj += [XA[3 + i] + own[3 + i] * qddj[j] + (c2v[i] + c3v[i]) * qdj[j] for i in range(3)]
        V.append(Vj)
        A.append(Aj)
        t = _cross(Vj[:3], Vj[3:])  # the classical acceleration of the origin: a = A_lin + ω × v
        acc = [Aj[3 + i] + t[i] for i in range(3)]
        K = _link_wrench(Vj[:3], Aj[:3], acc)
        # the screw of every joint k that carries link j, in link j's frame (Khalil's projection in
        # the link frame, where K_j is sparse and the local transforms hold the geometry's zeros)
        screws = {j: own}
        if p >= 0:
            for k, u in U[p].items():
                screws[k] = to_child(u)
        U.append(screws)
        links.append((K, screws))
        for k, u in screws.items():  # every joint from j back to the root carries link j
            for c in range(10):
                Yj[k][10 * j + c] = _dot(u, [K[r][c] for r in range(6)])
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
        elif kind in MOTOR_KINDS:  # motor k of a transmission θ_m = N q: Nᵀ e_k f_k (dynamics/transmission.py)
            Nk = [_snap(float(x)) for x in motor_matrix(chain)[k]]
            if kind == "motor_inertia":
                f = _dot(Nk, qddj)
            elif kind == "motor_viscous":
                f = _dot(Nk, qdj)
            else:
                f = coulomb(prog, _dot(Nk, qdj), chain.coulomb_smoothing)
            for i, r in enumerate(Nk):
                if r != 0.0:
                    rows[i][col] = f * r
    joint_rows, Gs = rows, None
    if chain.coupling is not None:  # virtual work: Y = Gᵀ Y_joints
        Gs = [[_snap(x) for x in row] for row in chain.coupling.G]
        rows = [[_dot([Gs[j][i] for j in range(n)], [joint_rows[j][c] for j in range(n)]) for c in range(layout.size)]
                for i in range(dof)]
    return Recorded(prog, rows, q, qd, qdd, links, tuple(cols), joint_rows, Gs)


def torque(rec: Recorded, phi) -> list:
    """τ = Y(q, q̇, q̈)·φ for constant standard parameters φ (layout order), traced as the
    Newton–Euler torque itself: each link's wrench w_j = K_j φ_j once, then τ_k = Σ_j u_kjᵀ w_j over
    the links joint k carries (6 products a link instead of one 6-vector product per column)."""
    n = len(rec.joint_rows)
    chain_phi = [0.0] * (10 * n)
    for i, c in enumerate(rec.inertial_columns):
        chain_phi[c] = float(phi[i])
    tau = [0.0] * n
    for j, (K, screws) in enumerate(rec.links):
        pj = chain_phi[10 * j : 10 * j + 10]
        if not any(pj):
            continue
        w = [_dot(K[r], pj) for r in range(6)]
        for k, u in screws.items():
            tau[k] = tau[k] + _dot(u, w)
    first = len(rec.inertial_columns)
    for k, row in enumerate(rec.joint_rows):  # the extras: their own columns of joint k's row
        for c in range(first, len(row)):
            if float(phi[c]) != 0.0:
                tau[k] = tau[k] + row[c] * float(phi[c])
    if rec.G is None:
        return tau
    return [_dot([rec.G[j][i] for j in range(n)], tau) for i in range(len(rec.G[0]))]


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
    def sgn():
        return coulomb(prog, qd, smoothing)

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
        return [q, 1.0]
    if effect == "gravity_error":
        return [prog.call("sin", q), prog.call("cos", q)]
    if effect == "spring_v1":  # the spring of model files of format version 1
        return [q, prog.call("sin", q), prog.call("cos", q)]
    if effect in ("cogging", "position_error"):
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
    nb = len(kept)
    P = len(rec.joint_rows[0])

    def standard(values):  # Y_b θ_b = Y φ with φ = θ_b at the kept columns, 0 elsewhere
        phi = np.zeros(P)
        phi[list(kept)] = np.asarray(values[:nb], dtype=float)
        return phi

    tau = torque(rec, standard(theta))
    tau_model = None if theta_model is None else torque(rec, standard(theta_model))
    from minparam_cli.dynamics.effects import EFFECTS

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
            for x, coef in zip(cols, theta[c : c + m], strict=True):
                tau[j] = tau[j] + x * float(coef)
            c += m
    return tau, tuple(omitted)
