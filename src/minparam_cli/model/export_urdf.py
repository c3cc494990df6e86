"""The robot as URDF with the identified bodies and joint friction (``identify --export-urdf``).

Frames: see ``model/export_robot.py``.  What this writer decides, for a chain from a DH/MDH table
(a URDF robot keeps its own joints and limits, only its inertials and ``<dynamics>`` change):

* limits: only those the description gave.  A revolute joint without position limits is written
  ``continuous``; a ``<limit>`` element carries ``lower``/``upper`` where the table gave ``limits``
  and ``effort``/``velocity`` only where it gave them.  URDF's specification makes ``effort`` and
  ``velocity`` required on a ``<limit>`` and the ``<limit>`` required on revolute and prismatic
  joints; a strict reader (urdfdom) refuses a file that lacks them.  Rather than invent a zero
  (which ROS reads as a zero limit) or a large number, such a file says so in a comment at the
  joint: the description had no such limit.
* gravity: a URDF has none; it is written as a comment and in the side file (``export_extra``).
* ``<dynamics damping friction>``: the identified viscous and Coulomb friction of each joint that has
  either (``export_extra.joint_terms``); rotor inertia, offsets, drive gains and the other diagnosed
  effects go into the side file.
"""

from __future__ import annotations

import numpy as np

from minparam_cli.model.export_robot import comment_text, inertial_xml, link_phi, num, rpy_from_matrix, standard_in_frame, xyz


def _dynamics_attrs(terms, j: int) -> str | None:
    if terms is None or not terms.has_friction[j]:
        return None
    return f'damping="{num(terms.damping[j])}" friction="{num(terms.friction[j])}"'


# --- URDF robot: the original file, inertials and joint dynamics replaced ---------------------------


def urdf_with_inertials(data: bytes, chain, phi: np.ndarray, note: str = "", terms=None) -> str:
    """The URDF ``data`` (the robot file the chain was read from) with each moving link's <inertial>
    the identified body, the <inertial> of links lumped into it (fixed joints) removed, and each
    actuated joint's <dynamics> the identified friction (``terms``, when it has any)."""
    from lxml import etree

    parser = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False, huge_tree=False)
    root = etree.fromstring(data, parser=parser)
    links = {el.get("name"): el for el in root.findall("link")}
    joints = {el.get("name"): el for el in root.findall("joint")}
    fixed_children: dict[str, list[str]] = {}
    for j in root.findall("joint"):
        if j.get("type") == "fixed":
            fixed_children.setdefault(j.find("parent").get("link"), []).append(j.find("child").get("link"))
    for name, phi10 in zip(chain.link_names, link_phi(chain, phi), strict=True):
        el = links[name]
        _replace_child(etree, el, "inertial", inertial_xml(phi10, _indent_of(el) + "  "))
        stack = list(fixed_children.get(name, []))
        while stack:  # links carried by fixed joints: their mass is part of the identified body
            child = stack.pop()
            stack += fixed_children.get(child, [])
            old = links[child].find("inertial")
            if old is not None:
                comment = etree.Comment(comment_text(f" inertial lumped into the identified body of link '{name}' "))
                comment.tail = old.tail
                links[child].replace(old, comment)
    for j, name in enumerate(chain.joint_names):
        attrs = _dynamics_attrs(terms, j)
        if attrs is not None and name in joints:
            _replace_child(etree, joints[name], "dynamics", f"<dynamics {attrs}/>", first=False)
    # the prolog line by line (lxml writes the comments before the root on the declaration's line)
    lines = ['<?xml version="1.0" encoding="utf-8"?>']
    lines += [etree.tostring(el, encoding="unicode", with_tail=False) for el in reversed(list(root.itersiblings(preceding=True)))]
    if note:
        lines.append(f"<!-- {comment_text(note)} -->")
    lines.append(f"<!-- gravity: {xyz(chain.gravity)} m/s^2 (a URDF has none; also in the side file .extra.yaml) -->")
    lines.append(etree.tostring(root, encoding="unicode", with_tail=False))
    return "\n".join(lines) + "\n"


def _indent_of(el) -> str:
    prev = el.getprevious()
    ws = prev.tail if prev is not None else el.getparent().text
    return (ws or "\n").rsplit("\n", 1)[-1] if ws and not ws.strip() else ""


def _replace_child(etree, parent, tag: str, text: str, first: bool = True) -> None:
    """Replace ``parent``'s <tag> by ``text``, or add it (first or last child) when it has none."""
    new = etree.fromstring(text)
    old = parent.find(tag)
    inner = _indent_of(parent) + "  "
    if old is not None:
        new.tail = old.tail
        parent.replace(old, new)
        return
    if not len(parent):  # <link name="x"/>
        parent.text = "\n" + inner
        new.tail = "\n" + _indent_of(parent)
    elif first:
        new.tail = parent.text
        parent.text = "\n" + inner
    else:
        last = parent[-1]
        new.tail = last.tail
        last.tail = "\n" + inner
    parent.insert(0 if first else len(parent), new)


# --- a chain (DH/MDH table) as a new URDF ------------------------------------------------------------


def _at(values, j: int):
    return values[j] if j < len(values) else None


def _joint_limit_lines(chain, j: int) -> tuple[str, list[str]]:
    """(URDF joint type, lines of its <limit>): only the limits the description gave."""
    limits, effort, velocity = _at(chain.limits, j), _at(chain.effort_limits, j), _at(chain.velocity_limits, j)
    kind = chain.types[j] if limits is not None or chain.types[j] == "prismatic" else "continuous"
    attrs = []
    if limits is not None:
        attrs += [f'lower="{num(limits[0])}"', f'upper="{num(limits[1])}"']
    attrs += [f'{key}="{num(v)}"' for key, v in (("effort", effort), ("velocity", velocity)) if v is not None]
    lines = [f"    <limit {' '.join(attrs)}/>"] if attrs else []
    missing = [w for w, v in (("position limits", limits if kind != "continuous" else 0), ("effort limit", effort),
                              ("velocity limit", velocity)) if v is None]
    if missing:
        lines.append(f"    <!-- the description gives no {', no '.join(missing)} for this joint -->")
    return kind, lines


def urdf_from_chain(chain, phi: np.ndarray, note: str = "", terms=None) -> str:
    """A URDF of the chain: one joint per row (origin Post_parent·Pre_j, the chain's axis), its link
    frame right after the motion, with the identified bodies moved into those frames."""
    from xml.sax.saxutils import quoteattr

    lines = ['<?xml version="1.0" encoding="utf-8"?>']
    if note:
        lines.append(f"<!-- {comment_text(note)} -->")
    lines.append(f"<!-- gravity of the description: {xyz(chain.gravity)} m/s^2 (a URDF has none; also in the side file .extra.yaml) -->")
    lines.append(f"<robot name={quoteattr(chain.name)}>")
    base = "base_link"
    while base in chain.link_names:
        base += "_"
    lines.append(f"  <link name={quoteattr(base)}/>")
    phis = link_phi(chain, phi)
    slot = {j: i for i, j in enumerate(chain.layout.links_with_columns)}  # massless links have no parameters
    for j in range(chain.n):
        p = chain.parents[j]
        parent = base if p < 0 else chain.link_names[p]
        T = (np.eye(4) if p < 0 else chain.post[p]) @ chain.pre[j]
        kind, limit_lines = _joint_limit_lines(chain, j)
        lines.append(f"  <joint name={quoteattr(chain.joint_names[j])} type=\"{kind}\">")
        lines.append(f"    <parent link={quoteattr(parent)}/>")
        lines.append(f"    <child link={quoteattr(chain.link_names[j])}/>")
        lines.append(f"    <origin xyz=\"{xyz(T[:3, 3])}\" rpy=\"{xyz(rpy_from_matrix(T[:3, :3]))}\"/>")
        lines.append(f"    <axis xyz=\"{xyz(chain.axes[j])}\"/>")
        lines += limit_lines
        attrs = _dynamics_attrs(terms, j)
        if attrs is not None:
            lines.append(f"    <dynamics {attrs}/>")
        lines.append("  </joint>")
        if j in slot:
            lines.append(f"  <link name={quoteattr(chain.link_names[j])}>")
            lines.append("    " + inertial_xml(standard_in_frame(phis[slot[j]], chain.post[j]), "    "))
            lines.append("  </link>")
        else:  # a massless link (an MJCF body's joints but the last): no <inertial>, as URDF allows
            lines.append(f"  <link name={quoteattr(chain.link_names[j])}/>")
        if not np.allclose(chain.post[j], np.eye(4), rtol=0, atol=0):
            frame = f"{chain.link_names[j]}_dh"
            P = chain.post[j]
            lines.append(f"  <joint name={quoteattr(frame + '_joint')} type=\"fixed\">")
            lines.append(f"    <parent link={quoteattr(chain.link_names[j])}/>")
            lines.append(f"    <child link={quoteattr(frame)}/>")
            lines.append(f"    <origin xyz=\"{xyz(P[:3, 3])}\" rpy=\"{xyz(rpy_from_matrix(P[:3, :3]))}\"/>")
            lines.append("  </joint>")
            lines.append(f"  <link name={quoteattr(frame)}/>")
    lines.append("</robot>")
    return "\n".join(lines) + "\n"
