"""The URDF tree -> RobotDescription: a depth-first walk from the root link numbers the moving
joints, lumps fixed joints' links into the moving body they hang on, and puts six virtual joints
in front of a floating base (``describe/urdf.py`` gives the reader's rules)."""

from __future__ import annotations

import math
import re
from fractions import Fraction

import numpy as np

from minparam_cli.describe.records import GeomValue, Inertial, JointRecord, RobotDescription
from minparam_cli.safety import MAX_JOINTS
from minparam_cli.describe.urdf_elements import ACTUATED
from minparam_cli.describe.urdf_tool import default_tool
from minparam_cli.describe.urdf_geometry import merged_box, moved_box
from minparam_cli.errors import DescriptionError, UnsupportedError


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
    return Inertial(float(m), (float(c[0]), float(c[1]), float(c[2])), (Ic[0, 0], Ic[0, 1], Ic[0, 2], Ic[1, 1], Ic[1, 2], Ic[2, 2]))


def _symbol_base(name: str) -> str:
    s = re.sub(r"\W", "_", name)
    s = re.sub(r"_joint$", "", s)
    return s if re.match(r"^[A-Za-z_]", s) else f"j_{s}"


def _joint_record(j: dict, body_parent: np.ndarray, parent: int) -> dict:
    """Record of actuated joint j hanging on body ``parent`` through the fixed transform ``body_parent``."""
    base = _symbol_base(j["name"])
    origin = {}
    for k, s in zip(("x", "y", "z"), j["xyz"], strict=True):
        origin[k] = GeomValue(float(s), f"{base}_{k}", False, Fraction(s))
    for k, s, deg in zip(("roll", "pitch", "yaw"), j["rpy"], j["rpy_deg"], strict=True):
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


def build_description(name: str, src: str, links: dict, joints: list[dict], floating_base: bool = False) -> RobotDescription:
    """The description of the tree read by ``urdf_elements.read_elements``."""
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
    body_box: list = []  # per body: the box its links' shapes fill (urdf_geometry.py), or None
    attached: list[tuple[str, int, tuple[float, float, float]]] = []  # links on moving bodies
    # depth-first walk in document order; state: (link, body index or -1 for the base,
    # transform from the body frame to the link frame, actuated joint entering the link)
    stack: list[tuple] = [(roots[0], -1, np.eye(4), None)]
    visited = 0
    if free is not None:
        records = _virtual_records(free, fj, {j["name"] for j in joints})
        body_phi = [None] * 6
        body_box = [None] * 6
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
            body_box.append(None)
            X = np.eye(4)
        if body >= 0:
            attached.append((link, body, (float(X[0, 3]) + 0.0, float(X[1, 3]) + 0.0, float(X[2, 3]) + 0.0)))
        inertial = links[link]["inertial"]
        if inertial is not None and body >= 0:
            phi = _standard_in_body(inertial, X)
            body_phi[body] = phi if body_phi[body] is None else body_phi[body] + phi
        if links[link].get("box") is not None and body >= 0:
            body_box[body] = merged_box(body_box[body], moved_box(links[link]["box"], X))
        pushed: list[tuple] = []
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
    for rec, body_sum, box in zip(records, body_phi, body_box, strict=True):
        out.append(JointRecord(**rec, inertial=None if body_sum is None else _to_inertial(body_sum), geometry=box))
    tool_link, tool = default_tool(attached, records)
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
