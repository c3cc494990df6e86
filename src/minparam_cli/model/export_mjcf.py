"""The robot as a MuJoCo MJCF model with the identified bodies (``identify --export-mjcf``).

Written from the chain, so DH/MDH tables and URDF robots alike (mujoco is not needed to write it).
Body j sits at Post_parent · Pre_j in its parent body (the frames of ``model/export_robot.py``'s
URDF from a chain), its joint at the body origin along the chain's axis, so the body frame is the
frame right after the motion and the chain's link frame is Post_j in it (a ``<site name="…_dh">``
marks it where it differs); the identified body is moved there (``standard_in_frame``) and written
as ``<inertial pos mass fullinertia>`` (about the centre of mass, MuJoCo's order Ixx Iyy Izz Ixy Ixz Iyz).

Joints: ``armature`` = rotor inertia, ``damping`` = viscous friction, ``frictionloss`` = Coulomb
friction (``export_extra.joint_terms``); ``range`` only where the description gave limits.
``<option gravity>`` is the description's gravity; one ``<motor>`` per joint with the drive gear.

A closed chain (``loops/coupling.py``) is written as its spanning tree plus its loops: every point
pair of a cut (``loops/model.py``: a ball joint one pair, a hinge two, a weld three) becomes a
``<connect site1 site2>`` equality between two sites placed at the pair's points, so MuJoCo enforces
the constraints minparam's model uses (the repeated equations of a hinge or weld are redundant rows,
which MuJoCo's soft constraints accept); only the actuated joints get a ``<motor>``.  The bodies are
written at the assembled reference configuration with each joint's ``ref`` its reference value, so
qpos0 is the assembled mechanism and qpos keeps minparam's joint values.  A massless link (a universal joint's cross,
no parameter columns) is written with a token body of 1e-9 kg (MuJoCo refuses moving bodies without
mass).
In MuJoCo, armature and damping are part of the inverse dynamics (``mj_inverse``: M with armature,
minus the passive damping force); frictionloss is a constraint force, found by MuJoCo's soft
constraint solver, which equals Fc·sign(q̇) only when it saturates (docs/simulation.md).
"""

from __future__ import annotations

import math

import numpy as np

from minparam_cli.chain import motion
from minparam_cli.errors import InputError
from minparam_cli.model.export_robot import body, comment_text, link_phi, num, standard_in_frame, xyz


# a massless link (no parameter columns) is written with this token body: MuJoCo refuses a moving body
# whose mass or inertia is below mjMINVAL (1e-15); its effect on the torques is ~1e-9 of a kilogram's
TOKEN_MASS, TOKEN_INERTIA = 1e-9, 1e-12


def quaternion(R: np.ndarray) -> np.ndarray:
    """Unit quaternion (w, x, y, z) of a rotation matrix (largest-component branch; w ≥ 0)."""
    t = np.trace(R)
    if t > 0:
        s = 2.0 * math.sqrt(1.0 + t)
        qv = np.array([0.25 * s, (R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s])
    else:
        i = int(np.argmax(np.diag(R)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2.0 * math.sqrt(max(1.0 + R[i, i] - R[j, j] - R[k, k], 0.0))
        qv = np.zeros(4)
        qv[0] = (R[k, j] - R[j, k]) / s
        qv[1 + i] = 0.25 * s
        qv[1 + j] = (R[j, i] + R[i, j]) / s
        qv[1 + k] = (R[k, i] + R[i, k]) / s
    qv = qv / np.linalg.norm(qv)
    return -qv if qv[0] < 0 else qv


def _pose(T: np.ndarray) -> str:
    return f'pos="{xyz(T[:3, 3])}" quat="{xyz(quaternion(T[:3, :3]))}"'


def _inertial(phi10: np.ndarray) -> str:
    m, c, Ic = body(phi10)
    full = (Ic[0, 0], Ic[1, 1], Ic[2, 2], Ic[0, 1], Ic[0, 2], Ic[1, 2])
    return f'<inertial pos="{xyz(c)}" mass="{num(m)}" fullinertia="{xyz(full)}"/>'


def _closed(chain):
    """The ``ClosedModel`` of a closed chain (its coupling), else None."""
    from minparam_cli.loops.coupling import ClosedCoupling

    return chain.coupling.model if isinstance(chain.coupling, ClosedCoupling) else None


def _loop_sites(model) -> tuple[dict[int, list[str]], list[str]]:
    """Per body (-1: the world) the ``<site>`` elements of the cuts' points, and the ``<connect>`` lines."""
    from xml.sax.saxutils import quoteattr

    chain = model.chain
    sites: dict[int, list[str]] = {}
    connects = []
    count = {c: model.cut_of_pair.count(c) for c in model.cut_of_pair}
    seen: dict[str, int] = {}
    for i, cut in enumerate(model.cut_of_pair):
        k = seen[cut] = seen.get(cut, 0) + 1
        name = f"cut_{cut}" if count[cut] == 1 else f"cut_{cut}_{k}"
        for side, owner, point in (("a", model.body_a[i], model.point_a[i]), ("b", model.body_b[i], model.point_b[i])):
            b = int(owner)
            pos = point if b < 0 else chain.post[b][:3, :3] @ point + chain.post[b][:3, 3]  # link frame -> body frame
            sites.setdefault(b, []).append(f'<site name={quoteattr(f"{name}_{side}")} pos="{xyz(pos)}"/>')
        connects.append(f'    <connect name={quoteattr(name)} site1={quoteattr(name + "_a")} site2={quoteattr(name + "_b")}/>')
    return sites, connects


def check_mjcf_chain(chain) -> None:
    """Chains the MJCF writer cannot write, refused in one line."""
    if chain.coupling is not None and _closed(chain) is None:
        raise InputError("--export-mjcf: the robot has coupled mimic joints, which the MJCF export does not write "
                         "(MuJoCo would need equality constraints); use --mimic fixed")
    if chain.floating_base:
        raise InputError("--export-mjcf: a floating-base robot is not exported")


def mjcf_from_chain(chain, phi: np.ndarray, terms, note: str = "") -> str:
    """The MJCF document of the chain with the identified bodies ``phi`` (full parameters, chain.layout
    order) and the joint terms ``terms`` (``export_extra.JointTerms``)."""
    from xml.sax.saxutils import quoteattr

    check_mjcf_chain(chain)
    closed = _closed(chain)
    loop_sites, connects = _loop_sites(closed) if closed is not None else ({}, [])
    ref = np.zeros(chain.n) if closed is None else np.asarray(closed.reference, dtype=float)
    phis = link_phi(chain, phi)
    slot = {j: i for i, j in enumerate(chain.layout.links_with_columns)}
    lines = [f"<mujoco model={quoteattr(chain.name)}>"]
    if note:
        lines.append(f"  <!-- {comment_text(note)} -->")
    lines.append('  <compiler angle="radian" autolimits="true" inertiafromgeom="false" balanceinertia="false"/>')
    lines.append(f'  <option gravity="{xyz(chain.gravity)}"/>')
    lines.append("  <worldbody>")
    lines.extend(f"    {site}" for site in loop_sites.get(-1, []))

    def emit(j: int, depth: int) -> None:
        pad = "  " * depth
        p = chain.parents[j]
        T = (np.eye(4) if p < 0 else chain.post[p]) @ chain.pre[j] @ motion(chain.types[j], np.asarray(chain.axes[j], dtype=float), ref[j:j + 1])[0]
        lines.append(f"{pad}<body name={quoteattr(chain.link_names[j])} {_pose(T)}>")
        kind = "hinge" if chain.types[j] == "revolute" else "slide"
        attrs = [f"name={quoteattr(chain.joint_names[j])}", f'type="{kind}"', 'pos="0 0 0"', f'axis="{xyz(chain.axes[j])}"',
                 f'armature="{num(terms.armature[j])}"', f'damping="{num(terms.damping[j])}"',
                 f'frictionloss="{num(terms.friction[j])}"']
        if ref[j] != 0.0:
            attrs.append(f'ref="{num(ref[j])}"')
        limits = chain.limits[j] if j < len(chain.limits) else None
        if limits is not None:
            attrs.append(f'range="{num(limits[0])} {num(limits[1])}"')
        lines.append(f"{pad}  <joint {' '.join(attrs)}/>")
        lines.extend(f"{pad}  {site}" for site in loop_sites.get(j, []))
        if j in slot:
            lines.append(f"{pad}  {_inertial(standard_in_frame(phis[slot[j]], chain.post[j]))}")
        else:  # a massless link (a universal joint's cross): MuJoCo refuses moving bodies without mass
            lines.append(f"{pad}  <!-- massless link (no parameters identified): a token body, not data; MuJoCo refuses "
                         "moving bodies without mass -->")
            lines.append(f'{pad}  <inertial pos="0 0 0" mass="{num(TOKEN_MASS)}" diaginertia="{xyz([TOKEN_INERTIA] * 3)}"/>')
        if not np.allclose(chain.post[j], np.eye(4), rtol=0, atol=0):
            lines.append(f"{pad}  <site name={quoteattr(chain.link_names[j] + '_dh')} {_pose(chain.post[j])}/>")
        for child in chain.children(j):
            emit(child, depth + 1)
        lines.append(f"{pad}</body>")

    for j in range(chain.n):
        if chain.parents[j] < 0:
            emit(j, 2)
    lines.append("  </worldbody>")
    if closed is not None:
        lines.append("  <equality>")
        lines.extend(connects)
        lines.append("  </equality>")
    lines.append("  <actuator>")
    for j in (range(chain.n) if closed is None else closed.actuated):
        effort = chain.effort_limits[j] if j < len(chain.effort_limits) else None
        bound = None if effort is None else effort / abs(float(terms.gear[j]))  # actuator force: torque / gear
        limit = "" if bound is None else f' forcerange="{num(-bound)} {num(bound)}"'
        lines.append(f"    <motor name={quoteattr(chain.joint_names[j] + '_motor')} joint={quoteattr(chain.joint_names[j])} "
                     f'gear="{num(terms.gear[j])}"{limit}/>')
    lines.append("  </actuator>")
    lines.append("</mujoco>")
    return "\n".join(lines) + "\n"
