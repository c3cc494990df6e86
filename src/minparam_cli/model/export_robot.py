"""Robot files with identified inertials: URDF (from a URDF or from a DH/MDH table) and minparam's YAML.

φ (``params.LINK_PARAMS`` per link) is in the chain's link frames, about their origins.  A URDF
``<inertial>`` holds the mass, the centre of mass in its link's frame (``origin xyz``, here with
rpy 0) and the inertia tensor about the centre of mass in those axes.

* URDF robot: ``describe/urdf_tree.py`` makes the frame of chain link j the frame of the URDF child link
  of actuated joint j (it resets the body transform on entering an actuated joint), so φ needs no
  change of frame.  Links hung on it by fixed joints are lumped into the same body: the identified
  body is the sum of them, so it goes on the moving link and the fixed links' ``<inertial>`` are
  removed (a comment says where their mass went); the file is otherwise unchanged.
* a chain from a DH/MDH table (``chain.py``): link j's frame is F_parent · Pre_j · Motion_j · Post_j.
  The generated URDF puts joint j at Post_parent · Pre_j (axis as in the chain, z for a table) and
  its child link frame right after the motion, so the chain's link frame sits at Post_j in the URDF
  link frame: the centre of mass and the inertia are moved there (``standard_in_frame``).  For
  standard DH that is the frame at the end of the link; for MDH, Post = I and nothing moves.  A
  massless ``<link>_dh`` link on a fixed joint marks each chain frame that differs.
* YAML: the table's own document with every joint's ``inertial`` replaced (centre of mass in the
  file's length unit, inertia in kg·m², as docs/yaml-schema.md says); its link frames are the chain's.
"""

from __future__ import annotations

import math

import numpy as np

from minparam_cli.params import N_LINK_PARAMS


def _skew(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def standard_in_frame(phi10: np.ndarray, T: np.ndarray) -> np.ndarray:
    """One link's standard parameters in frame B, given them in frame A and T, A's pose in B (p_B = T·p_A).

    m is unchanged, h_B = R h_A + m t, and I_B = R I_A Rᵀ − [t]×[R h_A]× − [R h_A]×[t]× − m [t]×²
    (the inertia about B's origin, from Σ m (|r|² 1 − r rᵀ) = −Σ m [r]×² with r_B = R r_A + t)."""
    XX, XY, XZ, YY, YZ, ZZ, MX, MY, MZ, M = (float(x) for x in phi10)
    R, t = T[:3, :3], T[:3, 3]
    I_a = np.array([[XX, XY, XZ], [XY, YY, YZ], [XZ, YZ, ZZ]])
    h = R @ np.array([MX, MY, MZ])
    S, St = _skew(h), _skew(t)
    I_b = R @ I_a @ R.T - St @ S - S @ St - M * St @ St
    h_b = h + M * t
    return np.array([I_b[0, 0], I_b[0, 1], I_b[0, 2], I_b[1, 1], I_b[1, 2], I_b[2, 2], *h_b, M])


def body(phi10: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass, centre of mass, inertia tensor about it) of one link's standard parameters, same frame."""
    from minparam_cli.dynamics.inertia import body_from_standard

    if not phi10[9] > 0:  # params.LINK_PARAMS: M last
        raise ValueError(f"a link of mass {phi10[9]} has no centre of mass")
    return body_from_standard(phi10)


def link_phi(chain, phi: np.ndarray) -> list[np.ndarray]:
    """The 10 standard parameters of every chain link (φ's inertial part, chain order)."""
    links = chain.layout.links_with_columns
    return [np.asarray(phi[N_LINK_PARAMS * i : N_LINK_PARAMS * (i + 1)], dtype=float) for i in range(len(links))]


def _comment_text(text: str) -> str:
    """Text an XML comment may hold: no '--' (and no trailing '-')."""
    while "--" in text:
        text = text.replace("--", "- -")
    return text.rstrip("-")


def _num(x: float) -> str:
    return repr(float(x)) if x != 0 else "0"


def _xyz(v) -> str:
    return " ".join(_num(x) for x in v)


def rpy_from_matrix(R: np.ndarray) -> tuple[float, float, float]:
    """URDF roll, pitch, yaw of R = Rz(yaw)·Ry(pitch)·Rx(roll) (at pitch ±90°: roll 0)."""
    pitch = math.atan2(-R[2, 0], math.hypot(R[0, 0], R[1, 0]))
    if math.hypot(R[0, 0], R[1, 0]) < 1e-12:
        return 0.0, pitch, math.atan2(-R[0, 1], R[1, 1])
    return math.atan2(R[2, 1], R[2, 2]), pitch, math.atan2(R[1, 0], R[0, 0])


def _inertial_xml(phi10: np.ndarray, indent: str) -> str:
    m, c, Ic = body(phi10)
    i2 = indent + "  "
    inertia = " ".join(f'{k}="{_num(Ic[a, b])}"' for k, (a, b) in
                       (("ixx", (0, 0)), ("ixy", (0, 1)), ("ixz", (0, 2)), ("iyy", (1, 1)), ("iyz", (1, 2)), ("izz", (2, 2))))
    return (f"<inertial>\n{i2}<mass value=\"{_num(m)}\"/>\n{i2}<origin xyz=\"{_xyz(c)}\" rpy=\"0 0 0\"/>\n"
            f"{i2}<inertia {inertia}/>\n{indent}</inertial>")


# --- URDF robot: the original file, inertials replaced ----------------------------------------------


def urdf_with_inertials(data: bytes, chain, phi: np.ndarray, note: str = "") -> str:
    """The URDF ``data`` (the robot file the chain was read from) with each moving link's <inertial>
    the identified body, and the <inertial> of links lumped into it (fixed joints) removed."""
    from lxml import etree

    parser = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False, huge_tree=False)
    root = etree.fromstring(data, parser=parser)
    links = {el.get("name"): el for el in root.findall("link")}
    fixed_children: dict[str, list[str]] = {}
    for j in root.findall("joint"):
        if j.get("type") == "fixed":
            fixed_children.setdefault(j.find("parent").get("link"), []).append(j.find("child").get("link"))
    for name, phi10 in zip(chain.link_names, link_phi(chain, phi), strict=True):
        el = links[name]
        _replace_inertial(etree, el, _inertial_xml(phi10, _indent_of(el) + "  "))
        stack = list(fixed_children.get(name, []))
        while stack:  # links carried by fixed joints: their mass is part of the identified body
            child = stack.pop()
            stack += fixed_children.get(child, [])
            old = links[child].find("inertial")
            if old is not None:
                comment = etree.Comment(_comment_text(f" inertial lumped into the identified body of link '{name}' "))
                comment.tail = old.tail
                links[child].replace(old, comment)
    # the prolog line by line (lxml writes the comments before the root on the declaration's line)
    lines = ['<?xml version="1.0" encoding="utf-8"?>']
    lines += [etree.tostring(el, encoding="unicode", with_tail=False) for el in reversed(list(root.itersiblings(preceding=True)))]
    if note:
        lines.append(f"<!-- {_comment_text(note)} -->")
    lines.append(etree.tostring(root, encoding="unicode", with_tail=False))
    return "\n".join(lines) + "\n"


def _indent_of(el) -> str:
    prev = el.getprevious()
    ws = prev.tail if prev is not None else el.getparent().text
    return (ws or "\n").rsplit("\n", 1)[-1] if ws and not ws.strip() else ""


def _replace_inertial(etree, link, text: str) -> None:
    new = etree.fromstring(text)
    old = link.find("inertial")
    inner = _indent_of(link) + "  "
    if old is not None:
        new.tail = old.tail
        link.replace(old, new)
        return
    if not len(link):  # <link name="x"/>
        link.text = "\n" + inner
        new.tail = "\n" + _indent_of(link)
    else:
        new.tail = link.text
        link.text = "\n" + inner
    link.insert(0, new)


# --- a chain (DH/MDH table) as a new URDF ------------------------------------------------------------


def urdf_from_chain(chain, phi: np.ndarray, note: str = "") -> str:
    """A URDF of the chain: one joint per row (origin Post_parent·Pre_j, the chain's axis), its link
    frame right after the motion, with the identified bodies moved into those frames."""
    from xml.sax.saxutils import quoteattr

    names = chain.layout.names
    lines = ['<?xml version="1.0" encoding="utf-8"?>']
    if note:
        lines.append(f"<!-- {_comment_text(note)} -->")
    g = chain.gravity
    lines.append(f"<!-- gravity of the description: {_xyz(g)} m/s^2 (a URDF has none) -->")
    lines.append(f"<robot name={quoteattr(chain.name)}>")
    base = "base_link"
    while base in chain.link_names:
        base += "_"
    lines.append(f"  <link name={quoteattr(base)}/>")
    phis = link_phi(chain, phi)
    for j in range(chain.n):
        p = chain.parents[j]
        parent = base if p < 0 else chain.link_names[p]
        T = (np.eye(4) if p < 0 else chain.post[p]) @ chain.pre[j]
        limits = chain.limits[j] if j < len(chain.limits) else None
        kind = chain.types[j] if limits is not None or chain.types[j] == "prismatic" else "continuous"
        lines.append(f"  <joint name={quoteattr(chain.joint_names[j])} type=\"{kind}\">")
        lines.append(f"    <parent link={quoteattr(parent)}/>")
        lines.append(f"    <child link={quoteattr(chain.link_names[j])}/>")
        lines.append(f"    <origin xyz=\"{_xyz(T[:3, 3])}\" rpy=\"{_xyz(rpy_from_matrix(T[:3, :3]))}\"/>")
        lines.append(f"    <axis xyz=\"{_xyz(chain.axes[j])}\"/>")
        if kind != "continuous":
            lo, hi = limits if limits is not None else (-1e3, 1e3)
            lines.append(f"    <limit lower=\"{_num(lo)}\" upper=\"{_num(hi)}\" effort=\"0\" velocity=\"0\"/>"
                         + ("" if limits is not None else "  <!-- no limits in the description -->"))
        k = chain.layout.numbers[j] if chain.layout.numbers is not None else j + 1
        fc = names.index(f"Fc{k}") if f"Fc{k}" in names else None
        fv = names.index(f"Fv{k}") if f"Fv{k}" in names else None
        if fc is not None or fv is not None:
            lines.append(f"    <dynamics damping=\"{_num(phi[fv]) if fv is not None else 0}\" "
                         f"friction=\"{_num(phi[fc]) if fc is not None else 0}\"/>")
        lines.append("  </joint>")
        lines.append(f"  <link name={quoteattr(chain.link_names[j])}>")
        lines.append("    " + _inertial_xml(standard_in_frame(phis[j], chain.post[j]), "    "))
        lines.append("  </link>")
        if not np.allclose(chain.post[j], np.eye(4), rtol=0, atol=0):
            frame = f"{chain.link_names[j]}_dh"
            P = chain.post[j]
            lines.append(f"  <joint name={quoteattr(frame + '_joint')} type=\"fixed\">")
            lines.append(f"    <parent link={quoteattr(chain.link_names[j])}/>")
            lines.append(f"    <child link={quoteattr(frame)}/>")
            lines.append(f"    <origin xyz=\"{_xyz(P[:3, 3])}\" rpy=\"{_xyz(rpy_from_matrix(P[:3, :3]))}\"/>")
            lines.append("  </joint>")
            lines.append(f"  <link name={quoteattr(frame)}/>")
    lines.append("</robot>")
    return "\n".join(lines) + "\n"


# --- YAML table: the document, inertials replaced ----------------------------------------------------


def yaml_with_inertials(doc: dict, chain, phi: np.ndarray, note: str = "") -> str:
    """The YAML document of a DH/MDH robot with every joint's ``inertial`` the identified body."""
    import copy

    import yaml

    from minparam_cli.describe.yaml_dh import LENGTH_UNITS

    out = copy.deepcopy(doc)
    unit = float(LENGTH_UNITS[(out.get("units") or {}).get("length", "m")])
    for jd, phi10 in zip(out["joints"], link_phi(chain, phi), strict=True):
        m, c, Ic = body(phi10)
        jd["inertial"] = {"mass": float(m), "com": [float(x) / unit for x in c],
                          "inertia": [float(Ic[0, 0]), float(Ic[0, 1]), float(Ic[0, 2]), float(Ic[1, 1]), float(Ic[1, 2]), float(Ic[2, 2])]}
    text = yaml.safe_dump(out, sort_keys=False, allow_unicode=True, default_flow_style=None, width=120)
    return (f"# {note}\n" if note else "") + text
