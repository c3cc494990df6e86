"""Closed-chain YAML (``kind: closed_chain``) -> RobotDescription with its ``loops`` record.

Schema (docs/methods/closed_chains.md has the full page)::

    kind: closed_chain
    name: parallelogram arm
    units: {length: m, angle: deg}
    gravity: [0, 0, -9.81]
    friction: [viscous]          # optional: columns of the actuated joints (a passive joint: its own 'friction')
    joints:                      # the spanning tree, parents first; each joint moves the link of its name
      - {name: q1, parent: base, type: revolute, origin: [0, 0, 0.5, 90, 0, 0], axis: [0, 0, 1],
         actuated: true, reference: 30, limits: [-90, 90], inertial: {mass: .., com: [..], inertia: [..]}}
    loops:                       # the cut joints that close the loops
      - {name: rod, type: connect, between: [q4, q2], at: [[0.3, 0, 0], [-0.2, 0, 0]]}

``origin``: x, y, z (length unit), roll, pitch, yaw (angle unit) of the joint frame in the parent's
link frame (URDF's order); ``axis``: the joint axis in that frame.  A cut's ``at``: the point (three
numbers) or the frame (six numbers, as ``origin``) on each of the two links (``base``: the base frame).
``reference``: the joint's value near which the mechanism is assembled (default 0).  ``massless: true``:
the link has no mass and no parameter columns (the cross of a universal joint, the intermediate links
of a ball joint written as three revolute joints).
"""

from __future__ import annotations

import math
from fractions import Fraction
from pathlib import Path
from typing import Any

from minparam_cli.describe.angles import parse_angle
from minparam_cli.describe.loops import CUT_KINDS, ClosedLoops, LoopCut, pose
from minparam_cli.describe.records import GeomValue, JointRecord, RobotDescription
from minparam_cli.describe.yaml_dh import (ANGLE_UNITS, JOINT_TYPES, LENGTH_UNITS, _bool, _friction, _inertial, _number,
                                           _positive, _text, _vector, _vector3)
from minparam_cli.errors import DescriptionError
from minparam_cli.safety import MAX_JOINTS, key_list, mapping_entry, short_repr

TOP_KEYS = {"kind", "name", "description", "units", "gravity", "friction", "rotor_inertia", "joints", "loops", "identified"}
JOINT_KEYS = {"name", "parent", "type", "origin", "axis", "actuated", "reference", "limits", "velocity", "acceleration",
              "effort", "inertial", "friction", "rotor_inertia", "massless"}
CUT_KEYS = {"name", "type", "between", "at"}
BASE = "base"


def load_closed(path: Path) -> RobotDescription | None:
    """The closed chain of a ``kind: closed_chain`` file or of a platform file with ``dynamics:``; None
    for any other file (an arm table: ``yaml_dh``)."""
    from minparam_cli.safety import read_yaml

    doc = read_yaml(path)
    if isinstance(doc, dict) and doc.get("kind") == "closed_chain":
        return closed_from_mapping(doc, str(path))
    if isinstance(doc, dict) and doc.get("kind") == "platform" and "dynamics" in doc:
        from minparam_cli.describe.platform_chain import platform_closed_chain

        return platform_closed_chain(doc, str(path))
    return None


def closed_from_mapping(doc: dict, src: str) -> RobotDescription:
    """Validate a parsed ``kind: closed_chain`` document and build the description with its loops."""
    unknown = set(doc) - TOP_KEYS
    if unknown:
        raise DescriptionError(f"unknown key(s) {key_list(unknown)}", src)
    for key in ("joints", "loops"):
        if key not in doc:
            raise DescriptionError(f"missing required field '{key}'", src)
    if "identified" in doc and not isinstance(doc["identified"], dict):  # identify --export-yaml's record, not read
        raise DescriptionError("expected a mapping (the values identify --export-yaml found)", src, "identified")
    units = doc.get("units") or {}
    if not isinstance(units, dict):
        raise DescriptionError("expected a mapping like {length: mm, angle: deg}", src, "units")
    lu, au = units.get("length", "m"), units.get("angle", "rad")
    if not isinstance(lu, str) or lu not in LENGTH_UNITS:
        raise DescriptionError(f"unknown length unit {short_repr(lu)}; expected 'm' or 'mm'", src, "units.length")
    if not isinstance(au, str) or au not in ANGLE_UNITS:
        raise DescriptionError(f"unknown angle unit {short_repr(au)}; expected 'deg' or 'rad'", src, "units.angle")
    scale = LENGTH_UNITS[lu]
    angle = math.pi / 180 if au == "deg" else 1.0
    gravity = _vector3(doc.get("gravity", [0.0, 0.0, -9.81]), src, "gravity")
    robot_friction = _friction(doc.get("friction", []), src, "friction")
    robot_rotor = _bool(doc.get("rotor_inertia", False), src, "rotor_inertia")
    items = doc["joints"]
    if not isinstance(items, list) or not items:
        raise DescriptionError("expected a non-empty list of joints", src, "joints")
    if len(items) > MAX_JOINTS:
        raise DescriptionError(f"{len(items)} joints exceed the limit of {MAX_JOINTS}", src, "joints")
    index: dict[str, int] = {}
    joints, actuated, reference = [], [], []
    for i, jd in enumerate(items):
        where = f"joints[{i + 1}]"
        mapping_entry(jd, JOINT_KEYS, src, where, "name, parent, type, origin, axis")
        for key in ("name", "parent", "type", "origin"):
            if key not in jd:
                raise DescriptionError(f"missing required field '{key}'", src, where)
        name = _text(jd["name"], src, f"{where}.name") or ""
        if name in index or name == BASE:
            raise DescriptionError(f"joint name {name!r} is used twice (or is 'base')", src, f"{where}.name")
        parent = _text(jd["parent"], src, f"{where}.parent")
        if parent != BASE and parent not in index:
            raise DescriptionError(f"parent {short_repr(parent)} is not 'base' nor a joint listed before", src, f"{where}.parent")
        jtype = jd["type"]
        if not isinstance(jtype, str) or jtype not in JOINT_TYPES:
            raise DescriptionError(f"unknown joint type {short_repr(jtype)}; expected revolute or prismatic", src, f"{where}.type")
        unit = angle if jtype == "revolute" else float(scale)
        axis = _vector3(jd.get("axis", [0, 0, 1]), src, f"{where}.axis")
        if math.hypot(*axis) < 1e-9:
            raise DescriptionError("the axis is a zero vector", src, f"{where}.axis")
        limits = None
        if jd.get("limits") is not None:
            lo, hi = _vector(jd["limits"], src, f"{where}.limits", n=2)
            if not lo < hi:
                raise DescriptionError(f"lower limit {lo} is not below upper limit {hi}", src, f"{where}.limits")
            limits = (lo * unit, hi * unit)
        extras = set(robot_friction) if _bool(jd.get("actuated", False), src, f"{where}.actuated") else set()
        if "friction" in jd:
            extras = set(_friction(jd["friction"], src, f"{where}.friction"))
        if _bool(jd.get("rotor_inertia", robot_rotor and bool(jd.get("actuated"))), src, f"{where}.rotor_inertia"):
            extras.add("rotor_inertia")
        massless = _bool(jd.get("massless", False), src, f"{where}.massless")
        if massless and jd.get("inertial") is not None:
            raise DescriptionError("a massless link has no inertial data (drop 'inertial' or 'massless')", src, where)
        if jd.get("actuated"):
            actuated.append(i)
        reference.append(_number(jd.get("reference", 0.0), src, f"{where}.reference") * unit)
        index[name] = i
        joints.append(JointRecord(
            name=name, type=jtype, parent=-1 if parent == BASE else index[parent], link_name=name,
            origin=_origin(jd["origin"], i + 1, scale, au, src, f"{where}.origin"),
            axis=axis, extras=tuple(sorted(extras)), inertial=_inertial(jd.get("inertial"), scale, src, f"{where}.inertial"),
            limits=limits, max_velocity=_positive(jd.get("velocity"), unit, src, f"{where}.velocity"),
            max_acceleration=_positive(jd.get("acceleration"), unit, src, f"{where}.acceleration"),
            max_effort=_positive(jd.get("effort"), 1.0, src, f"{where}.effort"), massless=massless))
    if not actuated:
        raise DescriptionError("no joint is actuated (mark the driven joints 'actuated: true')", src, "joints")
    cuts = _cuts(doc["loops"], index, float(scale), angle, src)
    return RobotDescription(
        name=_text(doc.get("name"), src, "name") or Path(src).stem, source=src, convention="urdf", joints=tuple(joints),
        gravity=gravity, gravity_source="file" if "gravity" in doc else "default", units={"length": lu, "angle": au},
        loops=ClosedLoops(cuts, tuple(actuated), tuple(reference), "yaml"))


def _origin(v: Any, j: int, scale: Fraction, au: str, src: str, where: str) -> dict[str, GeomValue]:
    if not isinstance(v, list) or len(v) != 6:
        raise DescriptionError(f"expected [x, y, z, roll, pitch, yaw], got {short_repr(v)}", src, where)
    out = {}
    for k, key in enumerate(("x", "y", "z")):
        exact = Fraction(repr(_number(v[k], src, where))) * scale
        out[key] = GeomValue(float(exact), f"{key}{j}", False, exact)
    for k, key in enumerate(("roll", "pitch", "yaw")):
        rad, deg = parse_angle(v[3 + k], au, src, where)
        out[key] = GeomValue(rad, f"{key}{j}", True, deg)
    return out


def _cuts(items: Any, index: dict[str, int], scale: float, angle: float, src: str) -> tuple[LoopCut, ...]:
    if not isinstance(items, list) or not items:
        raise DescriptionError("expected a non-empty list of loop-closing cuts", src, "loops")
    if len(items) > len(index):  # each loop a cut closes runs through a joint of its own: 1000 copies of one cut took minutes
        raise DescriptionError(f"{len(items)} loop-closing cuts for {len(index)} joints: at most one cut per joint", src, "loops")
    cuts: list[LoopCut] = []
    for c, cd in enumerate(items):
        where = f"loops[{c + 1}]"
        mapping_entry(cd, CUT_KEYS, src, where, "type, between, at")
        kind = cd.get("type", "connect")
        if kind not in CUT_KINDS:
            raise DescriptionError(f"unknown cut type {short_repr(kind)}; expected one of {list(CUT_KINDS)}", src, f"{where}.type")
        between = cd.get("between")
        if not isinstance(between, list) or len(between) != 2:
            raise DescriptionError(f"expected two link names, got {short_repr(between)}", src, f"{where}.between")
        bodies = []
        for name in between:
            if name != BASE and name not in index:
                raise DescriptionError(f"unknown link {short_repr(name)}; expected a joint's name or 'base'", src, f"{where}.between")
            bodies.append(-1 if name == BASE else index[name])
        if bodies[0] == bodies[1]:
            raise DescriptionError(f"the cut joins link {between[0]!r} to itself: a cut must join two different rigid bodies",
                                   src, f"{where}.between")
        at = cd.get("at")
        if not isinstance(at, list) or len(at) != 2:
            raise DescriptionError("expected 'at': a point or frame on each of the two links", src, f"{where}.at")
        frames = []
        for k, v in enumerate(at):
            w = f"{where}.at[{k + 1}]"
            if not isinstance(v, list) or len(v) not in (3, 6):
                raise DescriptionError(f"expected [x, y, z] or [x, y, z, roll, pitch, yaw], got {short_repr(v)}", src, w)
            x = [_number(e, src, w) for e in v]
            frames.append(pose([scale * e for e in x[:3]], [angle * e for e in x[3:]] if len(x) == 6 else (0.0, 0.0, 0.0)))
        name = _text(cd.get("name"), src, f"{where}.name") or f"cut{c + 1}"
        if any(cut.name == name for cut in cuts):
            raise DescriptionError(f"cut name {short_repr(name)} is used twice", src, f"{where}.name")
        cuts.append(LoopCut(name, kind, bodies[0], bodies[1], frames[0], frames[1]))
    return tuple(cuts)
