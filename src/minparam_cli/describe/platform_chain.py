"""A platform file with ``dynamics:`` -> the closed chain of its legs and platform (a RobotDescription
with loops), for ``minparam derive`` (docs/methods/closed_chains.md).

Schema of the section (lengths in the file's unit, masses kg, inertias kg·m²)::

    dynamics:
      home: [0, 0, 200, 0, 0, 0]    # platform pose at the reference: x, y, z, roll, pitch, yaw
      gravity: [0, 0, -9.81]         # optional
      friction: [viscous]            # optional: columns of the actuated (prismatic) leg joints
      platform: {mass: 1.5, com: [0, 0, 5], inertia: [ixx, ixy, ixz, iyy, iyz, izz]}   # platform frame
      cylinder: {mass: 0.4, com: 60, inertia: [0.002, 0.002, 0.0001]}   # each leg's lower part: com this far
      piston: {mass: 0.25, com: 50, inertia: [0.001, 0.001, 0.00005]}   #   from the base node (piston: from the
                                                                        #   platform node); principal inertias
                                                                        #   across, across, along the leg

Every leg is a UPS leg: a universal joint at its base node (two revolutes, axes across the leg as it
stands at home), the actuated prismatic joint (its value is the leg length) and a ball joint at the
platform node.  The tree carries the platform on leg 1 (its ball joint as three revolutes); the
other legs close on the platform by a ``connect`` cut at their platform node.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from minparam_cli.describe.loops import ClosedLoops, LoopCut, pose
from minparam_cli.describe.records import GeomValue, Inertial, JointRecord, RobotDescription
from minparam_cli.describe.yaml_dh import _friction, _inertial, _number, _vector, _vector3
from minparam_cli.errors import DescriptionError, UnsupportedError
from minparam_cli.safety import key_list

DYNAMICS_KEYS = {"home", "gravity", "friction", "platform", "cylinder", "piston"}
SCALE = {"mm": 1e-3, "cm": 1e-2, "m": 1.0}


def platform_closed_chain(doc: dict, src: str) -> RobotDescription:
    from minparam_cli.describe.platform_yaml import platform_from_mapping

    plat = platform_from_mapping(doc, src)
    if plat.structure != "platform":
        raise UnsupportedError("dynamics of a free truss (no platform): not supported; give 'base' and 'platform'", src)
    dyn = doc["dynamics"]
    if not isinstance(dyn, dict):
        raise DescriptionError("expected a mapping with home, platform, cylinder, piston", src, "dynamics")
    unknown = set(dyn) - DYNAMICS_KEYS
    if unknown:
        raise DescriptionError(f"unknown key(s) {key_list(unknown)}", src, "dynamics")
    for key in ("home", "platform", "cylinder", "piston"):
        if key not in dyn:
            raise DescriptionError(f"missing required field '{key}'", src, "dynamics")
    k = SCALE[plat.length_unit]
    angle = math.pi / 180 if plat.angle_unit == "deg" else 1.0
    home = _vector(dyn["home"], src, "dynamics.home", n=6)
    Hp = np.array(pose([k * x for x in home[:3]], [angle * a for a in home[3:]]))
    platform = _inertial(dyn["platform"], k, src, "dynamics.platform")  # type: ignore[arg-type]  # a float scale works
    if platform is None:
        raise DescriptionError("expected {mass, com, inertia}", src, "dynamics.platform")
    parts = [_part(dyn[key], k, src, f"dynamics.{key}") for key in ("cylinder", "piston")]
    friction = tuple(sorted(_friction(dyn.get("friction", []), src, "dynamics.friction")))
    base = {n: k * np.array(c) for n, c in zip(plat.base_names, plat.base_coords, strict=True)}
    top = {n: Hp[:3, :3] @ (k * np.array(c)) + Hp[:3, 3] for n, c in zip(plat.platform_names, plat.platform_coords, strict=True)}
    joints: list[JointRecord] = []
    reference: list[float] = []
    actuated, tips = [], []
    zero = None
    for i, leg in enumerate(plat.legs):
        B, P = base[leg.base], top[leg.platform]
        u = P - B
        length = float(np.linalg.norm(u))
        # the loops are closed from here: a home no leg can reach kept the sampler busy for minutes; a leg
        # at its stroke's end (a parked pose) is within, to rounding (1e-9 of the limit)
        slack = 0.0 if leg.limits is None else 1e-9 * max(abs(leg.limits[0]), abs(leg.limits[1]), 1.0)
        if length < 1e-9 or (leg.limits is not None and not leg.limits[0] - slack <= length / k <= leg.limits[1] + slack):
            span = "" if leg.limits is None else f", outside its limits [{leg.limits[0]:g}, {leg.limits[1]:g}]"
            raise DescriptionError(f"leg {leg.name} is {length / k:.10g} {plat.length_unit} long at the home pose{span}", src, "dynamics.home")
        theta, phi = math.acos(max(-1.0, min(1.0, u[2] / length))), math.atan2(u[1], u[0])
        first = len(joints)
        joints.append(_joint(f"{leg.name}_u1", "revolute", -1, B, (0.0, theta, phi), (1.0, 0.0, 0.0), zero))
        joints.append(_joint(f"{leg.name}_u2", "revolute", first, (0, 0, 0), (0, 0, 0), (0.0, 1.0, 0.0),
                             Inertial(parts[0][0], (0.0, 0.0, parts[0][1]), parts[0][2])))
        limits = None if leg.limits is None else (k * leg.limits[0], k * leg.limits[1])
        joints.append(_joint(leg.name, "prismatic", first + 1, (0, 0, 0), (0, 0, 0), (0.0, 0.0, 1.0),
                             Inertial(parts[1][0], (0.0, 0.0, -parts[1][1]), parts[1][2]), friction, limits))
        reference += [0.0, 0.0, length]
        actuated.append(first + 2)
        tips.append((first + 2, leg.platform))
        if i == 0:  # the ball joint that carries the platform
            for name, axis in (("s1", (1.0, 0.0, 0.0)), ("s2", (0.0, 1.0, 0.0)), ("s3", (0.0, 0.0, 1.0))):
                joints.append(_joint(f"{leg.name}_{name}", "revolute", len(joints) - 1, (0, 0, 0), (0, 0, 0), axis,
                                     zero if name != "s3" else platform))
                reference.append(0.0)
            R1 = np.array(pose((0, 0, 0), (0.0, theta, phi)))[:3, :3]  # the platform link's frame at home: leg 1's
            carrier, origin1 = len(joints) - 1, P
    # the platform's inertial data in the carrying link's frame
    Rl = R1.T @ Hp[:3, :3]
    com = R1.T @ (Hp[:3, :3] @ np.array(platform.com) + Hp[:3, 3] - origin1)
    ixx, ixy, ixz, iyy, iyz, izz = platform.inertia
    Ic = Rl @ np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]]) @ Rl.T
    inert = Inertial(platform.mass, (com[0], com[1], com[2]), (Ic[0, 0], Ic[0, 1], Ic[0, 2], Ic[1, 1], Ic[1, 2], Ic[2, 2]))
    from dataclasses import replace

    joints[carrier] = replace(joints[carrier], inertial=inert)
    cuts = tuple(LoopCut(f"{plat.legs[i].name}_ball", "connect", body, carrier, pose(),
                         pose(tuple(R1.T @ (top[node] - origin1))))
                 for i, (body, node) in enumerate(tips) if i > 0)
    gravity = _vector3(dyn.get("gravity", [0.0, 0.0, -9.81]), src, "dynamics.gravity")
    return RobotDescription(name=plat.name, source=src, convention="urdf", joints=tuple(joints), gravity=gravity,
                            gravity_source="file" if "gravity" in dyn else "default", units={"length": "m", "angle": "rad"},
                            loops=ClosedLoops(cuts, tuple(actuated), tuple(reference), "platform"))


def _part(v: Any, k: float, src: str, where: str) -> tuple[float, float, tuple[float, float, float, float, float, float]]:
    if not isinstance(v, dict) or set(v) != {"mass", "com", "inertia"}:
        raise DescriptionError("expected {mass, com, inertia: [across, across, along]}", src, where)
    mass = _number(v["mass"], src, f"{where}.mass")
    if mass < 0:
        raise DescriptionError(f"mass must be non-negative, got {mass}", src, f"{where}.mass")
    a, b, c = _vector(v["inertia"], src, f"{where}.inertia")
    return mass, k * _number(v["com"], src, f"{where}.com"), (a, 0.0, 0.0, b, 0.0, c)


def _joint(name, kind, parent, xyz, rpy, axis, inertial, extras=(), limits=None) -> JointRecord:
    """A joint of the tree; ``inertial`` None: a massless link (a universal or ball joint's cross) without columns."""
    origin = {key: GeomValue(float(v), f"{key}_{name}") for key, v in zip(("x", "y", "z"), xyz, strict=True)}
    origin.update({key: GeomValue(float(v), f"{key}_{name}", True) for key, v in zip(("roll", "pitch", "yaw"), rpy, strict=True)})
    return JointRecord(name=name, type=kind, parent=parent, link_name=name, origin=origin, axis=axis, extras=tuple(extras),
                       inertial=inertial, limits=limits, massless=inertial is None)
