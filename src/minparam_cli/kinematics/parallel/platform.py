"""Parallel platforms (hexapods, the dodekapod of Dang 2013): model, rotations, inverse kinematics.

Pose convention (Dang 2013, eq. 4): the platform frame is moved by the
translation (x, y, z) and turned by R = Rz(yaw) Ry(pitch) Rx(roll), i.e. the
paper's angles are yaw = alpha (about z), pitch = beta (about y) and
roll = gamma (about x).  A pose vector is always ordered
``(x, y, z, roll, pitch, yaw)``: see :data:`POSE_NAMES`.  Angles are radians
inside the package; lengths stay in the description's own unit.

Forward kinematics lives in ``platform_fk`` (dispatch, polishing,
de-duplication), ``platform_exact`` (elimination for the octahedral 3-3
pattern) and ``platform_pso`` (the paper's particle swarm, and multistart).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

POSE_NAMES = ("x", "y", "z", "roll", "pitch", "yaw")
EPS = np.finfo(float).eps


@dataclass(frozen=True)
class PlatformModel:
    """A base and a moving platform joined by legs (constant data only).

    ``base`` holds the base nodes in the base frame, ``platform`` the platform
    nodes in the platform frame, both (n, 3).  Leg k joins base node
    ``leg_base[k]`` to platform node ``leg_platform[k]``.  ``limits`` is
    (n_legs, 2) with NaN where a leg has no limit.
    """

    name: str
    base: np.ndarray
    platform: np.ndarray
    base_names: tuple[str, ...]
    platform_names: tuple[str, ...]
    leg_names: tuple[str, ...]
    leg_base: np.ndarray
    leg_platform: np.ndarray
    limits: np.ndarray
    length_unit: str = ""
    angle_unit: str = "rad"

    @property
    def n_legs(self) -> int:
        return int(self.leg_base.size)

    @property
    def scale(self) -> float:
        """A characteristic length: the largest node radius or leg limit (for relative tolerances)."""
        values = [np.abs(self.base).max(), np.abs(self.platform).max()]
        finite = self.limits[np.isfinite(self.limits)]
        if finite.size:
            values.append(np.abs(finite).max())
        return float(max(max(values), 1e-300))


def platform_model(desc) -> PlatformModel:
    """Build the model from a :class:`~minparam_cli.describe.platform_yaml.PlatformDescription`."""
    base_idx = {n: i for i, n in enumerate(desc.base_names)}
    plat_idx = {n: i for i, n in enumerate(desc.platform_names)}
    lb = np.array([base_idx[leg.base] for leg in desc.legs], dtype=int)
    lp = np.array([plat_idx[leg.platform] for leg in desc.legs], dtype=int)
    limits = np.array(
        [leg.limits if leg.limits is not None else (np.nan, np.nan) for leg in desc.legs], dtype=float
    )
    return PlatformModel(
        name=desc.name,
        base=np.array(desc.base_coords, dtype=float),
        platform=np.array(desc.platform_coords, dtype=float),
        base_names=tuple(desc.base_names),
        platform_names=tuple(desc.platform_names),
        leg_names=tuple(leg.name for leg in desc.legs),
        leg_base=lb,
        leg_platform=lp,
        limits=limits,
        length_unit=desc.length_unit,
        angle_unit=desc.angle_unit,
    )


# ---------------------------------------------------------------- rotations


def matrix_from_rpy(roll, pitch, yaw) -> np.ndarray:
    """R = Rz(yaw) Ry(pitch) Rx(roll), Dang (2013) eq. (4); broadcasts over arrays -> (..., 3, 3)."""
    cg, sg = np.cos(roll), np.sin(roll)
    cb, sb = np.cos(pitch), np.sin(pitch)
    ca, sa = np.cos(yaw), np.sin(yaw)
    cg, sg, cb, sb, ca, sa = np.broadcast_arrays(cg, sg, cb, sb, ca, sa)
    R = np.empty(cg.shape + (3, 3), dtype=np.result_type(cg, float))
    R[..., 0, 0] = ca * cb
    R[..., 0, 1] = ca * sb * sg - sa * cg
    R[..., 0, 2] = ca * sb * cg + sa * sg
    R[..., 1, 0] = sa * cb
    R[..., 1, 1] = sa * sb * sg + ca * cg
    R[..., 1, 2] = sa * sb * cg - ca * sg
    R[..., 2, 0] = -sb
    R[..., 2, 1] = cb * sg
    R[..., 2, 2] = cb * cg
    return R


def rpy_from_matrix(R: np.ndarray) -> np.ndarray:
    """Inverse of :func:`matrix_from_rpy`: (..., 3, 3) -> (..., 3) as (roll, pitch, yaw).

    pitch is in [-pi/2, pi/2]; roll and yaw in (-pi, pi].  At pitch = +-pi/2
    only roll - yaw (or roll + yaw) is defined; roll is then set to 0.
    """
    R = np.asarray(R, dtype=float)
    pitch = np.arctan2(-R[..., 2, 0], np.hypot(R[..., 0, 0], R[..., 1, 0]))
    yaw = np.arctan2(R[..., 1, 0], R[..., 0, 0])
    roll = np.arctan2(R[..., 2, 1], R[..., 2, 2])
    lock = np.hypot(R[..., 0, 0], R[..., 1, 0]) < 64 * EPS
    if np.any(lock):
        roll = np.where(lock, 0.0, roll)
        yaw = np.where(lock, np.arctan2(-R[..., 0, 1], R[..., 1, 1]), yaw)
    return np.stack([roll, pitch, yaw], axis=-1)


def normal_from_rpy(roll, pitch, yaw) -> np.ndarray:
    """Platform normal n = R (0, 0, 1), Dang (2013) eq. (12): the third column of R."""
    return matrix_from_rpy(roll, pitch, yaw)[..., :, 2]


def rpy_from_normal(normal, yaw=0.0) -> np.ndarray:
    """Roll and pitch from the platform normal with the yaw fixed, Dang (2013) eq. (13)-(15).

    With alpha = yaw fixed, n' = Rz(-yaw) n = (sin b cos g, -sin g, cos b cos g), so
    sin(roll) = n_x sin(yaw) - n_y cos(yaw) and
    tan(pitch) = (n_x cos(yaw) + n_y sin(yaw)) / n_z, with roll in [-pi/2, pi/2].
    ``normal`` need not be unit length; a zero vector raises ValueError.
    Returns (..., 3) as (roll, pitch, yaw).
    """
    n = np.asarray(normal, dtype=float)
    norm = np.linalg.norm(n, axis=-1, keepdims=True)
    if np.any(norm == 0) or not np.all(np.isfinite(n)):
        raise ValueError("the normal vector must be finite and non-zero")
    n = n / norm
    yaw = np.broadcast_to(np.asarray(yaw, dtype=float), n.shape[:-1])
    ca, sa = np.cos(yaw), np.sin(yaw)
    sin_roll = np.clip(n[..., 0] * sa - n[..., 1] * ca, -1.0, 1.0)
    roll = np.arcsin(sin_roll)
    pitch = np.arctan2(n[..., 0] * ca + n[..., 1] * sa, n[..., 2])
    return np.stack([roll, pitch, yaw], axis=-1)


def canonical_pose(pose) -> np.ndarray:
    """Same pose with its angles re-read from R: pitch in [-pi/2, pi/2], roll and yaw in (-pi, pi]."""
    q = np.array(pose, dtype=float)
    q[..., 3:] = rpy_from_matrix(matrix_from_rpy(q[..., 3], q[..., 4], q[..., 5]))
    return q


# ---------------------------------------------------------------- inverse kinematics


def platform_points(model: PlatformModel, poses) -> np.ndarray:
    """World (base-frame) coordinates of the platform nodes: (..., 6) poses -> (..., n_platform, 3)."""
    q = np.asarray(poses, dtype=float)
    R = matrix_from_rpy(q[..., 3], q[..., 4], q[..., 5])
    return q[..., None, :3] + np.einsum("...ij,nj->...ni", R, model.platform)


def leg_vectors(model: PlatformModel, poses) -> np.ndarray:
    """Leg vectors B_i -> P_j in the base frame, Dang (2013) eq. (3): (..., n_legs, 3)."""
    pts = platform_points(model, poses)
    return pts[..., model.leg_platform, :] - model.base[model.leg_base]


def leg_lengths(model: PlatformModel, poses) -> np.ndarray:
    """Inverse kinematics, Dang (2013) eq. (3): l = |-B_i + (x, y, z) + R P_j|, vectorised over poses."""
    return np.linalg.norm(leg_vectors(model, poses), axis=-1)


def pose_from_normal(position, normal, yaw=0.0) -> np.ndarray:
    """Pose vector from a position and a platform normal with the yaw fixed (eq. 13-15)."""
    rpy = rpy_from_normal(normal, yaw)
    return np.concatenate([np.asarray(position, dtype=float), rpy], axis=-1)


def leg_jacobian(model: PlatformModel, pose) -> np.ndarray:
    """d l / d pose at one pose: (n_legs, 6), columns ordered as :data:`POSE_NAMES`."""
    q = np.asarray(pose, dtype=float)
    roll, pitch, yaw = q[3:]
    cg, sg, cb, sb, ca, sa = np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch), np.cos(yaw), np.sin(yaw)
    Rz = np.array([[ca, -sa, 0], [sa, ca, 0], [0, 0, 1.0]])
    Ry = np.array([[cb, 0, sb], [0, 1.0, 0], [-sb, 0, cb]])
    Rx = np.array([[1.0, 0, 0], [0, cg, -sg], [0, sg, cg]])
    dRz = np.array([[-sa, -ca, 0], [ca, -sa, 0], [0, 0, 0.0]])
    dRy = np.array([[-sb, 0, cb], [0, 0, 0.0], [-cb, 0, -sb]])
    dRx = np.array([[0, 0, 0.0], [0, -sg, -cg], [0, cg, -sg]])
    derivs = (Rz @ Ry @ dRx, Rz @ dRy @ Rx, dRz @ Ry @ Rx)
    R = Rz @ Ry @ Rx
    p = model.platform[model.leg_platform]
    v = q[:3] + p @ R.T - model.base[model.leg_base]
    length = np.linalg.norm(v, axis=1)
    e = v / np.where(length > 0, length, 1.0)[:, None]
    J = np.empty((model.n_legs, 6))
    J[:, :3] = e
    for k, dR in enumerate(derivs):
        J[:, 3 + k] = np.einsum("ni,ni->n", e, p @ dR.T)
    return J


def legs_within_limits(model: PlatformModel, lengths) -> np.ndarray:
    """Per leg: inside its limits (a leg without limits always is): (..., n_legs) bool."""
    lengths = np.asarray(lengths, dtype=float)
    lo = np.where(np.isfinite(model.limits[:, 0]), model.limits[:, 0], -np.inf)
    hi = np.where(np.isfinite(model.limits[:, 1]), model.limits[:, 1], np.inf)
    return (lengths >= lo) & (lengths <= hi)


def pose_from_points(model: PlatformModel, points: np.ndarray) -> np.ndarray:
    """Rigid pose that carries the platform nodes onto ``points`` (..., n_platform, 3).

    Three nodes: the orthonormal frames of the two triangles give R = F_world F_local^T
    (exact when the side lengths agree; vectorised over leading axes).  More
    nodes: least squares (Kabsch, proper rotation), one configuration at a time.
    """
    points = np.asarray(points, dtype=float)
    p = model.platform
    if len(p) == 3:
        R = _triangle_frame(points) @ np.swapaxes(_triangle_frame(p), -1, -2)
        t = points.mean(axis=-2) - np.einsum("...ij,j->...i", R, p.mean(axis=0))
        return np.concatenate([t, rpy_from_matrix(R)], axis=-1)
    pc, Pc = p.mean(axis=0), points.mean(axis=0)
    U, _, Vt = np.linalg.svd((p - pc).T @ (points - Pc))
    d = np.sign(np.linalg.det(Vt.T @ U.T)) or 1.0
    R = Vt.T @ np.diag([1.0, 1.0, d]) @ U.T
    return np.concatenate([Pc - R @ pc, rpy_from_matrix(R)])


def _triangle_frame(tri: np.ndarray) -> np.ndarray:
    """Columns e1 along edge 0->1, e3 normal to the triangle, e2 = e3 x e1: (..., 3, 3)."""
    e1 = tri[..., 1, :] - tri[..., 0, :]
    e1 = e1 / np.linalg.norm(e1, axis=-1, keepdims=True)
    e3 = np.cross(e1, tri[..., 2, :] - tri[..., 0, :])
    e3 = e3 / np.linalg.norm(e3, axis=-1, keepdims=True)
    return np.stack([e1, np.cross(e3, e1), e3], axis=-1)
