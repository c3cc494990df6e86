"""URDF -> RobotDescription (no meshes).

* Parsed with lxml, after a safe pre-parse that refuses DTDs and entities;
  every element the dynamics read (links, joints, types, origins, axes,
  limits, inertials) is checked here and named in the error.  The raw
  attribute strings stay exact decimals and a missing inertial value is an
  error (yourdfpy would default ixx to 1.0).  yourdfpy is not imported: its
  import (trimesh) took 1.4 s of every URDF command and it checked nothing
  the dynamics read that this reader does not.
* revolute, continuous and prismatic joints are actuated; fixed joints are
  lumped: the child link's inertia is added to the moving body it hangs on,
  and joints further out get the fixed transform in front of their origin.
* mimic joints (``<mimic joint=... multiplier=m offset=o/>``, q = m·q_master + o) keep their
  link and move with their master (``mimic="coupled"``, the default: the record names the
  independent joint that drives it, a mimic of a mimic resolved to the first independent
  joint), or are frozen at q = o and lumped like fixed joints (``mimic="fixed"``).
* a floating base: a ``floating`` joint from the root link, or ``floating_base=True``
  (``--floating-base``) for a file whose root link is the free body, adds six virtual joints
  in front of the free link: translations along x, y, z of the root frame, then rotations
  about the moved x, y, z axes (q = 0: the floating joint's origin).  The first five virtual
  links have no mass (``JointRecord.massless``); the sixth carries the free link.  Their
  rows of the regressor are the six base-wrench equations.
* the tool point (``RobotDescription.tool``, used by ``singular``): when the last moving
  joint's link (the end of a serial chain; for a tree, the link of the last joint in the
  depth-first numbering, i.e. the end of the last branch written in the file) carries fixed
  descendant links, the tool is the origin of the one farthest from that link's origin (a tie:
  the one written last), in that link's frame; ``tool_link`` names it.  ``tool_links`` lists
  every link rigidly attached to a moving link (the moving links themselves included, origin
  0) with its body and origin, which ``--tool LINK`` chooses from (``select_tool``).
* planar joints, and floating joints inside the tree, are refused as not supported yet.
* Trees are supported: joints are numbered depth-first from the root, in
  document order, so a parent always comes before its children.

This module reads the file and applies the mimic and snapping options; ``urdf_elements`` checks
the elements, ``urdf_tree`` builds the description, ``urdf_tool`` chooses the tool point.
"""

from __future__ import annotations

import math
from dataclasses import replace
from fractions import Fraction
from pathlib import Path

import numpy as np

from minparam_cli.describe.records import MIMIC_MODES, RobotDescription
from minparam_cli.safety import parse_xml_safely, read_bounded
from minparam_cli.describe.urdf_elements import ACTUATED, read_elements
from minparam_cli.describe.urdf_tree import build_description
from minparam_cli.errors import DescriptionError


def load_urdf(path: Path, snap_angles: float | None = None, mimic: str = "coupled", floating_base: bool = False) -> RobotDescription:
    """Read a URDF; with ``snap_angles`` (rad), joint origin angles within that of a multiple of
    15° are rounded to it (fixed joints included), each change recorded in ``adjustments``.
    ``mimic``: "coupled" (mimic joints move with their master) or "fixed" (frozen at their offset).
    ``floating_base``: the root link is free (six virtual joints in front of it)."""
    if mimic not in MIMIC_MODES:
        raise ValueError(f"mimic must be one of {MIMIC_MODES}, got {mimic!r}")
    src = str(path)
    data = read_bounded(path)
    root = parse_xml_safely(data, src)
    if root.tag != "robot":
        raise DescriptionError(f"root element is <{root.tag}>, expected <robot>", src)
    name = (root.get("name") or "").strip()
    if not name:
        raise DescriptionError("the <robot> element has no name attribute (the URDF specification requires one)", src, "robot")
    if root.find("link") is None:
        raise DescriptionError("<robot> has no <link> element: the file describes no robot", src, f"robot[{name}]")
    links, joints = read_elements(root, src)
    changes = _snap_joint_angles(joints, snap_angles) if snap_angles is not None else ()
    masters = _mimic_masters(joints, src)
    if mimic == "fixed":
        for j in joints:
            if j["mimic"] is not None and j["type"] != "fixed":  # a <mimic> on a fixed joint moves nothing
                j["frozen"] = _motion_matrix(j["type"], j["axis"], float(j["mimic"][2]))
                j["type"] = "fixed"
    desc = build_description(name, src, links, joints, floating_base)
    if mimic == "coupled" and masters:
        desc = _couple(desc, masters)
    return replace(desc, adjustments=changes)


def _mimic_masters(joints: list[dict], src: str) -> dict[str, tuple[str, float, float]]:
    """{mimic joint: (independent joint, multiplier, offset)}, following mimics of mimics:
    q_a = m1 q_b + o1 and q_b = m2 q_c + o2 give q_a = m1 m2 q_c + m1 o2 + o1."""
    by_name = {j["name"]: j for j in joints}
    direct = {}
    for j in joints:
        if j["mimic"] is None or j["type"] == "fixed":
            continue  # a <mimic> on a fixed joint moves nothing
        master, mult, off = j["mimic"]
        where = f"joint[{j['name']}]/mimic"
        if master not in by_name:
            raise DescriptionError(f"mimic joint '{master}' is not defined", src, where)
        if master == j["name"]:
            raise DescriptionError("a joint cannot mimic itself", src, where)
        if by_name[master]["type"] not in ACTUATED:
            raise DescriptionError(f"mimic joint '{master}' is a {by_name[master]['type']} joint, expected a moving one", src, where)
        direct[j["name"]] = (master, float(mult), float(off))
    out = {}
    for name in direct:
        master, m, o = direct[name]
        seen = [name]
        while master in direct:
            if master in seen:
                raise DescriptionError(f"mimic joints form a loop: {' -> '.join(seen + [master])}", src, f"joint[{name}]/mimic")
            seen.append(master)
            nxt, m2, o2 = direct[master]
            master, m, o = nxt, m * m2, m * o2 + o
        out[name] = (master, m, o)
    return out


def _couple(desc: RobotDescription, masters: dict) -> RobotDescription:
    """Records of mimic joints name the independent joint that drives them (``JointRecord.mimic``)."""
    index = {jr.name: k for k, jr in enumerate(desc.joints)}
    joints = []
    for jr in desc.joints:
        if jr.name in masters:
            master, m, o = masters[jr.name]
            jr = replace(jr, mimic=(index[master], m, o))
        joints.append(jr)
    return replace(desc, joints=tuple(joints))


def _motion_matrix(jtype: str, axis, q: float) -> np.ndarray:
    """4x4 motion of a joint of type ``jtype`` about/along ``axis`` by q (a frozen mimic joint)."""
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    T = np.eye(4)
    if ACTUATED[jtype] == "revolute":
        K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
        T[:3, :3] = np.eye(3) + math.sin(q) * K + (1 - math.cos(q)) * (K @ K)
    else:
        T[:3, 3] = q * a
    return T


def _snap_joint_angles(joints: list[dict], tol: float) -> tuple[dict, ...]:
    """Round every joint origin's roll, pitch and yaw within ``tol`` of a multiple of 15° (in place)."""
    from minparam_cli.describe.snap import adjustment, snapped_angle

    changes = []
    for j in joints:
        for i, (key, text) in enumerate(zip(("roll", "pitch", "yaw"), j["rpy"], strict=True)):
            hit = snapped_angle(float(text), tol)
            if hit is None:
                continue
            j["rpy"][i] = repr(hit[0])
            j["rpy_deg"][i] = Fraction(hit[1])
            changes.append(adjustment(f"joint[{j['name']}]/origin@rpy {key}", float(text), hit[0], hit[1]))
    return tuple(changes)
