"""Inverse-dynamics regressor Y(q, qd, qdd) by recursive Newton–Euler, vectorised over samples.

tau = Y(q, qd, qdd) · phi, with phi the standard parameters named in
``params.py`` (Khalil & Dombre, *Modeling, Identification and Control of
Robots*, 2002, ch. 9; Atkeson, An & Hollerbach 1986 for the linearity).

Forward pass (Featherstone's spatial vectors, expressed in the base frame at
its origin): every joint k has the screw S_k = (z_k, o_k × z_k) (revolute) or
(0, z_k) (prismatic), and

    V_j = V_p + S_j qd_j,          A_j = A_p + S_j qdd_j + V_j ×_m S_j qd_j,

with A_0 = (0, -g) so that gravity enters as an upward base acceleration.
Per link, the Newton–Euler wrench about the link frame origin, in link
coordinates, is linear in that link's 10 parameters:

    F = M·a + ω̇ × s + ω × (ω × s),     N = I·ω̇ + ω × (I·ω) + s × a,

(a the classical acceleration of the frame origin, s = (MX, MY, MZ)).
Backward pass: joint k carries the wrenches of every link in its subtree,
tau_k = S_kᵀ · W_j.  Extras add Ia·qdd_k, Fc·sign(qd_k), Fv·qd_k and a
constant, each in its own column.
"""

from __future__ import annotations

import numpy as np

from minparam_cli.chain import REVOLUTE, Chain, forward_kinematics


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross product of (..., 3) arrays (np.cross is slow on small batches)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def _skew(v: np.ndarray) -> np.ndarray:
    """(N, 3) -> (N, 3, 3) cross-product matrices."""
    S = np.zeros(v.shape[:-1] + (3, 3))
    S[..., 0, 1], S[..., 0, 2] = -v[..., 2], v[..., 1]
    S[..., 1, 0], S[..., 1, 2] = v[..., 2], -v[..., 0]
    S[..., 2, 0], S[..., 2, 1] = -v[..., 1], v[..., 0]
    return S


def link_wrench_regressor(omega, domega, acc) -> np.ndarray:
    """Wrench (N; F) about the link origin in link coordinates, as a (N, 6, 10) linear map of phi_j.

    Written out entry by entry: N = L(ω̇)·I + ω×(L(ω)·I) − [a]×·s and
    F = ([ω̇]× + ωωᵀ − |ω|²E)·s + a·M (batched 3x3 products are slow in numpy).
    """
    N = omega.shape[0]
    K = np.zeros((N, 6, 10))
    w1, w2, w3 = omega[:, 0], omega[:, 1], omega[:, 2]
    d1, d2, d3 = domega[:, 0], domega[:, 1], domega[:, 2]
    a1, a2, a3 = acc[:, 0], acc[:, 1], acc[:, 2]
    w11, w22, w33, w12, w13, w23 = w1 * w1, w2 * w2, w3 * w3, w1 * w2, w1 * w3, w2 * w3
    # moment, inertia columns XX XY XZ YY YZ ZZ: L(ω̇) + ω × (L(ω) ·)
    K[:, 0, 0], K[:, 0, 1], K[:, 0, 2], K[:, 0, 3], K[:, 0, 4], K[:, 0, 5] = d1, d2 - w13, d3 + w12, -w23, w22 - w33, w23
    K[:, 1, 0], K[:, 1, 1], K[:, 1, 2], K[:, 1, 3], K[:, 1, 4], K[:, 1, 5] = w13, d1 + w23, w33 - w11, d2, d3 - w12, -w13
    K[:, 2, 0], K[:, 2, 1], K[:, 2, 2], K[:, 2, 3], K[:, 2, 4], K[:, 2, 5] = -w12, w11 - w22, d1 - w23, w12, d2 + w13, d3
    # moment, first-moment columns: s × a = −[a]× s
    K[:, 0, 7], K[:, 0, 8] = a3, -a2
    K[:, 1, 6], K[:, 1, 8] = -a3, a1
    K[:, 2, 6], K[:, 2, 7] = a2, -a1
    # force, first-moment columns: [ω̇]× + ωωᵀ − |ω|² E
    K[:, 3, 6], K[:, 3, 7], K[:, 3, 8] = -w22 - w33, w12 - d3, w13 + d2
    K[:, 4, 6], K[:, 4, 7], K[:, 4, 8] = w12 + d3, -w11 - w33, w23 - d1
    K[:, 5, 6], K[:, 5, 7], K[:, 5, 8] = w13 - d2, w23 + d1, -w11 - w22
    K[:, 3:6, 9] = acc
    return K


def joint_screws(chain: Chain, z: np.ndarray, o: np.ndarray) -> np.ndarray:
    """Unit joint screws (angular; linear at the base origin), (N, n, 6)."""
    S = np.zeros(z.shape[:-1] + (6,))
    for k, kind in enumerate(chain.types):
        if kind == REVOLUTE:
            S[:, k, :3] = z[:, k]
            S[:, k, 3:] = cross(o[:, k], z[:, k])
        else:
            S[:, k, 3:] = z[:, k]
    return S


def _cross_motion(V: np.ndarray, S: np.ndarray) -> np.ndarray:
    w, v = V[..., :3], V[..., 3:]
    ws, vs = S[..., :3], S[..., 3:]
    return np.concatenate([cross(w, ws), cross(w, vs) + cross(v, ws)], axis=-1)


def regressor(chain: Chain, q, qd, qdd, include_extras: bool = True) -> np.ndarray:
    """Y with shape (N, n, P): tau[s, k] = Y[s, k, :] @ phi.

    P = 10 n inertial columns, plus the extra columns of ``chain.layout`` when
    ``include_extras``.
    """
    q, qd, qdd = (np.atleast_2d(np.asarray(x, dtype=float)) for x in (q, qd, qdd))
    N, n = q.shape
    T, z, o = forward_kinematics(chain, q)
    S = joint_screws(chain, z, o)
    V = np.zeros((N, n, 6))
    A = np.zeros((N, n, 6))
    a0 = np.concatenate([np.zeros(3), -chain.gravity])
    for j in range(n):
        p = chain.parents[j]
        Vp = V[:, p] if p >= 0 else np.zeros((N, 6))
        Ap = A[:, p] if p >= 0 else np.broadcast_to(a0, (N, 6))
        V[:, j] = Vp + S[:, j] * qd[:, j, None]
        A[:, j] = Ap + S[:, j] * qdd[:, j, None] + _cross_motion(V[:, j], S[:, j]) * qd[:, j, None]

    layout = chain.layout
    P = layout.size if include_extras else layout.n_inertial
    Y = np.zeros((N, n, P))
    # every link at once: (w, dw, v, a) of the frame origins in link coordinates
    R = T[:, :, :3, :3]
    pos = T[:, :, :3, 3]
    w, dw = V[..., :3], A[..., :3]
    v_origin = V[..., 3:] + cross(w, pos)
    a_origin = A[..., 3:] + cross(dw, pos)
    local = np.matmul(np.swapaxes(R, -1, -2), np.stack([w, dw, v_origin, a_origin], axis=-1))
    w_l, dw_l, v_l = local[..., 0], local[..., 1], local[..., 2]
    acc_l = local[..., 3] + cross(w_l, v_l)
    K = link_wrench_regressor(w_l.reshape(-1, 3), dw_l.reshape(-1, 3), acc_l.reshape(-1, 3)).reshape(N, n, 6, 10)
    # joint k carries link j when k is an ancestor of j.  tau_k = z_k·(moment about the axis) reads, in
    # link j's coordinates, u·N + v·F with u = R_jᵀ z_k and v = R_jᵀ (z_k × (p_j − o_k)) (revolute),
    # u = 0 and v = R_jᵀ z_k (prismatic): one contraction for all (k, j) pairs.
    revolute = np.array([t == REVOLUTE for t in chain.types])
    zr = z * revolute[None, :, None]
    arm = cross(zr[:, None, :, :], pos[:, :, None, :] - o[:, None, :, :])  # (N, j, k, 3)
    if not revolute.all():
        arm[:, :, ~revolute] = z[:, None, ~revolute]
    G = np.empty((N, n, n, 6))  # (sample, link j, joint k, [u v])
    np.matmul(zr[:, None, :, :], R, out=G[..., :3])
    np.matmul(arm, R, out=G[..., 3:])
    carries = np.zeros((n, n))  # carries[j, k]: joint k carries link j
    for j in range(n):
        carries[j, list(chain.ancestors(j))] = 1.0
    G *= carries[None, :, :, None]
    Y[:, :, : 10 * n] = np.matmul(G, K).transpose(0, 2, 1, 3).reshape(N, n, 10 * n)
    if include_extras:
        for c, (k, kind) in enumerate(layout.extra_columns):
            col = layout.n_inertial + c
            if kind == "rotor_inertia":
                Y[:, k, col] = qdd[:, k]
            elif kind == "coulomb":
                Y[:, k, col] = np.sign(qd[:, k])
            elif kind == "viscous":
                Y[:, k, col] = qd[:, k]
            elif kind == "offset":
                Y[:, k, col] = 1.0
    return Y


def random_states(chain: Chain, samples: int, rng: np.random.Generator):
    """Random (q, qd, qdd) for rank studies: revolute q uniform on [-pi, pi),
    prismatic q uniform on ±(largest length of the robot); rates standard normal."""
    n = chain.n
    q = rng.uniform(-np.pi, np.pi, size=(samples, n))
    pris = ~chain.revolute
    if pris.any():
        q[:, pris] = rng.uniform(-1.0, 1.0, size=(samples, int(pris.sum()))) * chain.length_scale
    qd = rng.standard_normal((samples, n))
    qdd = rng.standard_normal((samples, n))
    return q, qd, qdd
