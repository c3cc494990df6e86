"""Robot files with identified inertials: what the URDF and MJCF writers share, and minparam's YAML.

The URDF writers are in ``model/export_urdf.py``, the MJCF writer in ``model/export_mjcf.py``, the
side file of what a format cannot express in ``model/export_extra.py``.

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
  Its ``identified`` block keeps the rest of the fit: per joint rotor inertia, Coulomb and viscous
  friction, offset and drive gear, and the other diagnosed effects (docs/yaml-schema.md).
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


def comment_text(text: str) -> str:
    """Text an XML comment may hold: no '--' (and no trailing '-')."""
    while "--" in text:
        text = text.replace("--", "- -")
    return text.rstrip("-")


def num(x: float) -> str:
    return repr(float(x)) if x != 0 else "0"


def xyz(v) -> str:
    return " ".join(num(x) for x in v)


def rpy_from_matrix(R: np.ndarray) -> tuple[float, float, float]:
    """URDF roll, pitch, yaw of R = Rz(yaw)·Ry(pitch)·Rx(roll) (at pitch ±90°: roll 0)."""
    pitch = math.atan2(-R[2, 0], math.hypot(R[0, 0], R[1, 0]))
    if math.hypot(R[0, 0], R[1, 0]) < 1e-12:
        return 0.0, pitch, math.atan2(-R[0, 1], R[1, 1])
    return math.atan2(R[2, 1], R[2, 2]), pitch, math.atan2(R[1, 0], R[0, 0])


def inertial_xml(phi10: np.ndarray, indent: str) -> str:
    m, c, Ic = body(phi10)
    i2 = indent + "  "
    inertia = " ".join(f'{k}="{num(Ic[a, b])}"' for k, (a, b) in
                       (("ixx", (0, 0)), ("ixy", (0, 1)), ("ixz", (0, 2)), ("iyy", (1, 1)), ("iyz", (1, 2)), ("izz", (2, 2))))
    return (f"<inertial>\n{i2}<mass value=\"{num(m)}\"/>\n{i2}<origin xyz=\"{xyz(c)}\" rpy=\"0 0 0\"/>\n"
            f"{i2}<inertia {inertia}/>\n{indent}</inertial>")


# --- YAML table: the document, inertials replaced ----------------------------------------------------


def check_loop_exports(chain, robot, urdf: bool, yaml_table: bool) -> None:
    """A closed chain's exports that would lose its loops or its bodies, refused in one line before the fit:
    URDF has no loop-closing joint, and a platform file keeps one body per kind of leg part."""
    from minparam_cli.errors import InputError
    from minparam_cli.loops.coupling import ClosedCoupling

    if not isinstance(chain.coupling, ClosedCoupling):
        return
    if urdf:
        raise InputError("--export-urdf: URDF has no loop-closing joints, so the closed chain's loops would be lost; "
                         "use --export-mjcf (the loops as connect equalities) or --export-yaml")
    if yaml_table and str(robot).lower().endswith((".yaml", ".yml")):
        from minparam_cli.safety import read_yaml

        if (read_yaml(robot) or {}).get("kind") == "platform":
            raise InputError("--export-yaml: a platform file holds one body per kind of leg part (cylinder, piston), "
                             "not each leg's identified body; use --export-mjcf")


def yaml_with_inertials(doc: dict, chain, phi: np.ndarray, note: str = "", terms=None) -> str:
    """The YAML document of a DH/MDH robot (or a closed chain's ``joints``) with every joint's ``inertial``
    the identified body, and the ``identified`` block of ``terms`` (``export_extra.JointTerms``) when given."""
    import copy

    import yaml

    from minparam_cli.describe.yaml_dh import LENGTH_UNITS

    out = copy.deepcopy(doc)
    unit = float(LENGTH_UNITS[(out.get("units") or {}).get("length", "m")])
    bodies = iter(link_phi(chain, phi))
    for jd in out["joints"]:
        if jd.get("massless"):  # a closed chain's massless link (no columns, no inertial)
            continue
        m, c, Ic = body(next(bodies))
        jd["inertial"] = {"mass": float(m), "com": [float(x) / unit for x in c],
                          "inertia": [float(Ic[0, 0]), float(Ic[0, 1]), float(Ic[0, 2]), float(Ic[1, 1]), float(Ic[1, 2]), float(Ic[2, 2])]}
    if terms is not None:
        out["identified"] = identified_block(terms, note)
    text = yaml.safe_dump(out, sort_keys=False, allow_unicode=True, default_flow_style=None, width=120)
    return (f"# {note}\n" if note else "") + text


def identified_block(terms, note: str = "") -> dict:
    """The ``identified`` block of an exported YAML robot: every identified term but the bodies."""
    joints = {}
    for j, name in enumerate(terms.names):
        entry = {"rotor_inertia": float(terms.armature[j]), "coulomb": float(terms.friction[j]),
                 "viscous": float(terms.damping[j])}
        if name in terms.offsets:
            entry["offset"] = float(terms.offsets[name])
        if terms.gear_source != "none":
            entry["gear"] = float(terms.gear[j])
        joints[name] = entry
    block: dict = {"source": note, "joints": joints}
    if terms.gear_source != "none":
        block["gear_source"] = terms.gear_source
    if terms.smoothing > 0:
        block["coulomb_smoothing"] = terms.smoothing
    if terms.effects:
        block["effects"] = terms.effects
    if terms.motors:
        block["coupled_motors"] = terms.motors
    return block
