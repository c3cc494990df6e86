"""The loop constraints of a closed chain, in numbers (docs/methods/closed_chains.md).

Every cut becomes point pairs (p_a on body a, p_b on body b) whose world positions must coincide:
a ``connect`` one pair, a ``revolute`` two (the origin and a point one robot size up the z axis),
a ``weld`` three (the origin and points along x and y).  With h(q) the stacked differences,

    J(q) q̇ = 0,        J(q) q̈ + J̇(q, q̇) q̇ = 0,

J's rows the world velocities of the points per joint of the tree, J̇q̇ the points' accelerations at
q̈ = 0.  With the actuated joints a and the passive joints p, q̇_p = −J_p⁺ J_a q̇_a, so
q̇ = G q̇_a and q̈ = G q̈_a + g with g_p = −J_p⁺ J̇q̇ (``tangent``).  J_p⁺ is a least-squares inverse:
equations that repeat others (a planar loop's out-of-plane ones) are consistent and drop out.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from minparam_cli.chain import REVOLUTE, Chain, forward_kinematics
from minparam_cli.describe.records import RobotDescription
from minparam_cli.dynamics.regressor import cross
from minparam_cli.errors import DescriptionError

# closure is reached when every point pair is within this fraction of the robot's size
CLOSE_RTOL = 1e-11
# a closure equation counts in the rank when its singular value exceeds this fraction of the largest
RANK_RTOL = 1e-8
NEWTON_STEPS = 60
# steps of the continuation from the reference to the wanted actuated coordinates (``close_from_reference``)
CONTINUATION_STEPS = 8
# a configuration whose loops close within this fraction of the robot's size counts as closed (the
# commands' test; Newton itself aims at CLOSE_RTOL)
CLOSED_RTOL = CLOSE_RTOL * 1e3


@dataclass(frozen=True, eq=False)
class ClosedModel:
    """A closed chain in numbers: the tree, the point pairs of the cuts, actuated and passive joints,
    the assembled reference configuration and the count of independent closure equations."""

    chain: Chain
    body_a: np.ndarray  # (m,) body of each point pair's first point (-1: base)
    body_b: np.ndarray
    point_a: np.ndarray  # (m, 3) in body a's frame
    point_b: np.ndarray  # (m, 3) in body b's frame
    cut_of_pair: tuple[str, ...]
    actuated: tuple[int, ...]
    passive: tuple[int, ...]
    reference: np.ndarray  # (n,) assembled
    closure_rank: int

    @property
    def mobility(self) -> int:
        return self.chain.n - self.closure_rank

    @property
    def actuated_types(self) -> tuple[str, ...]:
        return tuple(self.chain.types[j] for j in self.actuated)

    def ancestors_mask(self, bodies: np.ndarray) -> np.ndarray:
        """(m, n): 1 where joint j moves the pair's body (0 for the base)."""
        out = np.zeros((len(bodies), self.chain.n))
        for i, b in enumerate(bodies):
            if b >= 0:
                out[i, list(self.chain.ancestors(int(b)))] = 1.0
        return out

    # ---------------------------------------------------------------- kinematics of the points
    def points(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """World points (N, m, 3) of both sides, and the world screws S (N, n, 6) and frames T."""
        T, z, o = forward_kinematics(self.chain, q)
        S = np.concatenate([z, cross(o, z)], axis=2)
        pris = np.array([t != REVOLUTE for t in self.chain.types])
        S[:, pris, 3:] = z[:, pris]
        S[:, pris, :3] = 0.0
        return _world(T, self.body_a, self.point_a), _world(T, self.body_b, self.point_b), S, T

    def residual(self, q: np.ndarray) -> np.ndarray:
        pa, pb, _, _ = self.points(q)
        return (pa - pb).reshape(len(pa), -1)

    def jacobian(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """J (N, 3m, n) and the residual h (N, 3m)."""
        pa, pb, S, _ = self.points(q)
        Ja = _point_columns(S, pa) * self.ancestors_mask(self.body_a)[None, :, None, :]
        Jb = _point_columns(S, pb) * self.ancestors_mask(self.body_b)[None, :, None, :]
        N, m = pa.shape[:2]
        return (Ja - Jb).reshape(N, 3 * m, self.chain.n), (pa - pb).reshape(N, 3 * m)

    def bias(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """J̇q̇ (N, 3m): the points' relative acceleration at q̈ = 0."""
        pa, pb, S, _ = self.points(q)
        V, A = spatial_motion(self.chain, S, qd, np.zeros_like(qd))
        return (_point_acceleration(V, A, self.body_a, pa) - _point_acceleration(V, A, self.body_b, pb)).reshape(len(q), -1)

    def tangent(self, q: np.ndarray, qd: np.ndarray | None = None):
        """G (N, n, f) with q̇ = G q̇_a; with ``qd`` (N, n) also g (N, n): q̈ = G q̈_a + g."""
        G, pinv = self.tangent_map(q)
        return G, None if qd is None else self.drift(q, qd, pinv)

    def tangent_map(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """G (N, n, f) and the least-squares inverse of the passive columns of J (N, p, 3m) it came from."""
        J, _ = self.jacobian(q)
        a, p = list(self.actuated), list(self.passive)
        pinv = np.linalg.pinv(J[:, :, p], rcond=RANK_RTOL)
        N, n, f = len(q), self.chain.n, len(a)
        G = np.zeros((N, n, f))
        G[:, a, :] = np.eye(f)
        G[:, p, :] = -pinv @ J[:, :, a]
        return G, pinv

    def drift(self, q: np.ndarray, qd: np.ndarray, pinv: np.ndarray) -> np.ndarray:
        """g (N, n) with q̈ = G q̈_a + g at the rates ``qd`` (N, n), from ``tangent_map``'s ``pinv`` at q."""
        g = np.zeros((len(q), self.chain.n))
        g[:, list(self.passive)] = -np.einsum("spr,sr->sp", pinv, self.bias(q, qd))
        return g

    # ---------------------------------------------------------------- closure
    def close(self, q_a: np.ndarray, start: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Newton on the passive joints, the actuated ones held at ``q_a`` (N, f), from ``start`` (N, n):
        the configurations (N, n) and each one's largest point mismatch (m)."""
        q = np.array(start, dtype=float)
        q[:, list(self.actuated)] = q_a
        p = np.array(self.passive, dtype=int)
        # only the states not closed yet take further steps, and each one more after it first meets
        # the tolerance (Newton's next step takes it to rounding: the rank decisions of derive read them)
        active = np.arange(len(q))
        met = np.zeros(len(q), dtype=bool)
        for _ in range(NEWTON_STEPS):
            J, h = self.jacobian(q[active])
            close = np.abs(h).max(axis=1) < CLOSE_RTOL * self.chain.length_scale
            still = ~(close & met[active])
            met[active[close]] = True
            if not still.any():
                break
            active, J, h = active[still], J[still], h[still]
            step = np.linalg.lstsq(J[0][:, p], h[0], rcond=None)[0][None, :] if len(active) == 1 else _batched_lstsq(J[:, :, p], h)
            q[np.ix_(active, p)] -= step
        return q, np.abs(self.residual(q)).max(axis=1)


    def close_from_reference(self, q_a: np.ndarray, steps: int = CONTINUATION_STEPS) -> tuple[np.ndarray, np.ndarray]:
        """``close`` by continuation: the actuated joints moved from the reference to ``q_a`` (N, f) in
        ``steps`` equal steps, Newton from the previous solution at each, so the loops stay in the
        reference's assembly mode (a four-bar does not jump from parallelogram to antiparallelogram).

        A state whose straight path from the reference passes a singularity of the loops (the path,
        not the state: a planar 3-RRR's reference may lie far from where it moves) is continued instead
        from the nearest state of the same call that closed, in the same mode, again while that closes
        more of them: the samples of a motion then close from their neighbours."""
        a = list(self.actuated)
        q_a = np.asarray(q_a, dtype=float)
        q, err = self.continue_from(np.repeat(self.reference[None, :], len(q_a), axis=0), q_a, steps)
        bad = ~(err < CLOSED_RTOL * self.chain.length_scale)
        while bad.any() and not bad.all():
            from scipy.spatial import cKDTree

            good, idx = np.flatnonzero(~bad), np.flatnonzero(bad)
            near = good[cKDTree(q_a[good]).query(q_a[idx])[1]]
            q_new, err_new = self.continue_from(q[near], q_a[idx], steps)
            fixed = err_new < CLOSED_RTOL * self.chain.length_scale
            if not fixed.any():
                break
            q[idx[fixed]], err[idx[fixed]] = q_new[fixed], err_new[fixed]
            bad[idx[fixed]] = False
        q[:, a] = q_a
        return q, err

    def continue_from(self, start: np.ndarray, q_a: np.ndarray, steps: int) -> tuple[np.ndarray, np.ndarray]:
        """``close`` along the straight path of the actuated joints from ``start`` (N, n) to ``q_a`` (N, f)."""
        s_a = start[:, list(self.actuated)]
        q, err = start, np.zeros(len(q_a))
        for k in range(1, steps + 1):
            q, err = self.close(s_a + (q_a - s_a) * (k / steps), q)
        return q, err


def _batched_lstsq(J: np.ndarray, h: np.ndarray) -> np.ndarray:
    return np.einsum("spr,sr->sp", np.linalg.pinv(J, rcond=1e-12), h)


def _world(T: np.ndarray, bodies: np.ndarray, points: np.ndarray) -> np.ndarray:
    out = np.empty((T.shape[0], len(bodies), 3))
    for i, (b, p) in enumerate(zip(bodies, points, strict=True)):
        out[:, i] = p if b < 0 else T[:, b, :3, :3] @ p + T[:, b, :3, 3]
    return out


def _point_columns(S: np.ndarray, P: np.ndarray) -> np.ndarray:
    """(N, m, 3, n): velocity of world point P_i per unit rate of each joint, v = s_v + s_ω × P."""
    return np.moveaxis(S[:, None, :, 3:] + cross(S[:, None, :, :3], P[:, :, None, :]), 2, 3)


def spatial_motion(chain: Chain, S: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Spatial velocities V and accelerations A (N, n, 6) of every link at the world origin (no gravity):
    V_j = V_p + S_j q̇_j, A_j = A_p + S_j q̈_j + V_j ×ₘ S_j q̇_j."""
    N, n = qd.shape
    V, A = np.zeros((N, n, 6)), np.zeros((N, n, 6))
    for j in range(n):
        p = chain.parents[j]
        Sj = S[:, j]
        V[:, j] = (V[:, p] if p >= 0 else 0.0) + Sj * qd[:, j, None]
        w, v = V[:, j, :3], V[:, j, 3:]
        vxs = np.concatenate([cross(w, Sj[:, :3]), cross(w, Sj[:, 3:]) + cross(v, Sj[:, :3])], axis=1)
        A[:, j] = (A[:, p] if p >= 0 else 0.0) + Sj * qdd[:, j, None] + vxs * qd[:, j, None]
    return V, A


def _point_acceleration(V: np.ndarray, A: np.ndarray, bodies: np.ndarray, P: np.ndarray) -> np.ndarray:
    """Classical acceleration (N, m, 3) of the world points P on their bodies: a = a₀ + ω̇×P + ω×(v₀ + ω×P)."""
    out = np.zeros(P.shape)
    for i, b in enumerate(bodies):
        if b < 0:
            continue
        w, v, dw, a = V[:, b, :3], V[:, b, 3:], A[:, b, :3], A[:, b, 3:]
        out[:, i] = a + cross(dw, P[:, i]) + cross(w, v + cross(w, P[:, i]))
    return out


def closed_scales(model: ClosedModel) -> tuple[np.ndarray, np.ndarray]:
    """Column factors and per-row factors (one per actuated joint) of the actuated regressor in physical
    units (``base.result.physical_scales``)."""
    from minparam_cli.base.result import physical_scales

    chain = model.chain
    return physical_scales(chain.layout, chain.types, chain.length_scale, model.actuated_types)


def closed_model(desc: RobotDescription, chain: Chain) -> ClosedModel:
    """The numbers of ``desc``'s loops on ``chain``, checked: the loops close at the reference (Newton on
    the passive joints), they leave the mechanism mobile, and the actuated joints drive it."""
    loops = desc.loops
    if loops is None:
        raise ValueError("not a closed chain")
    src, n = desc.source, chain.n
    L = chain.length_scale
    ref = np.array(loops.reference, dtype=float)[None, :]
    T0, _, _ = forward_kinematics(chain, ref)
    ba, bb, pa, pb, names = [], [], [], [], []
    for cut in loops.cuts:
        Fa = np.array(cut.frame_a, dtype=float)
        Wa = Fa if cut.body_a < 0 else T0[0, cut.body_a] @ Fa
        if cut.frame_b is None:  # MuJoCo's convention: where frame a lies at the reference
            Fb = Wa if cut.body_b < 0 else np.linalg.inv(T0[0, cut.body_b]) @ Wa
        else:
            Fb = np.array(cut.frame_b, dtype=float)
        offsets: dict[str, list[np.ndarray]] = {"connect": [np.zeros(3)], "revolute": [np.zeros(3), np.array([0, 0, L])],
                                                "weld": [np.zeros(3), np.array([L, 0, 0]), np.array([0, L, 0])]}
        for d in offsets[cut.kind]:
            ba.append(cut.body_a)
            bb.append(cut.body_b)
            pa.append(Fa[:3, :3] @ d + Fa[:3, 3])
            pb.append(Fb[:3, :3] @ d + Fb[:3, 3])
            names.append(cut.name)
    actuated = tuple(loops.actuated)
    passive = tuple(j for j in range(n) if j not in actuated)
    model = ClosedModel(chain, np.array(ba), np.array(bb), np.array(pa, dtype=float), np.array(pb, dtype=float),
                        tuple(names), actuated, passive, ref[0], 0)
    q, err = model.close(ref[:, list(actuated)], ref)
    if not err[0] < CLOSED_RTOL * L:
        worst = names[int(np.argmax(np.abs(model.residual(q)).reshape(-1, 3).max(axis=1)))]
        raise DescriptionError(f"the loops cannot be assembled at the reference configuration: cut {worst!r} stays "
                               f"{err[0]:.3g} m apart after Newton on the passive joints (check the cut points and the "
                               "joints' 'reference' values)", src, "loops")
    J, _ = model.jacobian(q)
    sv = np.linalg.svd(J[0], compute_uv=False)
    rank = int(np.sum(sv > RANK_RTOL * sv[0])) if sv.size and sv[0] > 0 else 0
    mobility = n - rank
    if mobility == 0:
        raise DescriptionError(f"the loops lock the mechanism: {n} tree joints and {rank} independent closure equations "
                               "leave mobility 0", src, "loops")
    if mobility != len(actuated):
        raise DescriptionError(f"the mechanism has mobility {mobility} ({n} tree joints, {rank} independent closure "
                               f"equations) but {len(actuated)} joints are actuated", src, "joints")
    svp = np.linalg.svd(J[0][:, list(passive)], compute_uv=False) if passive else np.zeros(0)
    if int(np.sum(svp > RANK_RTOL * sv[0])) != rank:
        raise DescriptionError("the actuated joints do not determine the passive ones at the reference configuration "
                               "(a singular configuration, or the wrong joints marked actuated)", src, "joints")
    from dataclasses import replace

    return replace(model, reference=q[0], closure_rank=rank)
