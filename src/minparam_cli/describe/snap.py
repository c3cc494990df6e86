"""``--snap-angles TOL``: round angles that sit within TOL of a multiple of π/12 (15°).

Real files write π/2 as 1.57079 or π as 3.14158: the axes they build are a few
microradians from parallel or perpendicular, and parameters that only that
tilt makes identifiable become part of the base set (weakly: see
``base/weak.py``).  Snapping writes the angle the author meant.  Every value
changed is recorded (``RobotDescription.adjustments``) and printed, so nothing
is changed silently.  Angles that land on a multiple of 90° become exact, so
the exact routes (projection, symbolic) can use them.
"""

from __future__ import annotations

import math
from dataclasses import replace
from fractions import Fraction

from minparam_cli.describe.records import GeomValue, RobotDescription

STEP_DEG = 15
STEP = math.pi / 12
# a tolerance of half the step or more would move every angle
MAX_TOLERANCE = STEP / 2


def snapped_angle(value: float, tol: float) -> tuple[float, int] | None:
    """(the multiple of π/12, its degrees) when ``value`` (rad) is within ``tol`` of it but not on it."""
    k = round(value / STEP)
    target = k * STEP
    if k % 6 == 0:  # multiples of 90°: write them as exactly as floats allow
        target = (k // 6) * (math.pi / 2)
    diff = abs(value - target)
    if diff > tol or diff == 0.0:
        return None
    return target, k * STEP_DEG


def adjustment(where: str, old: float, new: float, degrees: int) -> dict:
    return {"where": where, "from": old, "to": new, "degrees": degrees, "change": new - old}


def snap_description(desc: RobotDescription, tol: float) -> RobotDescription:
    """DH/MDH tables: the angle entries of every row (alpha, theta) snapped, the changes recorded."""
    joints, changes = [], list(desc.adjustments)
    for jr in desc.joints:
        if jr.dh is None:
            joints.append(jr)
            continue
        table = dict(jr.dh)
        for key, g in jr.dh.items():
            if not g.is_angle:
                continue
            hit = snapped_angle(g.value, tol)
            if hit is None:
                continue
            table[key] = _snapped_value(g, *hit)
            changes.append(adjustment(f"joint[{jr.name}]/{key}", g.value, hit[0], hit[1]))
        joints.append(replace(jr, dh=table))
    return replace(desc, joints=tuple(joints), adjustments=tuple(changes))


def _snapped_value(g: GeomValue, value: float, degrees: int) -> GeomValue:
    return replace(g, value=value, exact=Fraction(degrees))
