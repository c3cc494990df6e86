"""MJCF ``connect`` and ``weld`` equalities -> the cuts of a closed chain (``describe/loops.py``), and the
actuated joints from the ``<actuator>`` elements with a joint transmission (docs/mjcf.md).

The compiled ``eq_data`` is read as MuJoCo's engine reads it (its constraint residuals are checked
against the cuts' on states of the loops in tests/test_mjcf_loops.py):

* ``connect`` between bodies: ``eq_data[0:3]`` is the anchor in body1's frame, ``eq_data[3:6]`` the
  same point in body2's frame where qpos0 puts it (the compiler's); the two points coincide;
* ``weld`` between bodies: ``eq_data[0:3]`` a point in body2's frame, ``eq_data[3:6]`` a point in
  body1's frame and ``eq_data[6:10]`` the quaternion q_rel with q_1·q_rel = q_2 (the relpose, or
  the compiler's at qpos0): frame_a = (eq_data[3:6], q_rel) on body1 and frame_b = (eq_data[0:3],
  identity) on body2 coincide; ``torquescale`` 0 leaves only the points (a connect);
* with ``site1``/``site2``: the two sites' origins coincide (connect), or their frames (weld).

A body without joints is welded to its moving ancestor: its points are carried into that link's
frame.  The cut's ``frame_b`` is always given (the compiler's point), never None.
"""

from __future__ import annotations

import numpy as np

from minparam_cli.describe.loops import ClosedLoops, LoopCut
from minparam_cli.describe.mjcf_tree import EQ_CONNECT, EQ_WELD, quat_matrix
from minparam_cli.errors import DescriptionError, UnsupportedError

OBJ_SITE = 6  # mujoco.mjtObj.mjOBJ_SITE
TRN_JOINT, TRN_JOINTINPARENT = 0, 1  # mujoco.mjtTrn


def _pose(pos, quat=None) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = [float(v) for v in pos]
    if quat is not None:
        T[:3, :3] = quat_matrix(quat)
    return T


def _as_pose(T: np.ndarray):
    return tuple(tuple(float(x) + 0.0 for x in row) for row in T)


def closed_loops(m, names, src: str, equalities: list[int], frames: dict, index: dict[int, int],
                 free: int | None, masters: dict) -> ClosedLoops:
    """The ``ClosedLoops`` of the active connect/weld equalities ``equalities``.  ``frames``: body ->
    (record, body frame in that record's link frame), -1 for the world; ``index``: MuJoCo joint ->
    record."""
    import mujoco

    first = names.equality[equalities[0]]
    if free is not None:
        raise UnsupportedError("connect/weld equalities on a floating-base model (a closed chain on a free body) are not "
                               "supported yet", src, first)
    if masters:
        raise UnsupportedError("joint equalities coupling two joints (mimic joints) in a model with connect/weld "
                               "equalities are not supported yet", src, first)
    if len(equalities) > len(index):  # as for a closed-chain YAML (closed_yaml._cuts): one cut per joint at most
        raise DescriptionError(f"{len(equalities)} active connect/weld equalities for {len(index)} joints: at most one per joint", src, first)
    cuts = []
    for e in equalities:
        where, kind = names.equality[e], int(m.eq_type[e])
        ids = (int(m.eq_obj1id[e]), int(m.eq_obj2id[e]))
        sites = int(m.eq_objtype[e]) == OBJ_SITE
        bodies = tuple(int(m.site_bodyid[i]) if sites else i for i in ids)
        for b in bodies:
            if b not in frames:
                raise UnsupportedError(f"the equality holds body '{names.body[b]}', a free object left out of the robot",
                                       src, where)
        (rec_a, Xa), (rec_b, Xb) = frames[bodies[0]], frames[bodies[1]]
        if rec_a == rec_b:
            raise DescriptionError(f"the equality joins bodies '{names.body[bodies[0]]}' and '{names.body[bodies[1]]}', "
                                   "which move as one rigid body (no joint between them): it closes no loop", src, where)
        data = np.asarray(m.eq_data[e], dtype=float)
        if sites:
            Fa = Xa @ _pose(m.site_pos[ids[0]], m.site_quat[ids[0]])
            Fb = Xb @ _pose(m.site_pos[ids[1]], m.site_quat[ids[1]])
        elif kind == EQ_CONNECT:
            Fa, Fb = Xa @ _pose(data[0:3]), Xb @ _pose(data[3:6])
        else:
            Fa, Fb = Xa @ _pose(data[3:6], data[6:10]), Xb @ _pose(data[0:3])
        cut_kind = "weld" if kind == EQ_WELD and data[10] != 0.0 else "connect"
        given = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_EQUALITY, e)
        cuts.append(LoopCut(given or f"equality{e + 1}", cut_kind, rec_a, rec_b, _as_pose(Fa), _as_pose(Fb)))
    actuated = set()
    for a in range(m.nu):
        if int(m.actuator_trntype[a]) not in (TRN_JOINT, TRN_JOINTINPARENT):
            continue
        j = int(m.actuator_trnid[a, 0])
        if j not in index:
            raise UnsupportedError(f"an actuator drives joint '{names.joint[j]}', which a joint equality locks", src,
                                   f"actuator #{a + 1}")
        actuated.add(index[j])
    if not actuated:
        raise DescriptionError("connect/weld equalities close kinematic loops, but no actuator drives a joint: add an "
                               "<actuator> with joint= for each driven joint, e.g. <motor joint=\"...\"/>", src, first)
    joint_of = {r: j for j, r in index.items()}
    reference = tuple(float(m.qpos0[m.jnt_qposadr[joint_of[r]]]) for r in range(len(joint_of)))
    return ClosedLoops(tuple(cuts), tuple(sorted(actuated)), reference, "mjcf")
