"""The record of a closed kinematic chain: a spanning tree (the description's joints) plus the
loop-closing cuts between two of its links, and which joints are actuated.

Every loader of a closed chain fills the same record (docs/methods/closed_chains.md):

* the closed-chain YAML (``kind: closed_chain``, ``describe/closed_yaml.py``);
* a platform YAML with a ``dynamics:`` section (``describe/platform_chain.py``): the legs and the
  platform become a tree, every leg but the first closed on the platform by a ``connect`` cut;
* the MJCF reader (``describe/mjcf_loops.py``): an active ``<connect>`` or ``<weld>`` equality is a
  cut between the links of its two bodies (-1: the world), ``frame_a``/``frame_b`` the compiled
  ``eq_data``'s points (and a weld's relative orientation on body 1) carried into those links'
  frames; the actuated joints are those an ``<actuator>`` drives through a joint transmission, the
  reference qpos0.  ``frame_b=None`` means: body b's point (or frame) is where frame_a lies at
  ``ClosedLoops.reference``, so such a cut closes there by construction (MuJoCo's convention; the
  MJCF reader gives the compiler's point itself).

Kinds of cut (the constraint they impose between frame_a on body a and frame_b on body b):
``connect`` (the two origins coincide: a ball joint, 3 equations), ``revolute`` (origins and z axes
coincide: a hinge, 5), ``weld`` (the frames coincide, 6).  Equations that repeat others (a planar
loop: the out-of-plane ones) are found by rank, not declared.
"""

from __future__ import annotations

from dataclasses import dataclass

CUT_KINDS = ("connect", "revolute", "weld")

Pose = tuple[tuple[float, float, float, float], ...]  # a 4x4 homogeneous transform, row by row


@dataclass(frozen=True)
class LoopCut:
    """One loop-closing joint between body a and body b (joint indices of the tree, -1: the base)."""

    name: str
    kind: str  # one of CUT_KINDS
    body_a: int
    body_b: int
    frame_a: Pose  # in body a's link frame, SI
    frame_b: Pose | None  # in body b's link frame (the base frame for -1); None: where frame_a is at the reference


@dataclass(frozen=True)
class ClosedLoops:
    """The loops of a closed chain: the cuts, the actuated joints (indices into the tree, in the
    order of the torques) and the reference configuration of every tree joint (SI), near which the
    mechanism is assembled (the start of the closure's Newton iterations)."""

    cuts: tuple[LoopCut, ...]
    actuated: tuple[int, ...]
    reference: tuple[float, ...]
    origin: str = "yaml"  # "yaml" | "platform" | "mjcf": which loader filled it


def pose(xyz=(0.0, 0.0, 0.0), rpy=(0.0, 0.0, 0.0)) -> Pose:
    """The 4x4 pose of a translation and roll-pitch-yaw angles (URDF's order: Rz(yaw) Ry(pitch) Rx(roll))."""
    import math

    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    R = ((cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr),
         (sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr),
         (-sp, cp * sr, cp * cr))
    return tuple((*R[i], float(xyz[i])) for i in range(3)) + ((0.0, 0.0, 0.0, 1.0),)
