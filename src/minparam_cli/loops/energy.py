"""The energy route (Gautier & Khalil's energy model, on the constraint manifold): the kinetic energy
½ q̇_aᵀ GᵀMG q̇_a and the potential energy are linear in the standard parameters, with coefficients that
need no accelerations and no Newton–Euler recursion:

    T = Σ_j ½ ω_jᵀ I_j ω_j + (m s)_j · (v_j × ω_j) + ½ M_j |v_j|²,   V = −Σ_j g · (M_j p_j + R_j (m s)_j)

(ω_j, v_j the angular velocity and the velocity of link j's frame origin in link j's frame; rotor
inertia adds ½ Ia q̇_j²).  The torques are the Lagrange derivative of T − V, so a combination of
parameters is invisible in the torques exactly when it is invisible in T and in V up to a constant:
stacking T's rows and V's rows (less their value at the reference) over manifold states gives the
same rank and the same regrouping as the Newton–Euler route, which ``energy_check`` confirms.
"""

from __future__ import annotations

import numpy as np

from minparam_cli.base.qr import base_from_regressor
from minparam_cli.chain import forward_kinematics
from minparam_cli.dynamics.regressor import cross
from minparam_cli.loops.model import ClosedModel, closed_scales, spatial_motion
from minparam_cli.loops.sample import manifold_states

# the two routes' regroupings agree when no coefficient differs by more than this (relative to 1)
AGREE_TOL = 1e-6


def energy_rows(model: ClosedModel, q: np.ndarray, qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Coefficient rows (N, P) of the kinetic and of the potential energy in the standard parameters."""
    chain = model.chain
    layout = chain.layout
    T, z, o = forward_kinematics(chain, q)
    S = np.concatenate([z, cross(o, z)], axis=2)
    pris = np.array([t != "revolute" for t in chain.types])
    S[:, pris, 3:], S[:, pris, :3] = z[:, pris], 0.0
    V, _ = spatial_motion(chain, S, qd, np.zeros_like(qd))
    N = len(q)
    kin, pot = np.zeros((N, layout.size)), np.zeros((N, layout.size))
    g = chain.gravity
    for slot, j in enumerate(layout.links_with_columns):  # massless links (a universal joint's cross) have none
        R, p = T[:, j, :3, :3], T[:, j, :3, 3]
        w = V[:, j, :3]
        v = V[:, j, 3:] + cross(w, p)
        wb, vb = np.einsum("sji,sj->si", R, w), np.einsum("sji,sj->si", R, v)
        c = 10 * slot
        kin[:, c:c + 6] = np.stack([wb[:, 0] ** 2 / 2, wb[:, 0] * wb[:, 1], wb[:, 0] * wb[:, 2], wb[:, 1] ** 2 / 2,
                                    wb[:, 1] * wb[:, 2], wb[:, 2] ** 2 / 2], axis=1)
        kin[:, c + 6:c + 9] = cross(vb, wb)
        kin[:, c + 9] = 0.5 * np.einsum("si,si->s", vb, vb)
        pot[:, c + 6:c + 9] = -np.einsum("sji,j->si", R, g)
        pot[:, c + 9] = -p @ g
    for i, (k, kind) in enumerate(layout.extra_columns):
        if kind == "rotor_inertia":
            kin[:, layout.n_inertial + i] = 0.5 * qd[:, k] ** 2
    return kin, pot


def energy_columns(model: ClosedModel) -> list[int]:
    """The columns the energy sees: inertial parameters and rotor inertias (friction dissipates)."""
    layout = model.chain.layout
    return list(range(layout.n_inertial)) + [layout.n_inertial + i for i, (_, kind) in enumerate(layout.extra_columns)
                                             if kind == "rotor_inertia"]


def energy_base(model: ClosedModel, samples: int, seed: int, rows: bool = False):
    """(kept, K, no-effect columns) of the energy rows on the energy columns, from states of ``seed``; with
    ``rows``, the energy rows in place of the no-effect columns."""
    q, qd, _, _ = manifold_states(model, samples, seed)
    kin, pot = energy_rows(model, q, qd)
    _, pot0 = energy_rows(model, model.reference[None, :], np.zeros((1, model.chain.n)))
    cols = energy_columns(model)
    E = np.concatenate([kin, pot - pot0])[:, cols]
    col, _ = closed_scales(model)
    kept, K, unident, _ = base_from_regressor(E, model.chain.source, col[cols])
    return kept, K, (E if rows else unident)


def energy_check(model: ClosedModel, W: np.ndarray, samples: int, seed: int) -> dict:
    """Rank and regrouping of the energy route (states of seed + 1) beside those of the torque rows ``W``,
    on the columns the energy sees."""
    cols = energy_columns(model)
    col, row = closed_scales(model)
    kept_d, K_d, _, _ = base_from_regressor(W[:, cols], model.chain.source, col[cols], row)
    kept_e, K_e, E = energy_base(model, max(samples, len(cols)), seed + 1, rows=True)
    same = list(kept_d) == list(kept_e)
    if not same and len(kept_d) == len(kept_e) and K_d.size:
        # the scan kept other columns of equal rank (near ties in the scan order): the energy rows' regrouping on
        # the torque route's kept columns (least squares; exact when the two null spaces are one)
        K_e = np.linalg.lstsq(E[:, list(kept_d)], E, rcond=None)[0]
    diff = float(np.max(np.abs(K_d - K_e))) if len(kept_d) == len(kept_e) and K_d.size else (0.0 if same else None)
    return {"rank_torques": len(kept_d), "rank_energy": len(kept_e), "same_kept": same, "largest_difference": diff,
            "agrees": bool(diff is not None and diff < AGREE_TOL), "seed": seed + 1}
