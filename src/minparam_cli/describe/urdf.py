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
"""

from __future__ import annotations

import math
import re
from dataclasses import replace
from fractions import Fraction
from pathlib import Path

import numpy as np

from minparam_cli.describe.records import GeomValue, Inertial, JointRecord, RobotDescription
from minparam_cli.describe.safety import MAX_ABS_VALUE, MAX_JOINTS, MAX_NUMBER_CHARS, bounded, parse_xml_safely, read_bounded, short_repr
from minparam_cli.errors import DescriptionError, UnsupportedError

ACTUATED = {"revolute": "revolute", "continuous": "revolute", "prismatic": "prismatic"}
KNOWN_TYPES = set(ACTUATED) | {"fixed", "floating", "planar"}
INERTIA_KEYS = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
# what to do with <mimic> joints: move with their master, or freeze them at their offset
MIMIC_MODES = ("coupled", "fixed")


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
    links, joints = _read_elements(root, src)
    changes = _snap_joint_angles(joints, snap_angles) if snap_angles is not None else ()
    masters = _mimic_masters(joints, src)
    if mimic == "fixed":
        for j in joints:
            if j["mimic"] is not None and j["type"] != "fixed":  # a <mimic> on a fixed joint moves nothing
                j["frozen"] = _motion_matrix(j["type"], j["axis"], float(j["mimic"][2]))
                j["type"] = "fixed"
    desc = _build(name, src, links, joints, floating_base)
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
        for i, (key, text) in enumerate(zip(("roll", "pitch", "yaw"), j["rpy"])):
            hit = snapped_angle(float(text), tol)
            if hit is None:
                continue
            j["rpy"][i] = repr(hit[0])
            j["rpy_deg"][i] = Fraction(hit[1])
            changes.append(adjustment(f"joint[{j['name']}]/origin@rpy {key}", float(text), hit[0], hit[1]))
    return tuple(changes)


def _floats(text: str | None, n: int, src: str, where: str, default: str | None = None, bound: bool = True) -> list[str]:
    if text is None:
        if default is None:
            raise DescriptionError("missing required attribute", src, where)
        text = default
    parts = text.split()
    if len(parts) != n:
        raise DescriptionError(f"expected {n} numbers, got {short_repr(text)}", src, where)
    for p in parts:
        if len(p) > MAX_NUMBER_CHARS:
            raise DescriptionError(f"a number written with {len(p)} characters (at most {MAX_NUMBER_CHARS})", src, where)
        try:
            x = float(p)
        except ValueError:
            raise DescriptionError(f"expected a number, got {p!r}", src, where) from None
        if not math.isfinite(x):
            raise DescriptionError(f"expected a finite number, got {p!r}", src, where)
        if bound:
            bounded(x, src, where)
    return parts


def _number_attr(el, attr: str, src: str, where: str, bound: bool = True) -> float:
    v = el.get(attr)
    if v is None:
        raise DescriptionError(f"missing required attribute '{attr}'", src, where)
    return float(_floats(v, 1, src, f"{where}@{attr}", bound=bound)[0])


def _read_elements(root, src: str):
    links: dict[str, dict] = {}
    for el in root.findall("link"):
        name = el.get("name")
        if not name:
            raise DescriptionError("a <link> has no name", src, "link")
        if name in links:
            raise DescriptionError(f"link '{name}' is defined twice", src, f"link[{name}]")
        links[name] = {"inertial": _read_inertial(el.find("inertial"), src, f"link[{name}]/inertial")}
    joints = []
    names = set()
    for el in root.findall("joint"):
        name = el.get("name")
        if not name:
            raise DescriptionError("a <joint> has no name", src, "joint")
        where = f"joint[{name}]"
        if name in names:
            raise DescriptionError(f"joint '{name}' is defined twice", src, where)
        names.add(name)
        jtype = el.get("type")
        if jtype is None:
            raise DescriptionError("missing required attribute 'type'", src, where)
        if jtype not in KNOWN_TYPES:
            raise DescriptionError(f"unknown joint type {short_repr(jtype)}", src, where)
        if jtype == "planar":
            raise UnsupportedError("planar joints are not supported yet", src, where)
        mimic = None
        mimic_el = el.find("mimic")
        if mimic_el is not None:
            master = (mimic_el.get("joint") or "").strip()
            if not master:
                raise DescriptionError("missing required attribute 'joint'", src, f"{where}/mimic")
            # URDF specification: multiplier 1 and offset 0 when absent
            mult = _floats(mimic_el.get("multiplier"), 1, src, f"{where}/mimic@multiplier", "1")[0]
            off = _floats(mimic_el.get("offset"), 1, src, f"{where}/mimic@offset", "0")[0]
            mimic = (master, mult, off)
        parent, child = el.find("parent"), el.find("child")
        if parent is None or not parent.get("link"):
            raise DescriptionError("missing <parent link=...>", src, where)
        if child is None or not child.get("link"):
            raise DescriptionError("missing <child link=...>", src, where)
        origin = el.find("origin")
        xyz = _floats(origin.get("xyz") if origin is not None else None, 3, src, f"{where}/origin@xyz", "0 0 0")
        rpy = _floats(origin.get("rpy") if origin is not None else None, 3, src, f"{where}/origin@rpy", "0 0 0")
        axis_el = el.find("axis")
        # URDF specification: the default axis is (1, 0, 0)
        axis = [float(x) for x in _floats(axis_el.get("xyz") if axis_el is not None else None, 3, src, f"{where}/axis@xyz", "1 0 0")]
        if jtype != "fixed" and np.linalg.norm(axis) == 0:
            raise DescriptionError("joint axis is the zero vector", src, f"{where}/axis")
        if jtype != "fixed" and np.linalg.norm(axis) < 1e-6:
            raise DescriptionError(f"joint axis {' '.join(axis_el.get('xyz').split())} is too short to give a direction (length below 1e-6)", src, f"{where}/axis")
        limits = None
        lim = el.find("limit")
        if jtype in ("revolute", "prismatic") and lim is not None and lim.get("lower") is not None and lim.get("upper") is not None:
            # finite but huge limits (-1e16 .. 1e16) are a common way of writing "no limit"
            lo = _number_attr(lim, "lower", src, f"{where}/limit", bound=False)
            hi = _number_attr(lim, "upper", src, f"{where}/limit", bound=False)
            if lo < hi and max(abs(lo), abs(hi)) <= MAX_ABS_VALUE:
                limits = (lo, hi)
        # <limit velocity= effort=>: positive values are limits; 0 or below (placeholders seen in real
        # files, which derive does not need), absent or huge: no limit
        rates = {"velocity": None, "effort": None}
        if jtype in ("revolute", "prismatic", "continuous") and lim is not None:
            for key in rates:
                if lim.get(key) is not None:
                    x = _number_attr(lim, key, src, f"{where}/limit", bound=False)
                    if 0 < x <= MAX_ABS_VALUE:
                        rates[key] = x
        joints.append(
            dict(
                name=name, type=jtype, parent=parent.get("link"), child=child.get("link"),
                xyz=xyz, rpy=list(rpy), rpy_deg=[None] * 3, axis=axis, limits=limits, mimic=mimic, frozen=None,
                max_velocity=rates["velocity"], max_effort=rates["effort"],
            )
        )
    for j in joints:
        for role in ("parent", "child"):
            if j[role] not in links:
                raise DescriptionError(f"{role} link '{j[role]}' is not defined", src, f"joint[{j['name']}]")
    return links, joints


def _read_inertial(el, src: str, where: str):
    """(mass, xyz, rpy, inertia6) from <inertial>, checking every value is present."""
    if el is None:
        return None
    mass_el = el.find("mass")
    if mass_el is None:
        raise DescriptionError("missing <mass>", src, where)
    mass = _number_attr(mass_el, "value", src, f"{where}/mass")
    if mass < 0:
        raise DescriptionError(f"negative mass {mass}", src, f"{where}/mass")
    inertia_el = el.find("inertia")
    if inertia_el is None:
        raise DescriptionError("missing <inertia>", src, where)
    inertia = [_number_attr(inertia_el, k, src, f"{where}/inertia") for k in INERTIA_KEYS]
    origin = el.find("origin")
    xyz = [float(x) for x in _floats(origin.get("xyz") if origin is not None else None, 3, src, f"{where}/origin@xyz", "0 0 0")]
    rpy = [float(x) for x in _floats(origin.get("rpy") if origin is not None else None, 3, src, f"{where}/origin@rpy", "0 0 0")]
    return mass, xyz, rpy, inertia


def _rpy_matrix(rpy) -> np.ndarray:
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    Rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    Ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    Rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    return Rz @ Ry @ Rx


def _origin_matrix(xyz, rpy) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = _rpy_matrix([float(x) for x in rpy])
    T[:3, 3] = [float(x) for x in xyz]
    return T


def _standard_in_body(inertial, X: np.ndarray) -> np.ndarray:
    """Standard params (about the body frame origin, body axes) of a link whose frame is X in the body."""
    mass, xyz, rpy, (ixx, ixy, ixz, iyy, iyz, izz) = inertial
    Ic = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    Rl = X[:3, :3] @ _rpy_matrix(rpy)
    c = X[:3, :3] @ np.asarray(xyz) + X[:3, 3]
    Io = Rl @ Ic @ Rl.T + mass * (c @ c * np.eye(3) - np.outer(c, c))
    return np.concatenate([[Io[0, 0], Io[0, 1], Io[0, 2], Io[1, 1], Io[1, 2], Io[2, 2]], mass * c, [mass]])


def _to_inertial(phi: np.ndarray) -> Inertial:
    m = phi[9]
    c = phi[6:9] / m if m > 0 else np.zeros(3)
    Io = np.array([[phi[0], phi[1], phi[2]], [phi[1], phi[3], phi[4]], [phi[2], phi[4], phi[5]]])
    Ic = Io - m * (c @ c * np.eye(3) - np.outer(c, c))
    return Inertial(float(m), tuple(float(x) for x in c), (Ic[0, 0], Ic[0, 1], Ic[0, 2], Ic[1, 1], Ic[1, 2], Ic[2, 2]))


def _symbol_base(name: str) -> str:
    s = re.sub(r"\W", "_", name)
    s = re.sub(r"_joint$", "", s)
    return s if re.match(r"^[A-Za-z_]", s) else f"j_{s}"


def _joint_record(j: dict, body_parent: np.ndarray, parent: int) -> dict:
    """Record of actuated joint j hanging on body ``parent`` through the fixed transform ``body_parent``."""
    base = _symbol_base(j["name"])
    origin = {}
    for k, s in zip(("x", "y", "z"), j["xyz"]):
        origin[k] = GeomValue(float(s), f"{base}_{k}", False, Fraction(s))
    for k, s, deg in zip(("roll", "pitch", "yaw"), j["rpy"], j["rpy_deg"]):
        v = float(s)
        origin[k] = GeomValue(v, f"{base}_{k}", True, Fraction(0) if v == 0 else deg)
    axis = np.asarray(j["axis"], dtype=float)
    return dict(
        name=j["name"],
        type=ACTUATED[j["type"]],
        parent=parent,
        link_name=j["child"],
        origin=origin,
        pre_fixed=None if np.array_equal(body_parent, np.eye(4)) else tuple(tuple(float(v) for v in r) for r in body_parent),
        axis=tuple(float(v) for v in axis / np.linalg.norm(axis)),
        limits=j["limits"],
        max_velocity=j.get("max_velocity"),
        max_effort=j.get("max_effort"),
    )


VIRTUAL = (("x", "prismatic", (1.0, 0.0, 0.0)), ("y", "prismatic", (0.0, 1.0, 0.0)), ("z", "prismatic", (0.0, 0.0, 1.0)),
           ("rx", "revolute", (1.0, 0.0, 0.0)), ("ry", "revolute", (0.0, 1.0, 0.0)), ("rz", "revolute", (0.0, 0.0, 1.0)))


def _free_link(src: str, root: str, joints: list[dict], children: dict, floating_base: bool):
    """(free link, its floating joint or None) of a floating base, or (None, None) for a fixed base."""
    floating = [j for j in joints if j["type"] == "floating"]
    if len(floating) > 1:
        raise UnsupportedError(f"{len(floating)} floating joints: only one, from the root link, is supported", src, f"joint[{floating[1]['name']}]")
    if not floating:
        return (root, None) if floating_base else (None, None)
    fj = floating[0]
    if fj["parent"] != root:
        raise UnsupportedError(f"a floating joint inside the tree (parent '{fj['parent']}', not the root link '{root}') is not supported yet", src, f"joint[{fj['name']}]")
    others = [j["name"] for j in children[root] if j is not fj]
    if others:
        raise UnsupportedError(f"the root link '{root}' has a floating joint and other joints {others[:3]}: not supported", src, f"joint[{fj['name']}]")
    return fj["child"], fj


def _virtual_records(free: str, fj: dict | None, taken: set[str]) -> list[dict]:
    """The six virtual joints of a floating base (``VIRTUAL``), named <free link>_x ... _rz."""
    out = []
    for k, (suffix, kind, axis) in enumerate(VIRTUAL):
        name = f"{free}_{suffix}"
        while name in taken:
            name += "_"
        j = dict(name=name, type=kind, child=free if k == 5 else "", xyz=["0"] * 3, rpy=["0"] * 3, rpy_deg=[None] * 3, axis=list(axis), limits=None)
        if k == 0 and fj is not None:  # q = 0 puts the free link where the floating joint's origin does
            j.update(xyz=fj["xyz"], rpy=fj["rpy"], rpy_deg=fj["rpy_deg"])
        rec = _joint_record(j, body_parent=np.eye(4), parent=k - 1)
        rec.update(virtual=True, massless=k < 5)
        out.append(rec)
    return out


def _build(name: str, src: str, links: dict, joints: list[dict], floating_base: bool = False) -> RobotDescription:
    children: dict[str, list[dict]] = {k: [] for k in links}
    parent_of: dict[str, dict] = {}
    for j in joints:
        if j["child"] in parent_of:
            raise DescriptionError(
                f"link '{j['child']}' is the child of two joints ('{parent_of[j['child']]['name']}' and '{j['name']}'): kinematic loops are not supported",
                src,
                f"joint[{j['name']}]",
            )
        parent_of[j["child"]] = j
        children[j["parent"]].append(j)
    roots = [k for k in links if k not in parent_of]
    if not roots:
        raise DescriptionError("no root link: the joints form a loop", src)
    if len(roots) > 1:
        raise DescriptionError(f"{len(roots)} root links {roots[:4]}: expected one connected tree", src)
    free, fj = _free_link(src, roots[0], joints, children, floating_base)
    n_act = sum(j["type"] in ACTUATED for j in joints)
    if n_act == 0 and free is None:
        raise DescriptionError("no revolute, continuous or prismatic joint", src)
    if n_act > MAX_JOINTS:
        raise DescriptionError(f"{n_act} actuated joints exceed the limit of {MAX_JOINTS}", src)

    records: list[dict] = []
    body_phi: list[np.ndarray | None] = []
    attached: list[tuple[str, int, tuple[float, float, float]]] = []  # links on moving bodies
    # depth-first walk in document order; state: (link, body index or -1 for the base,
    # transform from the body frame to the link frame, actuated joint entering the link)
    stack: list[tuple] = [(roots[0], -1, np.eye(4), None)]
    visited = 0
    if free is not None:
        records = _virtual_records(free, fj, {j["name"] for j in joints})
        body_phi = [None] * 6
        stack = [(free, 5, np.eye(4), None)]
        visited = 0 if fj is None else 1  # the root link the floating joint starts from
    while stack:
        link, body, X, entering = stack.pop()
        visited += 1
        if entering is not None:
            j, Xj = entering
            body = len(records)
            records.append(_joint_record(j, body_parent=X, parent=int(Xj)))
            body_phi.append(None)
            X = np.eye(4)
        if body >= 0:
            attached.append((link, body, tuple(float(v) + 0.0 for v in X[:3, 3])))
        inertial = links[link]["inertial"]
        if inertial is not None and body >= 0:
            phi = _standard_in_body(inertial, X)
            body_phi[body] = phi if body_phi[body] is None else body_phi[body] + phi
        pushed = []
        for j in children[link]:
            Xo = X @ _origin_matrix(j["xyz"], j["rpy"])
            if j["frozen"] is not None:  # a mimic joint frozen at its offset (mimic="fixed")
                Xo = Xo @ j["frozen"]
            if j["type"] == "fixed":
                pushed.append((j["child"], body, Xo, None))
            else:
                # X (not Xo): the joint's own origin stays symbolic in the record
                pushed.append((j["child"], body, X, (j, body)))
        stack.extend(reversed(pushed))
    if visited != len(links):
        raise DescriptionError("some links are not connected to the root", src)

    out = []
    for rec, phi in zip(records, body_phi):
        out.append(JointRecord(**rec, inertial=None if phi is None else _to_inertial(phi)))
    tool_link, tool = _default_tool(attached, records)
    return RobotDescription(
        tool=tool,
        tool_link=tool_link,
        tool_links=tuple(attached),
        name=name,
        source=src,
        convention="urdf",
        joints=tuple(out),
        gravity=(0.0, 0.0, -9.81),
        gravity_source="default",
        units={"length": "m", "angle": "rad"},
    )


def _default_tool(attached: list, records: list[dict]):
    """(link, point) of the default tool: of the fixed descendants of the last moving joint's link,
    the one farthest from that link's origin (a tie: the one written last); (None, None) if none."""
    if not records:
        return None, None
    last = len(records) - 1
    best = None
    for link, body, xyz in attached:
        if body != last or link == records[last]["link_name"]:
            continue
        d = float(np.linalg.norm(xyz))
        if best is None or d >= best[0] - 1e-12 * max(1.0, best[0]):
            best = (d, link, xyz)
    return (None, None) if best is None else (best[1], best[2])


def select_tool(desc: RobotDescription, link: str) -> RobotDescription:
    """The description with the tool point at the origin of ``link`` (``--tool LINK``), for a serial
    chain or a branch: if the link sits on a moving body other than the last, the description keeps
    only the joints from the root to that body (renumbered).  InputError (exit 2) naming the links
    allowed when ``link`` is not rigidly attached to a moving link."""
    from minparam_cli.errors import InputError

    allowed = {name: (body, xyz) for name, body, xyz in desc.tool_links}
    if link not in allowed:
        if desc.convention != "urdf":
            raise InputError(f"--tool {link}: {desc.source} is a {desc.convention.upper()} description without links; its tool point is its 'tool' entry")
        names = ", ".join(name for name, _, _ in desc.tool_links)
        raise InputError(f"--tool: no link {link!r} rigidly attached to a moving link in {desc.source}; allowed: {names}")
    body, xyz = allowed[link]
    path = []
    k = body
    while k >= 0:
        path.append(k)
        k = desc.joints[k].parent
    path.reverse()
    joints = desc.joints
    if path != list(range(len(joints))):
        new = {old: i for i, old in enumerate(path)}
        kept = []
        for old in path:
            jr = joints[old]
            mimic = jr.mimic
            if mimic is not None:
                if mimic[0] not in new:
                    raise InputError(f"--tool {link}: joint {jr.name!r} on its path mimics {joints[mimic[0]].name!r}, which is not on the path")
                mimic = (new[mimic[0]], mimic[1], mimic[2])
            kept.append(replace(jr, parent=new.get(jr.parent, -1), mimic=mimic))
        joints = tuple(kept)
    return replace(desc, joints=joints, tool=xyz, tool_link=link)
