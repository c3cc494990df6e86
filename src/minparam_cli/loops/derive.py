"""The base set of a closed chain's actuated torques (Khalil & Bennis 1995): τ_a = Gᵀ·Y_tree(q, q̇, q̈)·φ
on states of the constraint manifold, stacked and reduced by the same ordered QR scan as a tree
(``base.qr.base_from_regressor``), then checked by the energy route (``loops/energy.py``)."""

from __future__ import annotations

import time

import numpy as np

from minparam_cli.base.qr import RankUndecided, base_from_regressor
from minparam_cli.base.result import BaseSet
from minparam_cli.describe.records import RobotDescription
from minparam_cli.dynamics.regressor import joint_regressor
from minparam_cli.errors import InputError
from minparam_cli.loops.model import ClosedModel, closed_model, closed_scales
from minparam_cli.loops.sample import manifold_states


def actuated_regressor(model: ClosedModel, q, qd, qdd, G) -> np.ndarray:
    """Y_a (N, f, P) = Gᵀ·Y_tree: the actuated torques' regressor (virtual work through the loops)."""
    Yt = joint_regressor(model.chain, np.ascontiguousarray(q), np.ascontiguousarray(qd), np.ascontiguousarray(qdd))
    return np.einsum("snf,snp->sfp", G, Yt)


def derive_closed(desc: RobotDescription, chain, samples: int, seed: int, method: str = "qr", symbolic: bool = False) -> BaseSet:
    """Base parameters of the actuated torques of ``desc``'s closed chain (``minparam derive``).
    Krutikov's projection and the symbolic regrouping are tree routes: refused in one line."""
    from minparam_cli.errors import UnsupportedError
    from minparam_cli.loops.energy import energy_check

    if method == "projection":
        raise UnsupportedError("--method projection works on trees; a closed chain's base set comes from the loops' "
                               "tangent map (use --method qr)", desc.source)
    if symbolic:
        raise UnsupportedError("--symbolic regroups a tree in closed form; a closed chain's regrouping is numeric "
                               "(drop --symbolic)", desc.source)
    t0 = time.perf_counter()
    model = closed_model(desc, chain)
    f, P = len(model.actuated), chain.layout.size
    if samples * f < P:
        raise InputError(f"{samples} samples give {samples * f} equations for {P} parameters; use at least {-(-P // f)} samples")
    q, qd, qdd, G = manifold_states(model, samples, seed)
    W = actuated_regressor(model, q, qd, qdd, G).reshape(-1, P)
    try:
        kept, K, unident, margin = base_from_regressor(W, chain.source, *closed_scales(model))
    except RankUndecided as e:
        raise e.explained(chain) from None
    info = {"tree_joints": chain.n, "actuated": [chain.joint_names[j] for j in model.actuated],
            "passive": [chain.joint_names[j] for j in model.passive],
            "cuts": list(dict.fromkeys(model.cut_of_pair)), "closure_equations": model.closure_rank,
            "mobility": model.mobility, "energy_check": energy_check(model, W, samples, seed)}
    return BaseSet(standard_names=chain.layout.names, kept=tuple(kept), K=K, unidentifiable=tuple(unident), method="qr",
                   rank_margin=margin, exact=False, seed=seed, samples=samples, elapsed_s=time.perf_counter() - t0,
                   extra={"closed_chain": info})
