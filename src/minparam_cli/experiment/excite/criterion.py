"""The design criterion: conditioning of the base regressor, with its gradient.

Stacking the base regressor (``dynamics.regressor`` columns ``kept`` of the base
set, declared extras included) at the samples t_1..t_N of one period gives
W (N·n × p), in SI units (lengths in m).  Two versions of it are used:

    W itself (``--scaling si``, the default), as Gautier & Khalil 1992 and
    FIGAROH minimise and report it, and
    W_s = W D⁻¹, D = diag(‖w_1‖, …, ‖w_p‖) (``--scaling columns``), unit column
    norms, which makes the number independent of units, as identify's
    excitation check reports it.

Measured on three robots (benchmarks/bench_excite.py), minimising κ(W) also
lowers κ(W_s) by 1.7–2×, while minimising κ(W_s) raises κ(W): the SI
criterion is the default.  The criteria, for the singular values
σ_1 ≥ … ≥ σ_p of the chosen matrix:

    cond    f = log κ = log σ_1 − log σ_p                         (reported as κ)
    logdet  f = −(1/p) log det(WᵀW) = −(2/p) Σ_i log σ_i           (D-optimal)

Gradients with respect to the matrix (σ_i simple): ∂σ_i/∂W = u_i v_iᵀ, so
G = u_1 v_1ᵀ/σ_1 − u_p v_pᵀ/σ_p for cond and −(2/p) W (WᵀW)⁻¹ for logdet;
through the column scaling, column c of ∂f/∂W is

    G_c = G_s,c / D_c − w_c (G_s,cᵀ w_c) / D_c³.

The gradient with respect to the joint states at each sample is the
contraction of G with ∂Y/∂q_k, ∂Y/∂q̇_k and ∂Y/∂q̈_k.  Y is linear in q̈ and
quadratic in q̇, so finite differences in q̇ and q̈ are exact (up to
rounding: a forward difference with unit step in q̈, a central one in q̇);
in q a forward difference (step 1e-6 rad or m) is first-order accurate,
about 1e-6 relative, ample for the optimiser.  The extra columns (rotor
inertia q̈_k, viscous q̇_k, Coulomb sign(q̇_k), offset 1) are differentiated
in closed form (sign has zero derivative away from q̇ = 0; the smooth tanh
form its own).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from minparam_cli.chain import Chain
from minparam_cli.dynamics.regressor import regressor

CRITERIA = ("cond", "logdet")
Q_STEP = 1e-6  # rad or m: central-difference step in q


@dataclass(frozen=True, eq=False)
class Sensitivities:
    """Per sample s and coordinate k: ∂f/∂q_k, ∂f/∂q̇_k, ∂f/∂q̈_k (each (N, n)), and when asked the
    torque τ = Y φ (N, n) with ∂τ_i/∂q_k, ∂τ_i/∂q̇_k, ∂τ_i/∂q̈_k (each (N, n_i, n_k))."""

    value: float
    dq: np.ndarray
    ddq_v: np.ndarray
    ddq_a: np.ndarray
    tau: np.ndarray | None = None
    tau_q: np.ndarray | None = None
    tau_v: np.ndarray | None = None
    tau_a: np.ndarray | None = None


def column_norms(W: np.ndarray, scaled: bool = True) -> np.ndarray:
    """D: the column norms of W (1 for a zero column), or ones when not ``scaled``."""
    if not scaled:
        return np.ones(W.shape[1])
    D = np.sqrt(np.einsum("ij,ij->j", W, W))
    return np.where(D > 0, D, 1.0)


def condition_number(W: np.ndarray, scaled: bool = True) -> float:
    """κ(W D⁻¹) (``scaled``, the reported figure; module docstring) or κ(W) in SI units."""
    s = np.linalg.svd(W / column_norms(W, scaled), compute_uv=False)
    return float(s[0] / s[-1]) if s[-1] > 0 else float("inf")


def criterion_value(W: np.ndarray, kind: str, scaled: bool = True) -> float:
    s = np.linalg.svd(W / column_norms(W, scaled), compute_uv=False)
    if s[-1] <= 0:
        return float("inf")
    if kind == "cond":
        return float(np.log(s[0] / s[-1]))
    return float(-2.0 / s.size * np.sum(np.log(s)))


def _svd_thin(Ws: np.ndarray):
    """Σ and V of W_s from the eigen-decomposition of the p × p Gram matrix (p ≪ rows: ~10× faster
    than a thin SVD); a full SVD where the Gram matrix squares κ past double precision."""
    lam, V = np.linalg.eigh(Ws.T @ Ws)
    lam, V = lam[::-1], V[:, ::-1]
    if lam[-1] > lam[0] * 1e-10:
        return np.sqrt(lam), V
    _, s, Vt = np.linalg.svd(Ws, full_matrices=False)
    return s, Vt.T


def criterion_gradient(W: np.ndarray, kind: str, scaled: bool = True) -> tuple[float, np.ndarray]:
    """f and ∂f/∂W (same shape as W) for the stacked base regressor W (rows × p)."""
    D = column_norms(W, scaled)
    Ws = W / D
    s, V = _svd_thin(Ws)
    s = np.maximum(s, s[0] * np.finfo(float).eps)  # rank deficient: finite, pushing σ_p up
    if kind == "cond":
        f = float(np.log(s[0] / s[-1]))
        # u_i v_iᵀ / σ_i = W_s v_i v_iᵀ / σ_i²
        Gs = Ws @ (np.outer(V[:, 0], V[:, 0]) / s[0] ** 2 - np.outer(V[:, -1], V[:, -1]) / s[-1] ** 2)
    elif kind == "logdet":
        p = s.size
        f = float(-2.0 / p * np.sum(np.log(s)))
        Gs = -2.0 / p * Ws @ ((V / s**2) @ V.T)  # W_s (W_sᵀ W_s)⁻¹
    else:
        raise ValueError(f"unknown criterion {kind!r}")
    if not scaled:
        return f, Gs
    G = Gs / D - W * (np.einsum("ij,ij->j", Gs, W) / D**3)
    return f, G


def _extra_derivatives(chain: Chain, qd: np.ndarray):
    """Closed-form ∂/∂q̇_k and ∂/∂q̈_k of the extra columns: lists of (column, k, which, values)."""
    layout = chain.layout
    out = []
    for c, (k, kind) in enumerate(layout.extra_columns):
        col = layout.n_inertial + c
        if kind == "rotor_inertia":
            out.append((col, k, "a", np.ones(qd.shape[0])))
        elif kind == "viscous":
            out.append((col, k, "v", np.ones(qd.shape[0])))
        elif kind == "coulomb" and chain.coulomb_smoothing > 0:
            v = chain.coulomb_smoothing
            out.append((col, k, "v", 1.0 / (v * np.cosh(qd[:, k] / v) ** 2)))
    return out


def _coupling_tangent(chain: Chain, q, qd, qdd):
    """(T, q̇ of every joint): T (N, joints, coordinates) the coupling's Jacobian at each state (None
    without a coupling: the joints are the coordinates, and q̇ is theirs)."""
    coupling = chain.coupling
    if coupling is None:
        return None, qd
    tree_states = getattr(coupling, "tree_states", None)  # a closed chain's: T depends on the state
    if tree_states is not None:
        _, qd_joints, _, T = tree_states(q, qd, qdd)
        return T, qd_joints
    G = np.asarray(coupling.G, dtype=float)
    return np.broadcast_to(G, (len(q),) + G.shape), qd @ G.T


def sensitivities(chain: Chain, kept, q, qd, qdd, kind: str, phi=None, scaled: bool = True) -> Sensitivities:
    """The criterion of the base regressor at the samples (q, q̇, q̈) (N, n) and its derivatives with
    respect to every sample's joint states; with ``phi`` (standard inertial parameters) also the
    rigid-body torques and their derivatives (for the torque limits)."""
    kept = np.asarray(kept)
    N, n = q.shape
    Y = regressor(chain, q, qd, qdd)
    f, Gb = criterion_gradient(Y[:, :, kept].reshape(N * n, -1), kind, scaled)
    G = np.zeros(Y.shape)
    G[:, :, kept] = Gb.reshape(N, n, -1)
    ni = chain.layout.n_inertial
    Gi = G[:, :, :ni]
    with_tau = phi is not None
    phi = None if phi is None else np.asarray(phi, dtype=float)
    out = {w: np.zeros((N, n)) for w in "qva"}
    dtau = {w: np.zeros((N, n, n)) for w in "qva"} if with_tau else None
    Y0 = Y[:, :, :ni]
    # a coupled chain's extra columns (friction, rotor inertia of joint k) reach the coordinates through
    # the coupling's T (N, joints, coordinates); a closed chain's T moves with q, so their q-derivative
    # comes with the inertial columns' difference
    T, qd_joints = _coupling_tangent(chain, q, qd, qdd)
    Yq0, Gq = (Y0, Gi) if T is None else (Y, G)
    extras = _extra_derivatives(chain, qd_joints)
    # a closed chain's q̈ of joint k (a rotor inertia column's signal) carries the drift g_k(q, q̇), quadratic in q̇:
    # its q̇-derivative comes from the central difference of the loops' q̈ (exact), weighted as the column is
    drifting = [(col, kk, np.einsum("sf,sf->s", G[:, :, col], T[:, kk, :])) for col, kk, which, _ in extras
                if which == "a" and T is not None and hasattr(chain.coupling, "tree_states")]
    for k in range(n):
        e = np.zeros(n)
        e[k] = 1.0
        if drifting:
            dg = (chain.coupling.tree_states(q, qd + e, qdd)[2] - chain.coupling.tree_states(q, qd - e, qdd)[2]) / 2.0  # type: ignore[union-attr]  # drifting: a closed chain's coupling
            for _, kk, w in drifting:
                out["v"][:, k] += w * dg[:, kk]
        # q: forward difference (first order, step Q_STEP); q̇: central (exact, Y is quadratic in q̇);
        # q̈: forward with a unit step (exact, Y is linear in q̈)
        dYq = (regressor(chain, q + Q_STEP * e, qd, qdd, include_extras=T is not None) - Yq0) / Q_STEP
        dYv = (regressor(chain, q, qd + e, qdd, include_extras=False) - regressor(chain, q, qd - e, qdd, include_extras=False)) / 2.0
        dYa = regressor(chain, q, qd, qdd + e, include_extras=False) - Y0
        for which, dY in (("q", dYq), ("v", dYv), ("a", dYa)):
            out[which][:, k] += np.einsum("sic,sic->s", Gq if which == "q" else Gi, dY)
            if dtau is not None:
                dtau[which][:, :, k] = dY[:, :, :ni] @ phi
    for col, k, which, values in extras:
        if T is None:
            out[which][:, k] += G[:, k, col] * values
        else:  # Y[s, f, col] = T[s, k, f]·x_k(s) with x_k's rate or acceleration = Σ_f' T[s, k, f']·(that of f')
            w = np.einsum("sf,sf->s", G[:, :, col], T[:, k, :]) * values
            out[which] += w[:, None] * T[:, k, :]
    if dtau is None:
        return Sensitivities(f, out["q"], out["v"], out["a"])
    tau = Y[:, :, :ni] @ phi
    return Sensitivities(f, out["q"], out["v"], out["a"], tau, dtau["q"], dtau["v"], dtau["a"])
