"""Near-special geometry: relations of a chain that do not depend on the joint angles and sit close to a
special value (an axis nearly parallel or perpendicular to its parent's axis or to gravity, two axes
nearly intersecting or coaxial), each with a copy of the chain where it is exact.  ``base/weak.py``
explains weakly identifiable parameters with them; ``base/qr.py`` names them when the rank decision is
too close to call."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from minparam_cli.base.result import RANK_RTOL
from minparam_cli.chain import Chain

# relations closer than this to special (rad, or fraction of the robot's size) are candidates
NEAR = 1e-2


def _parent_line(chain: Chain, j: int) -> tuple[np.ndarray, np.ndarray]:
    """Direction and a point of the parent's axis of joint j, in the parent's link frame."""
    p = chain.parents[j]
    Rpost, tpost = chain.post[p][:3, :3], chain.post[p][:3, 3]
    return Rpost.T @ chain.axes[p], -Rpost.T @ tpost


def _rotation_between(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The smallest rotation taking unit u to unit v (Rodrigues)."""
    w = np.cross(u, v)
    s, c = np.linalg.norm(w), float(u @ v)
    if s == 0.0:
        return np.eye(3)
    k = w / s
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + s * K + (1 - c) * (K @ K)


def _label(chain: Chain, j: int) -> str:
    return f"joint {j + 1} ({chain.joint_names[j]})"


def near_special_relations(chain: Chain) -> list[dict]:
    """Every near-special relation of the chain, with a copy of the chain where it is exact."""
    L = chain.length_scale
    g = np.asarray(chain.gravity, dtype=float)
    out = []
    for j in range(chain.n):
        R, o = chain.pre[j][:3, :3], chain.pre[j][:3, 3]
        u = R @ chain.axes[j]
        p = chain.parents[j]
        if p < 0:
            if not np.any(g):
                continue
            v, c, other = g / np.linalg.norm(g), None, "gravity"
        else:
            v, c = _parent_line(chain, j)
            other = _label(chain, p) + "'s axis"
        cos = float(np.clip(abs(u @ v), 0.0, 1.0))
        off_parallel = float(np.arccos(cos)) if cos < 1 else 0.0
        off_perpendicular = float(np.arcsin(cos))
        for delta, kind in ((off_parallel, "parallel"), (off_perpendicular, "perpendicular")):
            if not RANK_RTOL < delta < NEAR:
                continue
            if kind == "parallel":
                target = np.sign(u @ v) * v
            else:
                target = u - (u @ v) * v
                target /= np.linalg.norm(target)
            pre = chain.pre.copy()
            pre[j][:3, :3] = _rotation_between(u, target) @ R
            out.append(
                {
                    "text": f"{_label(chain, j)} axis {delta:.2g} rad from {kind} to {other}",
                    "delta": delta,
                    "joint": j,
                    "chain": _copy(chain, pre),
                }
            )
        if c is None:
            continue
        # distance between the two axis lines, and the shortest move of joint j's axis onto the parent's
        d = o - c
        n = np.cross(u, v)
        if np.linalg.norm(n) < NEAR:  # (nearly) parallel: distance between parallel lines
            move = -(d - (d @ v) * v)
            what = "coaxial with"
        else:
            n /= np.linalg.norm(n)
            move = -(d @ n) * n
            what = "intersecting"
        dist = float(np.linalg.norm(move))
        if RANK_RTOL * L < dist < NEAR * L:
            pre = chain.pre.copy()
            pre[j][:3, 3] = o + move
            out.append(
                {
                    "text": f"{_label(chain, j)} axis {dist * 1e3:.3g} mm ({dist / L:.2g} of the robot's size) from {what} {other}",
                    "delta": dist / L,
                    "joint": j,
                    "chain": _copy(chain, pre),
                }
            )
    return out


def _copy(chain: Chain, pre: np.ndarray) -> Chain:
    return replace(chain, pre=pre, exact_source=None)
