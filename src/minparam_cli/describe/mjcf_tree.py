"""The compiled MuJoCo model's bodies -> RobotDescription (``describe/mjcf.py`` gives the rules).

MuJoCo places body b at T_parent · T(body_pos, body_quat) · J_1(q_1) · … · J_k(q_k), its k joints
applied in order in the moving body frame: a hinge J = T(p)·R(axis, q − ref)·T(−p) (p: the joint's
``pos``), a slide J = T(axis·(q − ref)).  Each hinge or slide joint becomes one record whose link
frame is the frame after its motion at the anchor p: origin = (transform so far)·T(p)·Motion(−ref),
and T(−p) leads on to the body frame.  The body's inertia (``body_mass/ipos/iquat/inertia``, as the
compiler made it, inferred from geoms or not) goes to the link of its last joint, or of the nearest
moving ancestor when it has none.
"""

from __future__ import annotations

import math
import re
from fractions import Fraction

import numpy as np

from minparam_cli.describe.records import GeomValue, Inertial, JointRecord, RobotDescription
from minparam_cli.describe.urdf_tool import default_tool
from minparam_cli.errors import DescriptionError, NotARobotError
from minparam_cli.safety import MAX_JOINTS

# eq_type and jnt_type values of mujoco.mjtEq / mujoco.mjtJoint (checked against the module in tests)
EQ_CONNECT, EQ_WELD, EQ_JOINT, EQ_TENDON = 0, 1, 2, 3
JNT_FREE, JNT_BALL, JNT_SLIDE, JNT_HINGE = 0, 1, 2, 3
DSBL_GRAVITY = 128  # mujoco.mjtDisableBit.mjDSBL_GRAVITY
# a compiled angle this close to a multiple of 90° is that multiple (the compiler's own rounding of
# euler="0 90 0" or a quaternion's cos 45°), so exact geometry stays exact
RIGHT_ANGLE_TOL = 1e-12
VIRTUAL = (("x", "prismatic", (1.0, 0.0, 0.0)), ("y", "prismatic", (0.0, 1.0, 0.0)), ("z", "prismatic", (0.0, 0.0, 1.0)),
           ("rx", "revolute", (1.0, 0.0, 0.0)), ("ry", "revolute", (0.0, 1.0, 0.0)), ("rz", "revolute", (0.0, 0.0, 1.0)))
# extra id -> the dof attribute that is its nominal value
NOMINAL = (("rotor_inertia", "dof_armature"), ("coulomb", "dof_frictionloss"), ("viscous", "dof_damping"))


def quat_matrix(q) -> np.ndarray:
    """Rotation matrix of a unit quaternion (w, x, y, z), MuJoCo's order."""
    w, x, y, z = (float(v) for v in q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def _pose(pos, R=None) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = [float(v) for v in pos]
    if R is not None:
        T[:3, :3] = R
    return T


def _motion(hinge: bool, axis: np.ndarray, q: float) -> np.ndarray:
    """4x4 motion of a hinge (about ``axis`` through the origin) or slide joint by q."""
    if not hinge:
        return _pose(q * axis)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return _pose((0, 0, 0), np.eye(3) + math.sin(q) * K + (1 - math.cos(q)) * (K @ K))


def _rpy(R: np.ndarray) -> tuple[float, float, float]:
    """(roll, pitch, yaw) with R = Rz(yaw)·Ry(pitch)·Rx(roll), URDF's order; pitch by atan2 (exact near ±90°)."""
    cp = math.hypot(R[0, 0], R[1, 0])
    pitch = math.atan2(-R[2, 0], cp)
    if cp > 1e-9:
        return math.atan2(R[2, 1], R[2, 2]), pitch, math.atan2(R[1, 0], R[0, 0])
    return 0.0, pitch, math.atan2(-R[0, 1], R[1, 1])


def _rpy_matrix(r: float, p: float, y: float) -> np.ndarray:
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    return np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]]) @ np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]]) @ np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])


def _angle(v: float, symbol: str, snap: float | None, where: str, changes: list) -> GeomValue:
    """The GeomValue of a compiled angle: multiples of 90° (to the compiler's rounding) exact; with
    ``snap`` (--snap-angles) within it of a multiple of 15° rounded to it and recorded."""
    k = round(v / (math.pi / 2))
    if abs(v - k * math.pi / 2) <= RIGHT_ANGLE_TOL:
        return GeomValue(k * (math.pi / 2), symbol, True, Fraction(90 * k))
    if snap is not None:
        from minparam_cli.describe.snap import adjustment, snapped_angle

        hit = snapped_angle(v, snap)
        if hit is not None:
            changes.append(adjustment(where, v, hit[0], hit[1]))
            return GeomValue(hit[0], symbol, True, Fraction(hit[1]) if hit[1] % 90 == 0 else None)
    return GeomValue(v, symbol, True, None)


def _origin(T: np.ndarray, base: str, snap: float | None, where: str, changes: list):
    """(origin dict, pre_fixed) of a joint whose frame is T in its parent link's frame; pre_fixed
    carries what the roll-pitch-yaw triple misses beyond rounding (None: nothing)."""
    rpy = _rpy(T[:3, :3])
    origin = {k: GeomValue(float(v) + 0.0, f"{base}_{k}", False, Fraction(repr(float(v) + 0.0)))
              for k, v in zip(("x", "y", "z"), T[:3, 3], strict=True)}
    for k, v in zip(("roll", "pitch", "yaw"), rpy, strict=True):
        origin[k] = _angle(v, f"{base}_{k}", snap, f"{where}/origin {k}", changes)
    residual = _rpy_matrix(*rpy).T @ T[:3, :3]
    if np.max(np.abs(residual - np.eye(3))) <= 4e-16:
        return origin, None
    fix = T @ np.linalg.inv(_pose(T[:3, 3], _rpy_matrix(*rpy)))  # T = fix · origin
    return origin, tuple(tuple(float(x) for x in r) for r in fix)


def _symbol_base(name: str) -> str:
    s = re.sub(r"\W", "_", name)
    return s if re.match(r"^[A-Za-z_]", s) else f"j_{s}"


def _body_phi(m, b: int, X: np.ndarray) -> np.ndarray:
    """Khalil's 10 standard parameters of body b (about the link frame origin, link axes), the body
    frame being X in the link frame."""
    mass = float(m.body_mass[b])
    Ri = X[:3, :3] @ quat_matrix(m.body_iquat[b])
    c = X[:3, :3] @ np.asarray(m.body_ipos[b], dtype=float) + X[:3, 3]
    Io = Ri @ np.diag(np.asarray(m.body_inertia[b], dtype=float)) @ Ri.T + mass * (c @ c * np.eye(3) - np.outer(c, c))
    return np.array([Io[0, 0], Io[0, 1], Io[0, 2], Io[1, 1], Io[1, 2], Io[2, 2], *(mass * c), mass])


def _inertial(phi: np.ndarray) -> Inertial:
    m = float(phi[9])
    c = phi[6:9] / m if m > 0 else np.zeros(3)
    Io = np.array([[phi[0], phi[1], phi[2]], [phi[1], phi[3], phi[4]], [phi[2], phi[4], phi[5]]])
    Ic = Io - m * (c @ c * np.eye(3) - np.outer(c, c))
    return Inertial(m, (float(c[0]), float(c[1]), float(c[2])), (Ic[0, 0], Ic[0, 1], Ic[0, 2], Ic[1, 1], Ic[1, 2], Ic[2, 2]))


def _joint_limits(m, j: int) -> dict:
    out: dict = {"limits": None, "max_effort": None}
    if m.jnt_limited[j] and m.jnt_range[j, 0] < m.jnt_range[j, 1]:
        out["limits"] = (float(m.jnt_range[j, 0]), float(m.jnt_range[j, 1]))
    if m.jnt_actfrclimited[j]:
        effort = float(max(abs(m.jnt_actfrcrange[j, 0]), abs(m.jnt_actfrcrange[j, 1])))
        out["max_effort"] = effort if effort > 0 else None
    return out


def _nominal(m, j: int) -> tuple[tuple[str, float], ...]:
    dof = int(m.jnt_dofadr[j])
    return tuple((kind, float(getattr(m, attr)[dof])) for kind, attr in NOMINAL if getattr(m, attr)[dof] != 0.0)


def build_description(m, names, src: str, free: int | None, locked: dict[int, float], masters: dict, snap: float | None,
                      left_out: frozenset[int] = frozenset()) -> tuple[RobotDescription, dict, dict[int, int]]:
    """Walk the compiled bodies (parents come first in MuJoCo's numbering) into joint records: the
    description, each body's (record, body frame in that record's link frame) and MuJoCo joint -> record."""
    records: list[dict] = []
    phi: list[np.ndarray | None] = []
    changes: list[dict] = []
    attached: list[tuple[str, int, tuple[float, float, float]]] = []
    index: dict[int, int] = {}  # MuJoCo joint id -> record index
    state: dict[int, tuple[int, np.ndarray]] = {0: (-1, np.eye(4))}  # body -> (record, body frame in the link frame)
    for b in range(1, m.nbody):
        if int(m.body_rootid[b]) in left_out:
            continue
        rec, X = state[int(m.body_parentid[b])]
        X = X @ _pose(m.body_pos[b], quat_matrix(m.body_quat[b]))
        first = int(m.body_jntadr[b])
        moving = [j for j in range(first, first + int(m.body_jntnum[b])) if int(m.jnt_type[j]) != JNT_FREE and j not in locked]
        for j in range(first, first + int(m.body_jntnum[b])):
            kind = int(m.jnt_type[j])
            if kind == JNT_FREE:  # a floating base (mjcf._check_joints: the world's child, its only joint)
                rec = len(records) + 5  # the sixth virtual joint carries the free body
                records.extend(_virtual(names.body[b], X, {names.joint[i] for i in range(m.njnt)}, snap, changes))
                phi.extend([None] * 6)
                X = np.eye(4)
                continue
            hinge = kind == JNT_HINGE
            axis = np.asarray(m.jnt_axis[j], dtype=float)
            axis = axis / np.linalg.norm(axis)
            p = np.asarray(m.jnt_pos[j], dtype=float)
            ref = float(m.qpos0[m.jnt_qposadr[j]])
            if j in locked:  # welded at its locked value
                X = X @ _pose(p) @ _motion(hinge, axis, locked[j] - ref) @ _pose(-p)
                continue
            name = names.joint[j]
            origin, pre = _origin(X @ _pose(p) @ _motion(hinge, axis, -ref), _symbol_base(name), snap, f"joint[{name}]", changes)
            nominal = _nominal(m, j)
            index[j] = len(records)
            records.append(dict(name=name, type="revolute" if hinge else "prismatic", parent=rec,
                                link_name=names.body[b] if j == moving[-1] else f"{names.body[b]}/{name}", origin=origin,
                                pre_fixed=pre, axis=tuple(float(v) for v in axis), extras=tuple(k for k, _ in nominal),
                                nominal_extras=nominal, massless=j != moving[-1], **_joint_limits(m, j)))
            phi.append(None)
            rec = len(records) - 1
            X = _pose(-p)
        state[b] = (rec, X)
        if rec < 0:
            continue  # welded to the world
        if m.body_mass[b] > 0 or np.any(m.body_inertia[b]):
            contribution = _body_phi(m, b, X)
            phi[rec] = contribution if phi[rec] is None else phi[rec] + contribution
        attached.append((names.body[b], rec, (float(X[0, 3]) + 0.0, float(X[1, 3]) + 0.0, float(X[2, 3]) + 0.0)))
    _add_sites(m, names, state, attached)
    if not records:
        raise NotARobotError("no hinge, slide or free joint: the model does not move (a scene or a fragment to include?)", src)
    if len(records) > MAX_JOINTS:
        raise DescriptionError(f"{len(records)} joints exceed the limit of {MAX_JOINTS}", src)
    joints = []
    for k, (r, body_sum) in enumerate(zip(records, phi, strict=True)):
        mimic = None
        for j, i in index.items():
            if i == k and j in masters:
                master, mult, off = masters[j]
                mimic = (index[master], mult, off)
        inertial = None if r.get("massless") else _inertial(body_sum if body_sum is not None else np.zeros(10))
        joints.append(JointRecord(**r, inertial=inertial, mimic=mimic))
    tool_link, tool = default_tool(attached, records)
    disabled = bool(int(m.opt.disableflags) & DSBL_GRAVITY)
    gravity = (0.0, 0.0, 0.0) if disabled else tuple(float(g) for g in m.opt.gravity)
    desc = RobotDescription(name=names.model, source=src, convention="mjcf", joints=tuple(joints),
                            gravity=gravity, gravity_source="file",  # type: ignore[arg-type]
                            tool=tool, tool_link=tool_link, tool_links=tuple(attached), adjustments=tuple(changes))
    return desc, state, index


def _add_sites(m, names, state: dict, attached: list) -> None:
    """Named sites on moving bodies are tool points too (Menagerie arms mark their flange with one)."""
    taken = {a[0] for a in attached}
    for s in range(m.nsite):
        name = names.site[s]
        rec, X = state.get(int(m.site_bodyid[s]), (-1, None))
        if not name or name in taken or rec < 0 or X is None:
            continue
        pos = X[:3, :3] @ np.asarray(m.site_pos[s], dtype=float) + X[:3, 3]
        attached.append((name, rec, (float(pos[0]) + 0.0, float(pos[1]) + 0.0, float(pos[2]) + 0.0)))
        taken.add(name)


def _virtual(free: str, X: np.ndarray, taken: set[str], snap: float | None, changes: list) -> list[dict]:
    """The six virtual joints of a floating base in front of body ``free`` (urdf_tree's VIRTUAL): q = 0
    puts the body at its compiled pose X."""
    out = []
    for k, (suffix, kind, axis) in enumerate(VIRTUAL):
        name = f"{free}_{suffix}"
        while name in taken:
            name += "_"
        T = X if k == 0 else np.eye(4)
        origin, pre = _origin(T, _symbol_base(name), snap, f"joint[{name}]", changes)
        out.append(dict(name=name, type=kind, parent=k - 1, link_name=free if k == 5 else "", origin=origin, pre_fixed=pre,
                        axis=axis, virtual=True, massless=k < 5))
    return out

