"""The global problem of Glazunov (1985): sweep the joints that move the axes relative to each other.

Only joints 2 … n-1 change the relative position of the joint axes of a
serial arm (joint 1 moves the whole chain rigidly, joint n moves no axis), so
the singular set is a set in the space of those joints.  ``scan`` evaluates
the relative smallest singular value σ_min/σ_max (the local test of
``screws``) on a grid, keeps the grid nodes at or below ε as the paper does,
and, because a grid rarely lands on the singular set, also locates the
crossings between neighbouring nodes:

* six joints: the determinant of matrix (3) changes sign across the set;
  each sign change is refined by the Illinois variant of regula falsi;
* other n: σ_min/σ_max has a V-shaped dip at the set; a grid node that is a
  local minimum deep enough to hide a zero is refined by golden-section search.

Refined points are kept when σ_min/σ_max ≤ ε there, then sorted by their
dependent joints (the paper's column-deletion test).  ``singular_grid`` holds
the grids, σ_min/σ_max at configurations and ``sigma_map`` (the same quantity
on a fine grid over two joints, for a plot).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from minparam_cli.chain import Chain
from minparam_cli.errors import InputError
from minparam_cli.kinematics.defaults import DEFAULT_EPSILON, DEFAULT_STEP_DEG
from minparam_cli.kinematics.serial.plucker import plucker_matrices, require_serial
from minparam_cli.kinematics.serial.screws import dependent_groups
from minparam_cli.kinematics.serial.singular_grid import ScanAxis, axis_values, evaluate_sigma, grid_plucker, sigma_det, swept_joints

MAX_NODES = 3_000_000
MAX_POINTS_KEPT = 200_000
REFINE_ITERATIONS = 60
DISTINCT_VALUES = 4  # a swept joint taking at most this many values over a set is reported as constant


@dataclass(frozen=True, eq=False)
class SingularSet:
    """The found singular points that share one set of dependent joints."""

    dependent_joints: tuple[int, ...]
    groups: tuple[tuple[int, ...], ...]
    rank: int
    count: int
    example: np.ndarray  # a configuration (rad / m)
    constant: dict  # swept joint -> tuple of the few values it takes over the set
    ranges: dict  # swept joint -> (min, max) when it takes more values

    @property
    def consistent(self) -> bool:
        """The minimal groups at the example join to the deletion-test set (False near the cut)."""
        return {j for g in self.groups for j in g} == set(self.dependent_joints)


@dataclass(frozen=True, eq=False)
class ScanResult:
    robot: str
    source: str
    axes: tuple[ScanAxis, ...]
    q_fixed: np.ndarray
    epsilon: float
    nodes: int
    node_hits: int  # grid nodes with σ_min/σ_max ≤ ε
    crossings: int  # refined crossings accepted
    sigma_grid_min: float
    points: np.ndarray  # (M, n) singular configurations found
    sigma: np.ndarray  # (M,) σ_min/σ_max at them
    point_set: np.ndarray  # (M,) index into ``sets``
    sets: tuple[SingularSet, ...]
    notes: tuple[str, ...]


# --- the scan --------------------------------------------------------------------------


def scan(
    chain: Chain,
    q_fixed,
    step: float = np.radians(DEFAULT_STEP_DEG),
    epsilon: float = DEFAULT_EPSILON,
    progress: Callable[[int, int], None] | None = None,
) -> ScanResult:
    """Sweep joints 2 … n-1 on a grid (others held at ``q_fixed``) and collect the singular set."""
    require_serial(chain)
    if not step > 0:
        raise InputError(f"the scan step must be positive, got {step}")
    if not 0 < epsilon < 1:
        raise InputError(f"epsilon must lie in (0, 1), got {epsilon}")
    n = chain.n
    q_fixed = np.asarray(q_fixed, dtype=float).reshape(-1)
    if q_fixed.size != n:
        raise InputError(f"expected {n} joint values, got {q_fixed.size}")
    notes: list[str] = []
    swept = swept_joints(chain)
    axes = tuple(axis_values(chain, j, step) for j in swept)
    values = [np.array([q_fixed[j]]) for j in range(n)]
    for ax in axes:
        values[ax.joint] = ax.values
    shape = tuple(ax.values.size for ax in axes)
    nodes = math.prod(shape)  # Python integers: numpy's product wraps around past 2^63 (24 values on 33 joints gave 0)
    if nodes > MAX_NODES:
        raise InputError(f"the grid has {nodes} nodes (limit {MAX_NODES}); use a larger step")
    if not swept:
        notes.append("no joint changes the relative position of the axes: the test does not depend on q")

    # sigma (and det) on the grid, chunked over the first swept joint
    sig = np.empty(nodes)
    det = np.empty(nodes) if n == 6 else None
    chunks = shape[0] if shape else 1
    per = nodes // chunks
    for k in range(chunks):
        vals = list(values)
        if axes:
            vals[axes[0].joint] = axes[0].values[k : k + 1]
        J0, c = grid_plucker(chain, vals)
        rel, d, _, _ = sigma_det(chain, J0, c)
        sig[k * per : (k + 1) * per] = rel
        if det is not None:
            det[k * per : (k + 1) * per] = d
        if progress:
            progress(k + 1, chunks + 1)
    sig_g = sig.reshape(shape) if shape else sig
    det_g = det.reshape(shape) if (det is not None and shape) else det
    hit_g = sig_g <= epsilon

    def node_q(index_tuple_arrays):
        Q = np.tile(q_fixed, (index_tuple_arrays[0].size if axes else 1, 1))
        for a, ax in enumerate(axes):
            Q[:, ax.joint] = ax.values[index_tuple_arrays[a]]
        return Q

    hits = np.nonzero(hit_g) if axes else (np.array([0]) if sig[0] <= epsilon else np.array([], int),)
    points = [node_q(hits)] if axes else ([q_fixed[None]] if sig[0] <= epsilon else [])

    # crossings between neighbouring nodes along each swept axis
    crossings = 0
    for a, ax in enumerate(axes):
        lo_idx, hi_x, lo_x = _candidates(sig_g, det_g, hit_g, a, ax, epsilon)
        if lo_idx[0].size == 0:
            continue
        Q_lo = node_q(lo_idx)
        refined = _refine(chain, Q_lo, ax.joint, lo_x, hi_x, use_det=det is not None)
        rel, _, _, _ = evaluate_sigma(chain, refined) if refined.shape[0] else (np.empty(0), None, None, None)
        keep = refined[rel <= epsilon]
        crossings += keep.shape[0]
        points.append(keep)
        if progress:
            progress(chunks, chunks + 1)
    P = np.concatenate(points, axis=0) if points else np.zeros((0, n))
    if P.shape[0] > MAX_POINTS_KEPT:
        notes.append(f"{P.shape[0]} singular points found; the first {MAX_POINTS_KEPT} are kept")
        P = P[:MAX_POINTS_KEPT]
    if n != 6 and axes:
        notes.append(
            "without a determinant the crossings are found from dips of σ_min/σ_max; "
            "a singular set of codimension above one is met only where the grid lands on it"
        )
    sets, which, sigma_pts = _classify(chain, P, axes, epsilon)
    if progress:
        progress(chunks + 1, chunks + 1)
    return ScanResult(
        robot=chain.name,
        source=chain.source,
        axes=axes,
        q_fixed=q_fixed,
        epsilon=epsilon,
        nodes=nodes,
        node_hits=int(np.count_nonzero(hit_g)),
        crossings=crossings,
        sigma_grid_min=float(sig.min()),
        points=P,
        sigma=sigma_pts,
        point_set=which,
        sets=sets,
        notes=tuple(notes),
    )


def _candidates(sig_g, det_g, hit_g, a, ax: ScanAxis, epsilon):
    """Brackets along axis a: (indices of the lower node, upper value, lower value)."""
    m = sig_g.shape[a]
    if m < 2:
        return (np.array([], int),), None, None
    nxt = np.roll(sig_g, -1, axis=a)
    hit_next = np.roll(hit_g, -1, axis=a)
    valid = np.ones(sig_g.shape, bool)
    if not ax.periodic:
        sl: list[slice | int] = [slice(None)] * sig_g.ndim
        sl[a] = m - 1
        valid[tuple(sl)] = False
    valid &= ~hit_g & ~hit_next
    step = 2 * np.pi / m if ax.periodic else ax.step
    if det_g is not None:
        cand = valid & (det_g * np.roll(det_g, -1, axis=a) < 0)
        idx = np.nonzero(cand)
        lo_x = ax.values[idx[a]]
        return idx, lo_x + step, lo_x
    # V-shaped dips: a local minimum at least as deep as its own value
    prv = np.roll(sig_g, 1, axis=a)
    if not ax.periodic:
        sl = [slice(None)] * sig_g.ndim
        sl[a] = 0
        prv = prv.copy()
        prv[tuple(sl)] = np.inf
        sl[a] = m - 1
        nxt = nxt.copy()
        nxt[tuple(sl)] = np.inf
    deep = np.maximum(np.where(np.isfinite(prv), prv, -np.inf), np.where(np.isfinite(nxt), nxt, -np.inf)) - sig_g
    cand = (sig_g <= prv) & (sig_g <= nxt) & ~hit_g & (sig_g <= deep)
    idx = np.nonzero(cand)
    centre = ax.values[idx[a]]
    lo_x = centre - step
    hi_x = centre + step
    if not ax.periodic:
        lo_x = np.maximum(lo_x, ax.values[0])
        hi_x = np.minimum(hi_x, ax.values[-1])
    return idx, hi_x, lo_x


def _refine(chain: Chain, Q_lo: np.ndarray, joint: int, lo: np.ndarray, hi: np.ndarray, use_det: bool) -> np.ndarray:
    """Locate the singular point inside each bracket [lo, hi] of ``joint``, all brackets at once."""
    Q = Q_lo.copy()
    a, b = lo.astype(float).copy(), hi.astype(float).copy()

    def f(x):
        Q[:, joint] = x
        if use_det:
            return np.linalg.det(plucker_matrices(chain, Q)[0])
        return evaluate_sigma(chain, Q)[0]

    if use_det:  # Illinois variant of regula falsi on the sign change of det
        fa, fb = f(a), f(b)
        side = np.zeros(a.size, int)
        x = 0.5 * (a + b)
        for _ in range(REFINE_ITERATIONS):
            x_old = x
            x = (a * fb - b * fa) / (fb - fa)
            x = np.where(np.isfinite(x), x, 0.5 * (a + b))
            fx = f(x)
            same_b = fx * fb > 0
            a, b = np.where(same_b, a, x), np.where(same_b, x, b)
            fa_new, fb_new = np.where(same_b, fa, fx), np.where(same_b, fx, fb)
            fa = np.where(same_b & (side == -1), fa_new / 2, fa_new)
            fb = np.where(~same_b & (side == 1), fb_new / 2, fb_new)
            side = np.where(same_b, -1, 1)
            if np.all(np.abs(x - x_old) <= 1e-14 * (1 + np.abs(x))):
                break
        Q[:, joint] = x
        return Q
    g = (np.sqrt(5) - 1) / 2  # golden section on the V-shaped σ_min/σ_max
    x1, x2 = b - g * (b - a), a + g * (b - a)
    f1, f2 = f(x1), f(x2)
    for _ in range(REFINE_ITERATIONS):
        left = f1 < f2  # the minimum lies in [a, x2]
        a, b = np.where(left, a, x1), np.where(left, x2, b)
        n1 = np.where(left, b - g * (b - a), x2)
        n2 = np.where(left, x1, a + g * (b - a))
        fn = f(np.where(left, n1, n2))
        f1, f2 = np.where(left, fn, f2), np.where(left, f1, fn)
        x1, x2 = n1, n2
    Q[:, joint] = 0.5 * (a + b)
    return Q


def _classify(chain: Chain, P: np.ndarray, axes, epsilon):
    """Sort the singular points by their dependent joints (column-deletion test, batched)."""
    n = chain.n
    if P.shape[0] == 0:
        return (), np.zeros(0, int), np.zeros(0)
    rel, _, Jn, s = evaluate_sigma(chain, P)
    cut = epsilon * s[:, 0]
    rank = np.sum(s > cut[:, None], axis=1)
    if n <= 6:
        key = np.zeros(P.shape[0], np.int64)
        for i in range(n):
            si = np.linalg.svd(np.delete(Jn, i, axis=2), compute_uv=False)
            ri = np.sum(si > cut[:, None], axis=1)
            key |= (ri == rank).astype(np.int64) << i
    else:
        key = np.zeros(P.shape[0], np.int64)
    key = key * 16 + rank
    uniq, which = np.unique(key, return_inverse=True)
    sets = []
    for u_i, u in enumerate(uniq):
        members = np.nonzero(which == u_i)[0]
        ex = P[members[0]]
        Jex = Jn[members[0]]
        groups = dependent_groups(Jex, epsilon * float(s[members[0], 0]))
        if n <= 6:
            dep = tuple(i for i in range(n) if (int(u) // 16) >> i & 1)
        else:
            dep = tuple(sorted({j for g in groups for j in g}))
        constant, ranges = {}, {}
        for ax in axes:
            vals = P[members, ax.joint]
            distinct = _distinct(vals, ax)
            if distinct.size <= DISTINCT_VALUES:
                constant[ax.joint] = tuple(float(v) for v in distinct)
            else:
                ranges[ax.joint] = (float(vals.min()), float(vals.max()))
        sets.append(SingularSet(dep, groups, int(u % 16), int(members.size), ex, constant, ranges))
    order = sorted(range(len(sets)), key=lambda i: -sets[i].count)
    remap = np.empty(len(sets), int)
    remap[order] = np.arange(len(sets))
    return tuple(sets[i] for i in order), remap[which], rel


def _distinct(vals: np.ndarray, ax: ScanAxis) -> np.ndarray:
    """Distinct values up to a thousandth of the grid step (angles wrapped to (-π, π])."""
    v = np.asarray(vals, float)
    if ax.periodic:
        v = np.angle(np.exp(1j * v))
        v = np.where(v <= -np.pi + 1e-12, np.pi, v)
    tol = 1e-3 * (ax.step or 1.0)
    v = np.sort(v)
    out = [v[0]]
    for x in v[1:]:
        if x - out[-1] > tol:
            out.append(x)
    return np.array(out)
