"""``excite --collisions``: signed distances between a robot's collision shapes (MuJoCo), as a constraint of
the design and as a dense check of its result.

The shapes are the robot file's own, compiled by MuJoCo (the ``[mujoco]`` extra): a URDF's ``<collision>``
elements (``<visual>`` ones are dropped; a mesh must exist, in a format MuJoCo reads), an MJCF's geoms
(those with a nonzero contype or conaffinity, or every geom when none has one).  With ``--floor`` a plane
at that height, normal against gravity, joins them.

Pairs: two shapes on bodies that move against each other and are not parent and child (bodies welded
together count as one, MuJoCo's ``body_weldid``), allowed by contype/conaffinity and by the MJCF's
``<contact><exclude>``; and the floor with every shape on a moving body.  A pair closer than the
clearance in every one of PROBE_POSITIONS random positions within the joint limits (two shapes that
overlap by construction) is left out and named in a note.

For a pair k, d_k(q) is MuJoCo's signed distance (``mj_geomDistance``; negative: the depth of the
overlap; meshes as their convex hulls).  Its gradient is n·(J_2(p_2) − J_1(p_1)): p_1, p_2 the nearest
(deepest) points, n the unit vector from p_1 to p_2 (reversed when the shapes overlap), J MuJoCo's point
Jacobians (``mj_jac``).  The design asks, at GRID_POINTS_PER_HARMONIC points per period of the highest
harmonic, one smooth inequality per time: the soft minimum over the pairs

    s(q) = −(1/β) ln Σ_k exp(−β d_k(q)) ≥ c,   β = SOFTMIN_LOG_PAIRS · ln P / c,

(c: the clearance; min_k d_k − ln P / β ≤ s ≤ min_k d_k, so s ≥ c keeps every pair at least c apart,
and asks at most c/2 more of the closest one; one row per time instead of one per pair keeps SLSQP's
subproblem small); the result must keep every d_k ≥ c/2 on the dense grid of ``constraints.dense_times``
(the times the other limits are checked at).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from minparam_cli.describe.mesh_files import find_mesh
from minparam_cli.errors import InputError
from minparam_cli.experiment.excite import constraints as cons

GRID_POINTS_PER_HARMONIC = 32
SOFTMIN_LOG_PAIRS = 2.0  # β = this · ln P / c: the soft minimum is at most c/2 below the least distance
REACH = 0.1  # m beyond the clearance: a pair farther apart is clear (its value capped there, zero gradient)
REPORT_REACH = 100.0  # m: the report's smallest distance is exact
PROBE_POSITIONS = 64
MESH_FORMATS = (".stl", ".obj", ".msh")
FLOOR_NAME = "minparam_floor"


@dataclass(eq=False)
class Collisions:
    """The compiled shapes, the pairs checked, and what the check cost."""

    mj: Any  # the mujoco module
    model: Any
    data: Any
    qpos: np.ndarray  # per chain joint: its qpos address
    dof: np.ndarray  # per chain joint: its dof address
    pairs: np.ndarray  # (P, 2) geom ids
    labels: tuple[str, ...]  # per pair: "body and body"
    clearance: float
    source: str
    floor_pairs: int = 0
    left_out: tuple[str, ...] = ()
    seconds: float = 0.0  # time spent in the distance computations
    per_harmonic: int = GRID_POINTS_PER_HARMONIC  # the design's grid for the constraint: points per period of the highest harmonic

    def distances(self, qj: np.ndarray, gradients: bool = False, reach: float = REACH) -> tuple[np.ndarray, np.ndarray | None]:
        """Signed distances (N, P), capped at clearance + reach, at joint states qj (N, chain joints);
        with ``gradients`` also ∂d/∂(joint state) (N, P, chain joints)."""
        mj, m, d = self.mj, self.model, self.data
        start = time.perf_counter()
        cap = self.clearance + reach
        N, P = qj.shape[0], len(self.pairs)
        out = np.full((N, P), cap)
        grad = np.zeros((N, P, qj.shape[1])) if gradients else None
        g1, g2 = self.pairs[:, 0], self.pairs[:, 1]
        rb = m.geom_rbound
        unbounded = (rb[g1] == 0) | (rb[g2] == 0)  # a plane
        fromto = np.zeros(6)
        j1, j2 = np.zeros((3, m.nv)), np.zeros((3, m.nv))
        for s in range(N):
            d.qpos[self.qpos] = qj[s]
            mj.mj_kinematics(m, d)
            if gradients:
                mj.mj_comPos(m, d)
            centres = d.geom_xpos
            gap = np.linalg.norm(centres[g1] - centres[g2], axis=1) - rb[g1] - rb[g2]
            for k in np.flatnonzero(unbounded | (gap < cap)):
                a, b = int(g1[k]), int(g2[k])
                dist = mj.mj_geomDistance(m, d, a, b, cap, fromto)
                out[s, k] = min(dist, cap)
                if grad is None or dist >= cap:
                    continue
                u = fromto[3:] - fromto[:3]
                length = float(np.linalg.norm(u))
                if length == 0.0:  # touching at one point: no direction
                    continue
                normal = u / length * (1.0 if dist >= 0 else -1.0)
                mj.mj_jac(m, d, j1, None, fromto[:3].copy(), int(m.geom_bodyid[a]))
                mj.mj_jac(m, d, j2, None, fromto[3:].copy(), int(m.geom_bodyid[b]))
                grad[s, k] = normal @ (j2 - j1)[:, self.dof]
        self.seconds += time.perf_counter() - start
        return out, grad

    def constraint(self, chain, Bq: np.ndarray, n: int, m: int) -> dict:
        """s(q(t_i)) − c ≥ 0 at the rows of Bq (s: the soft minimum over the pairs, module docstring), as an
        SLSQP inequality with its Jacobian in x = X.ravel()."""
        cache: dict = {}
        beta = SOFTMIN_LOG_PAIRS * np.log(max(len(self.pairs), 2)) / self.clearance

        def values(x):
            key = x.tobytes()
            if key not in cache:
                cache.clear()
                q = Bq @ x.reshape(n, m).T
                dist, grad = self.distances(cons.joint_states(chain, q), gradients=True)
                assert grad is not None  # asked for
                low = dist.min(axis=1)
                w = np.exp(-beta * (dist - low[:, None]))
                total = w.sum(axis=1)
                soft = low - np.log(total) / beta
                G = np.einsum("sp,spj,sjk->sk", w / total[:, None], grad, _joint_jacobian(chain, q))[:, None, :]
                zero = np.zeros_like(G)
                # in units of the clearance: rows of the size of the other constraints' (SLSQP is not scale-free)
                cache[key] = ((soft - self.clearance) / self.clearance,
                              cons.state_jacobian(G, zero, zero, Bq, Bq, Bq) / self.clearance)
            return cache[key]

        return {"type": "ineq", "fun": lambda x: values(x)[0], "jac": lambda x: values(x)[1]}

    def closest(self, chain, q: np.ndarray, t: np.ndarray, reach: float = REACH) -> tuple[float, int, float]:
        """The smallest distance over the times t (positions q (N, n)), its pair and its time (distances
        beyond clearance + reach count as that)."""
        dist, _ = self.distances(cons.joint_states(chain, q), reach=reach)
        s, k = np.unravel_index(int(np.argmin(dist)), dist.shape)
        return float(dist[s, k]), int(k), float(t[s])

    def violations(self, chain, q: np.ndarray, t: np.ndarray, strict: bool = False) -> list[str]:
        """The dense check: a text when a pair comes closer than half the clearance (``strict``: than the
        clearance) (empty: none)."""
        low, k, when = self.closest(chain, q, t)
        if low >= (self.clearance if strict else self.clearance / 2):
            return []
        if low < 0:
            return [f"collision: {self.labels[k]} overlap {-low * 1000:.3g} mm deep at t = {when:.4g} s"]
        return [f"collision: {self.labels[k]} only {low * 1000:.3g} mm apart at t = {when:.4g} s "
                f"(the clearance: {self.clearance * 1000:g} mm)"]

    def report(self, chain, q: np.ndarray, t: np.ndarray, grid_points: int) -> dict:
        """The JSON record of the check on the dense grid (q at the times t)."""
        low, k, when = self.closest(chain, q, t, REPORT_REACH)
        return {"geometry": self.source, "clearance": self.clearance, "pairs": len(self.pairs),
                "floor_pairs": self.floor_pairs, "left_out": list(self.left_out), "grid_points_per_period": grid_points,
                "checked_times": int(t.size), "smallest_distance": low,
                "closest_pair": self.labels[k], "at_t": when, "check_s": round(self.seconds, 3)}


def _joint_jacobian(chain, q: np.ndarray) -> np.ndarray:
    """∂(joint states)/∂(independent coordinates) at every sample, (N, joints, n)."""
    if chain.coupling is None:
        return np.broadcast_to(np.eye(q.shape[1]), (q.shape[0], q.shape[1], q.shape[1]))
    return cons._central_differences(lambda x: cons.joint_states(chain, x), q)


def urdf_for_mujoco(path: Path) -> str:
    """The URDF's text for MuJoCo's URDF reader: no <visual>, collision meshes as absolute paths (each one
    found, or a one-line error naming it), mass and inertia bounded (they do not matter here)."""
    from lxml import etree

    from minparam_cli.safety import parse_xml_safely, read_bounded

    src = str(path)
    root = parse_xml_safely(read_bounded(path), src)
    for el in root.findall(".//visual") + root.findall("mujoco"):
        el.getparent().remove(el)
    for link in root.findall("link"):
        for mesh in link.findall("collision/geometry/mesh"):
            name = mesh.get("filename", "")
            found = find_mesh(name, path.parent)
            where = f"{src}: link '{link.get('name')}'"
            if found is None:
                raise InputError(f"{where}: --collisions: collision mesh {name!r} not found (looked beside the URDF, in "
                                 "the folders above it and on ROS_PACKAGE_PATH); --collisions needs every mesh the file names")
            if found.suffix.lower() not in MESH_FORMATS:
                raise InputError(f"{where}: --collisions: collision mesh {name!r}: MuJoCo reads {', '.join(MESH_FORMATS)} meshes, "
                                 f"not {found.suffix}")
            mesh.set("filename", str(found.resolve()))
    root.insert(0, etree.fromstring('<mujoco><compiler strippath="false" discardvisual="true" balanceinertia="true" '
                                    'boundmass="1e-6" boundinertia="1e-9"/></mujoco>'))
    return etree.tostring(root, encoding="unicode")
