"""Weakly identifiable parameters and the geometry that keeps them.

A kept column whose residual is below ``WEAK_RTOL`` of the largest column
(``result.scan_margin``) is identifiable, but only just: typically because the
file's geometry is a few microradians or millimetres away from a special one
(π/2 written 1.57079; a joint origin 1.6 mm off the previous axis).  Such a
parameter is named with its margin and, when one is found, the relation
responsible.

Candidates are the relations that do not depend on the joint angles:

* the angle between a joint's axis and its parent's axis (or gravity, for a
  joint on the base) near 0 or 90°;
* the distance between a joint's axis and its parent's axis near 0
  (intersecting or coaxial axes).

Each candidate between RANK_RTOL and ``NEAR`` (rad, or fraction of the robot's
size) is made exact on a copy of the chain, by the smallest change: the
joint's fixed frame turned (about the common normal) or moved (along it), so
every frame after it follows rigidly.  The base set of that copy (QR route,
same samples and seed) is computed; a weak parameter that is no longer kept
there is explained by that candidate.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from minparam_cli.base.result import RANK_RTOL, WEAK_RTOL, BaseSet
from minparam_cli.chain import Chain

# relations closer than this to special (rad, or fraction of the robot's size) are candidates
NEAR = 1e-2
# at most this many candidates are tried (closest to special first): each costs one QR base set
MAX_CANDIDATES = 16


def weak_parameters(chain: Chain, base: BaseSet, explain: bool = True, samples: int = 100, seed: int = 0) -> list[dict]:
    """One dict per weakly identifiable parameter: name, margin, and the geometry found responsible."""
    weak = [(int(c), float(r)) for c, r in base.rank_margin.get("weak", [])]
    names = base.standard_names
    out: list[dict[str, Any]] = [{"parameter": names[c], "margin": r, "bound": WEAK_RTOL, "geometry": []} for c, r in weak]
    if not explain or not weak:
        return out
    from minparam_cli.base.qr import derive_qr

    # a relation at joint j changes how the links after j move: only those on the path to a weak link
    links = {c // 10 for c, _ in weak if c < chain.layout.n_inertial} | {chain.layout.extra_columns[c - chain.layout.n_inertial][0] for c, _ in weak if c >= chain.layout.n_inertial}
    upstream = set().union(*(chain.ancestors(k) for k in links)) if links else set()
    candidates = sorted((c for c in near_special_relations(chain) if c["joint"] in upstream), key=lambda c: c["delta"])
    for cand in candidates[:MAX_CANDIDATES]:
        kept = set(derive_qr(cand["chain"], samples=samples, seed=seed).kept)
        for entry, (c, _) in zip(out, weak, strict=True):
            if c not in kept:
                entry["geometry"].append(cand["text"])
    return out


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
