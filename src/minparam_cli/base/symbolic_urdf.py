"""URDF geometry the symbolic route reads as symbols: lumped fixed joints and oblique axes.

The symbolic route works on a *rewritten* description, equal to the file's robot (the same
link frames, so the same standard parameters and the same regressor):

* a joint after lumped fixed joints: the fixed transforms before it and its own origin are one
  rigid transform T = T_fixed · T_origin from the parent moving link's frame to the joint frame.
  It is written as x y z roll pitch yaw (T = Trans(xyz)·Rz(yaw)·Ry(pitch)·Rx(roll)) under the
  joint's own origin symbols (``<joint>_x`` … ``<joint>_yaw``).  The lumped rotation's angles
  within ``RIGHT_ANGLE_TOL`` of a right angle are taken as that right angle first (URDF files
  write π/2 with 9–16 digits), so a flange turned by 90° adds no angle symbol.
* an axis u not along ±x, ±y, ±z: two angle symbols, ``<joint>_axis_theta`` (polar) and
  ``<joint>_axis_phi`` (azimuth), u = (cos φ sin θ, sin φ sin θ, cos θ).  The rotation that
  turns z onto u is R_u = Rz(φ)·Ry(θ), exactly orthogonal in the field of the symbols (its
  entries are products of the angles' sin and cos, with sin² + cos² = 1 kept by the normal
  form), so Khalil's rules of stage 1 apply to it unchanged.  A right angle among θ, φ (an
  axis in a coordinate plane) is a number, as for every other angle.
"""

from __future__ import annotations

import math
from dataclasses import replace
from fractions import Fraction

import numpy as np

from minparam_cli.describe.records import GeomValue

AXIS_THETA, AXIS_PHI = "axis_theta", "axis_phi"
MIMIC_OFFSET = "mimic_offset"
_RPY = ("roll", "pitch", "yaw")


def _rot(roll: float, pitch: float, yaw: float) -> np.ndarray:
    cr, sr, cp, sp, cy, sy = math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch), math.cos(yaw), math.sin(yaw)
    Rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
    Ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    Rx = np.array([[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])
    return Rz @ Ry @ Rx


def rpy_of(R: np.ndarray) -> tuple[float, float, float]:
    """roll, pitch, yaw with R = Rz(yaw)·Ry(pitch)·Rx(roll) (at pitch = ±90°: roll = 0)."""
    pitch = math.atan2(-R[2, 0], math.hypot(R[0, 0], R[1, 0]))  # not asin: accurate near ±90°
    if math.hypot(R[2, 1], R[2, 2]) > 1e-12:
        return math.atan2(R[2, 1], R[2, 2]), pitch, math.atan2(R[1, 0], R[0, 0])
    return 0.0, pitch, math.atan2(-R[0, 1], R[1, 1])


def _snap(angle: float, tol: float) -> float:
    k = round(angle / (math.pi / 2))
    return k * math.pi / 2 if abs(angle - k * math.pi / 2) <= tol else angle


def _origin_matrix(origin: dict) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = _rot(*(origin[k].value for k in _RPY))
    T[:3, 3] = [origin[k].value for k in ("x", "y", "z")]
    return T


def is_frame_axis(axis) -> bool:
    return sorted(abs(float(c)) for c in axis) == [0.0, 0.0, 1.0]


def symbolic_description(desc, right_angle_tol: float):
    """The description with every URDF joint's geometry in its origin symbols (see module doc)."""
    if desc.convention not in ("urdf", "mjcf"):
        return desc
    joints = []
    for jr in desc.joints:
        if jr.dh is not None or jr.origin is None:
            joints.append(jr)
            continue
        origin = dict(jr.origin)
        if jr.pre_fixed is not None:
            F = np.array(jr.pre_fixed, dtype=float)
            F[:3, :3] = _rot(*(_snap(a, right_angle_tol) for a in rpy_of(F[:3, :3])))
            T = F @ _origin_matrix(origin)
            xyz = T[:3, 3]
            tiny = 1e-12 * max(1e-3, float(np.abs(xyz).max()))
            new = dict(zip(("x", "y", "z"), (0.0 if abs(v) <= tiny else float(v) for v in xyz), strict=True))
            new.update(zip(_RPY, (_snap(a, 1e-14) for a in rpy_of(T[:3, :3])), strict=True))
            # a fixed rotation by right angles only: the composed lengths are sums of the file's
            # decimals (read back to 12 significant digits); else irrational, kept as symbols only
            perm = bool(np.all(np.isin(F[:3, :3], (-1.0, 0.0, 1.0)) | (np.abs(F[:3, :3]) < 1e-15)))
            for k, v in new.items():
                old = origin[k]
                exact = Fraction(f"{v:.12g}") if perm and not old.is_angle else None
                origin[k] = GeomValue(float(v), old.symbol, old.is_angle, exact, old.named)
        u = np.asarray(jr.axis, dtype=float)
        u = u / np.linalg.norm(u)
        if not is_frame_axis(jr.axis):
            theta, phi = math.acos(max(-1.0, min(1.0, u[2]))), math.atan2(u[1], u[0])
            origin[AXIS_THETA] = GeomValue(theta, f"{jr.name}_axis_theta", True)
            origin[AXIS_PHI] = GeomValue(phi, f"{jr.name}_axis_phi", True)
        if jr.mimic is not None and jr.mimic[2] != 0.0:
            o = float(jr.mimic[2])
            exact = None if jr.type == "revolute" else Fraction(repr(o))
            origin[MIMIC_OFFSET] = GeomValue(o, f"{jr.name}_mimic_offset", jr.type == "revolute", exact)
        joints.append(replace(jr, origin=origin, pre_fixed=None))
    return replace(desc, joints=tuple(joints))


def axes_at(desc, values: dict):
    """The rewritten description with each oblique axis at the values of its angle symbols and each
    mimic joint's offset at the value of its symbol."""
    if desc.convention not in ("urdf", "mjcf") or not any(jr.origin and (AXIS_THETA in jr.origin or MIMIC_OFFSET in jr.origin)
                                            for jr in desc.joints):
        return desc
    joints = []
    for jr in desc.joints:
        if jr.origin and AXIS_THETA in jr.origin:
            th, ph = (values.get(jr.origin[k].symbol, jr.origin[k].value) for k in (AXIS_THETA, AXIS_PHI))
            jr = replace(jr, axis=(math.cos(ph) * math.sin(th), math.sin(ph) * math.sin(th), math.cos(th)))
        if jr.origin and MIMIC_OFFSET in jr.origin:
            gv = jr.origin[MIMIC_OFFSET]
            jr = replace(jr, mimic=(jr.mimic[0], jr.mimic[1], float(values.get(gv.symbol, gv.value))))
        joints.append(jr)
    return replace(desc, joints=tuple(joints))


def axis_rotation_oblique(jr, ar):
    """R_u = Rz(φ)·Ry(θ) (4x4) in the arithmetic ``ar``: R_u·e_z = u."""
    ct, st = ar.cos_sin(jr.origin[AXIS_THETA])
    cp, sp = ar.cos_sin(jr.origin[AXIS_PHI])
    z, o = ar.zero, ar.one
    return [[cp * ct, -sp, cp * st, z], [sp * ct, cp, sp * st, z], [-st, z, ct, z], [z, z, z, o]]


# --- exact numbers instead of symbols (``derive --symbolic-numbers``) ----------


def _rational_sqrt(x):
    from math import isqrt

    n, d = x.numerator, x.denominator
    rn, rd = isqrt(n), isqrt(d)
    return None if x < 0 or rn * rn != n or rd * rd != d else type(x)(rn, rd)


def rational_axis(axis):
    """The unit axis as exact rationals (e.g. 0.6 0.8 0, or 1 2 2 / 3) or None: components within
    1e-12 of the file's unit axis whose squares sum to 1 exactly."""
    u = [Fraction(float(c)).limit_denominator(10**6) for c in axis]
    if sum(c * c for c in u) != 1 or any(abs(float(c) - float(a)) > 1e-12 for c, a in zip(u, axis, strict=True)):
        return None
    return u


def exact_numbers(desc, symbols, shifts) -> dict:
    """{symbol: Fraction (a length) or (cos, sin) (an angle)}: the geometry that becomes exact
    numbers.  Lengths: the file's decimals (``GeomValue.exact``; for an origin composed with fixed
    joints turned by right angles, sums of the file's decimals read back to 12 significant digits).  Axis angles: when the unit axis has
    rational components (``rational_axis``), cos and sin of θ and φ are rational.  Every other
    angle stays a symbol: the cosine and sine of a rational angle (rad, or degrees other than
    multiples of 90°) are not both rational.  Shift symbols stay symbols (they cannot appear), and so
    do lengths without an exact value (an origin composed with a skew fixed rotation)."""
    names = {s.name for s in symbols}
    out: dict = {}
    for name, gv in desc.geometry().items():
        if name in names and name not in shifts and not gv.is_angle and gv.exact is not None:
            out[name] = gv.exact
    for jr in desc.joints:
        if jr.origin is None or AXIS_THETA not in jr.origin:
            continue
        u = rational_axis(jr.axis)
        st = None if u is None else _rational_sqrt(1 - u[2] * u[2])
        if not st:
            continue
        out[jr.origin[AXIS_THETA].symbol] = (u[2], st)
        out[jr.origin[AXIS_PHI].symbol] = (u[0] / st, u[1] / st)
    return {k: v for k, v in out.items() if k in names}
