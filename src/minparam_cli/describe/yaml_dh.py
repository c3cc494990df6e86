"""YAML DH/MDH robot tables -> RobotDescription.

Schema (docs/yaml-schema.md has the full page)::

    name: PUMA 560
    convention: dh            # dh: Rz(theta) Tz(d) Tx(a) Rx(alpha); mdh: Rx(alpha) Tx(a) Rz(theta) Tz(d)
    units: {length: mm, angle: deg}
    gravity: [0, 0, -9.81]    # m/s^2, optional
    friction: [coulomb, viscous]   # optional, whole robot
    rotor_inertia: true            # optional, whole robot
    tool: [0, 0, 0.1]              # optional tool point in the last link frame (length unit)
    joints:
      - {name: j1, type: revolute, alpha: -90, a: 0, d: 0, theta: 0}
      - {type: revolute, alpha: 0, a: {symbol: a2, value: 431.8}, d: 150, theta: 0,
         friction: [viscous], rotor_inertia: false, limits: [-160, 160],
         inertial: {mass: 17.4, com: [-363.8, 6, 77.4], inertia: [0.13, 0, 0, 0.524, 0, 0.539]}}
"""

from __future__ import annotations

import math
import re
from fractions import Fraction
from pathlib import Path
from typing import Any

from minparam_cli.describe.angles import parse_angle
from minparam_cli.describe.records import GeomValue, Inertial, JointRecord, RobotDescription
from minparam_cli.safety import MAX_JOINTS, finite_number, key_list, mapping_entry, read_yaml, short_repr
from minparam_cli.errors import DescriptionError, NotARobotError
from minparam_cli.params import FRICTION_KINDS

LENGTH_UNITS = {"m": Fraction(1), "mm": Fraction(1, 1000)}
ANGLE_UNITS = ("deg", "rad")
CONVENTIONS = ("dh", "mdh")
JOINT_TYPES = ("revolute", "prismatic")
TOP_KEYS = {"kind", "name", "convention", "units", "gravity", "friction", "rotor_inertia", "tool", "joints", "description",
            "transmission", "identified", "drive_gains"}
JOINT_KEYS = {"name", "type", "alpha", "a", "d", "theta", "friction", "rotor_inertia", "limits", "velocity", "acceleration",
              "effort", "inertial"}


def load_yaml(path: Path) -> RobotDescription:
    return description_from_mapping(read_yaml(path), str(path))


def description_from_mapping(doc: Any, src: str) -> RobotDescription:
    """Validate a parsed YAML document and build the description record."""
    if not isinstance(doc, dict):
        raise DescriptionError("expected a mapping with 'name', 'convention' and 'joints'", src)
    if doc.get("kind", "robot") != "robot":
        if doc.get("kind") == "platform":
            raise NotARobotError("is a parallel-platform description; use 'minparam platform'", src)
        raise DescriptionError(f"unknown kind {short_repr(doc.get('kind'))}; expected 'robot'", src, "kind")
    unknown = set(doc) - TOP_KEYS
    if unknown:
        raise DescriptionError(f"unknown key(s) {key_list(unknown)}", src)
    if "identified" in doc and not isinstance(doc["identified"], dict):  # identify --export-yaml's record, not read
        raise DescriptionError("expected a mapping (the values identify --export-yaml found)", src, "identified")
    for key in ("convention", "joints"):
        if key not in doc:
            raise DescriptionError(f"missing required field '{key}'", src)
    name = _text(doc.get("name"), src, "name") or Path(src).stem
    convention = doc["convention"]
    if not isinstance(convention, str) or convention not in CONVENTIONS:
        raise DescriptionError(f"unknown convention {short_repr(convention)}; expected 'dh' or 'mdh'", src, "convention")

    units = doc.get("units") or {}
    if not isinstance(units, dict):
        raise DescriptionError("expected a mapping like {length: mm, angle: deg}", src, "units")
    lu = units.get("length", "m")
    au = units.get("angle", "rad")
    if not isinstance(lu, str) or lu not in LENGTH_UNITS:
        raise DescriptionError(f"unknown length unit {short_repr(lu)}; expected 'm' or 'mm'", src, "units.length")
    if not isinstance(au, str) or au not in ANGLE_UNITS:
        raise DescriptionError(f"unknown angle unit {short_repr(au)}; expected 'deg' or 'rad'", src, "units.angle")
    scale = LENGTH_UNITS[lu]

    gravity = _vector3(doc.get("gravity", [0.0, 0.0, -9.81]), src, "gravity")
    robot_friction = _friction(doc.get("friction", []), src, "friction")
    robot_rotor = _bool(doc.get("rotor_inertia", False), src, "rotor_inertia")
    tool = None
    if doc.get("tool") is not None:
        tool = _scaled(float(scale), _vector3(doc["tool"], src, "tool"))

    joints_in = doc["joints"]
    if not isinstance(joints_in, list) or not joints_in:
        raise DescriptionError("expected a non-empty list of joints", src, "joints")
    if len(joints_in) > MAX_JOINTS:
        raise DescriptionError(f"{len(joints_in)} joints exceed the limit of {MAX_JOINTS}", src, "joints")

    joints: list[JointRecord] = []
    for i, jd in enumerate(joints_in):
        j = i + 1
        where = f"joints[{j}]"
        mapping_entry(jd, JOINT_KEYS, src, where, "type, alpha, a, d, theta")
        jtype = jd.get("type")
        if jtype is None:
            raise DescriptionError("missing required field 'type'", src, where)
        if not isinstance(jtype, str) or jtype not in JOINT_TYPES:
            raise DescriptionError(f"unknown joint type {short_repr(jtype)}; expected revolute or prismatic", src, f"{where}.type")
        dh = {}
        for key in ("alpha", "a", "d", "theta"):
            if key not in jd:
                raise DescriptionError(f"missing required field '{key}'", src, where)
            is_angle = key in ("alpha", "theta")
            dh[key] = _geom(jd[key], key, j, is_angle, scale, au, src, f"{where}.{key}")
        extras = set(robot_friction)
        if "friction" in jd:
            extras = set(_friction(jd["friction"], src, f"{where}.friction"))
        rotor = _bool(jd.get("rotor_inertia", robot_rotor), src, f"{where}.rotor_inertia")
        if rotor:
            extras.add("rotor_inertia")
        limits = None
        if jd.get("limits") is not None:
            lo, hi = _vector(jd["limits"], src, f"{where}.limits", n=2)
            unit = (math.pi / 180 if au == "deg" else 1.0) if jtype == "revolute" else float(scale)
            if not lo < hi:
                raise DescriptionError(f"lower limit {lo} is not below upper limit {hi}", src, f"{where}.limits")
            limits = (lo * unit, hi * unit)
        # speed limits in the file's units per s and per s² (deg/s under angle: deg, mm/s under length: mm);
        # effort always in N·m (revolute) or N (prismatic)
        rate_unit = (math.pi / 180 if au == "deg" else 1.0) if jtype == "revolute" else float(scale)
        max_velocity = _positive(jd.get("velocity"), rate_unit, src, f"{where}.velocity")
        max_acceleration = _positive(jd.get("acceleration"), rate_unit, src, f"{where}.acceleration")
        max_effort = _positive(jd.get("effort"), 1.0, src, f"{where}.effort")
        inertial = _inertial(jd.get("inertial"), scale, src, f"{where}.inertial")
        joint_name = _text(jd.get("name"), src, f"{where}.name") or f"joint{j}"
        if any(jr.name == joint_name for jr in joints):  # as URDF, MJCF and closed chains: an export names joints by it
            default = "" if jd.get("name") else f" (joint {j}'s default name)"
            raise DescriptionError(f"joint name {short_repr(joint_name)} is used twice{default}", src, f"{where}.name")
        joints.append(
            JointRecord(
                name=joint_name,
                type=jtype,
                parent=i - 1,
                link_name=f"link{j}",
                dh=dh,
                extras=tuple(sorted(extras)),
                inertial=inertial,
                limits=limits,
                max_velocity=max_velocity,
                max_acceleration=max_acceleration,
                max_effort=max_effort,
            )
        )
    transmission = None
    if doc.get("transmission") is not None:  # motors, gears, coupling: describe/transmission.py
        from minparam_cli.describe.transmission import parse_transmission

        transmission = parse_transmission(doc["transmission"], tuple(j.type for j in joints), au, float(scale), src)
    gains = None
    if doc.get("drive_gains") is not None:  # joint-side drive gains, tau_j = k_j i_j: describe/transmission.py
        from minparam_cli.describe.transmission import parse_joint_gains

        gains = parse_joint_gains(doc["drive_gains"], len(joints), src, "drive_gains")
    return RobotDescription(
        transmission=transmission,
        drive_gains=gains,
        name=name,
        source=src,
        convention=convention,
        joints=tuple(joints),
        gravity=gravity,
        gravity_source="file" if "gravity" in doc else "default",
        units={"length": lu, "angle": au},
        tool=tool,
    )


def _positive(v: Any, unit: float, src: str, where: str) -> float | None:
    """An optional positive limit (velocity, acceleration, effort), times ``unit``; None when absent."""
    if v is None:
        return None
    x = _number(v, src, where)
    if not x > 0:
        raise DescriptionError(f"expected a positive limit, got {short_repr(v)}", src, where)
    return x * unit


def _number(v: Any, src: str, where: str) -> float:
    return finite_number(v, src, where)


def _text(v: Any, src: str, where: str) -> str | None:
    """A name: text (or a number written as one); None when absent."""
    if v is None or v == "":
        return None
    if isinstance(v, bool) or not isinstance(v, (str, int, float)):
        raise DescriptionError(f"expected a name, got {short_repr(v)}", src, where)
    text = str(v)
    if len(text) > 200:
        raise DescriptionError(f"a name of {len(text)} characters (at most 200)", src, where)
    return text


def _vector(v: Any, src: str, where: str, n: int = 3) -> tuple[float, ...]:
    if not isinstance(v, (list, tuple)) or len(v) != n:
        raise DescriptionError(f"expected a list of {n} numbers, got {short_repr(v)}", src, where)
    return tuple(_number(x, src, where) for x in v)


def _vector3(v: Any, src: str, where: str) -> tuple[float, float, float]:
    x, y, z = _vector(v, src, where)
    return x, y, z


def _scaled(k: float, v: tuple[float, float, float]) -> tuple[float, float, float]:
    return k * v[0], k * v[1], k * v[2]


def _bool(v: Any, src: str, where: str) -> bool:
    if not isinstance(v, bool):
        raise DescriptionError(f"expected true or false, got {short_repr(v)}", src, where)
    return v


def _friction(v: Any, src: str, where: str) -> tuple[str, ...]:
    if isinstance(v, str):
        v = [s.strip() for s in v.split(",") if s.strip()]
    if not isinstance(v, list):
        raise DescriptionError(f"expected a list drawn from {list(FRICTION_KINDS)}", src, where)
    for k in v:
        if not isinstance(k, str) or k not in FRICTION_KINDS:
            raise DescriptionError(f"unknown friction kind {short_repr(k)}; expected any of {list(FRICTION_KINDS)}", src, where)
    return tuple(v)


def _geom(v: Any, key: str, j: int, is_angle: bool, scale: Fraction, au: str, src: str, where: str) -> GeomValue:
    symbol = f"{key}{j}"
    named = False
    if isinstance(v, dict):
        if set(map(str, v)) - {"symbol", "value"} or "value" not in v:
            raise DescriptionError("expected {symbol: NAME, value: NUMBER}", src, where)
        if "symbol" in v:
            symbol = str(v["symbol"]) if isinstance(v["symbol"], str) else ""
            if len(symbol) > 64 or not re.match(r"^[A-Za-z_][A-Za-z0-9_]*$", symbol):
                raise DescriptionError(f"symbol {short_repr(v['symbol'])} is not a valid identifier (at most 64 characters)", src, where)
            named = True
        v = v["value"]
    if is_angle:
        rad, deg = parse_angle(v, au, src, where)
        return GeomValue(rad, symbol, True, deg, named)
    x = _number(v, src, where)
    exact = Fraction(repr(x)) * scale
    return GeomValue(float(exact), symbol, False, exact, named)


def _inertial(v: Any, scale: Fraction, src: str, where: str) -> Inertial | None:
    if v is None:
        return None
    if not isinstance(v, dict):
        raise DescriptionError("expected {mass, com, inertia}", src, where)
    for key in ("mass", "com", "inertia"):
        if key not in v:
            raise DescriptionError(f"missing required field '{key}'", src, where)
    mass = _number(v["mass"], src, f"{where}.mass")
    if mass < 0:
        raise DescriptionError(f"mass must be non-negative, got {mass}", src, f"{where}.mass")
    com = _scaled(float(scale), _vector3(v["com"], src, f"{where}.com"))
    ixx, ixy, ixz, iyy, iyz, izz = _vector(v["inertia"], src, f"{where}.inertia", n=6)
    inertia = (ixx, ixy, ixz, iyy, iyz, izz)
    # inertia is given in kg*m^2 regardless of the length unit (documented)
    return Inertial(mass, com, inertia)
