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


def _inertia_operator(w: np.ndarray) -> np.ndarray:
    """L(w) with I·w = L(w)·[XX XY XZ YY YZ ZZ], batched: (N, 3) -> (N, 3, 6)."""
    L = np.zeros(w.shape[:-1] + (3, 6))
    w1, w2, w3 = w[..., 0], w[..., 1], w[..., 2]
    L[..., 0, 0], L[..., 0, 1], L[..., 0, 2] = w1, w2, w3
    L[..., 1, 1], L[..., 1, 3], L[..., 1, 4] = w1, w2, w3
    L[..., 2, 2], L[..., 2, 4], L[..., 2, 5] = w1, w2, w3
    return L


def link_wrench_regressor(omega, domega, acc) -> np.ndarray:
    """Wrench (N; F) about the link origin in link coordinates, as a (N, 6, 10) linear map of phi_j."""
    N = omega.shape[0]
    K = np.zeros((N, 6, 10))
    Wo, dWo, A = _skew(omega), _skew(domega), _skew(acc)
    K[:, 0:3, 0:6] = _inertia_operator(domega) + Wo @ _inertia_operator(omega)
    K[:, 0:3, 6:9] = -A
    K[:, 3:6, 6:9] = dWo + Wo @ Wo
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
    # to the base frame, moments about the base origin
    F_w = R @ K[:, :, 3:6]
    N_w = R @ K[:, :, 0:3] + _skew(pos) @ F_w
    W = np.concatenate([N_w, F_w], axis=2)  # (N, n, 6, 10)
    # joint k carries link j when k is an ancestor of j: tau_k = S_k . W_j
    carries = np.zeros((n, n))
    for j in range(n):
        carries[list(chain.ancestors(j)), j] = 1.0
    Wt = W.transpose(0, 2, 1, 3).reshape(N, 6, 10 * n)
    Y[:, :, : 10 * n] = (S @ Wt) * np.repeat(carries, 10, axis=1)[None]
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
