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
In MuJoCo, armature and damping are part of the inverse dynamics (``mj_inverse``: M with armature,
minus the passive damping force); frictionloss is a constraint force, found by MuJoCo's soft
constraint solver, which equals Fc·sign(q̇) only when it saturates (docs/simulation.md).
"""

from __future__ import annotations

import math

import numpy as np

from minparam_cli.errors import InputError
from minparam_cli.model.export_robot import body, comment_text, link_phi, num, standard_in_frame, xyz


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


def check_mjcf_chain(chain) -> None:
    """Chains the MJCF writer cannot write, refused in one line."""
    if chain.coupling is not None:
        raise InputError("--export-mjcf: the robot has coupled mimic joints, which the MJCF export does not write "
                         "(MuJoCo would need equality constraints); use --mimic fixed")
    if chain.floating_base:
        raise InputError("--export-mjcf: a floating-base robot is not exported")


def mjcf_from_chain(chain, phi: np.ndarray, terms, note: str = "") -> str:
    """The MJCF document of the chain with the identified bodies ``phi`` (full parameters, chain.layout
    order) and the joint terms ``terms`` (``export_extra.JointTerms``)."""
    from xml.sax.saxutils import quoteattr

    check_mjcf_chain(chain)
    phis = link_phi(chain, phi)
    lines = [f"<mujoco model={quoteattr(chain.name)}>"]
    if note:
        lines.append(f"  <!-- {comment_text(note)} -->")
    lines.append('  <compiler angle="radian" autolimits="true" inertiafromgeom="false" balanceinertia="false"/>')
    lines.append(f'  <option gravity="{xyz(chain.gravity)}"/>')
    lines.append("  <worldbody>")

    def emit(j: int, depth: int) -> None:
        pad = "  " * depth
        p = chain.parents[j]
        T = (np.eye(4) if p < 0 else chain.post[p]) @ chain.pre[j]
        lines.append(f"{pad}<body name={quoteattr(chain.link_names[j])} {_pose(T)}>")
        kind = "hinge" if chain.types[j] == "revolute" else "slide"
        attrs = [f"name={quoteattr(chain.joint_names[j])}", f'type="{kind}"', 'pos="0 0 0"', f'axis="{xyz(chain.axes[j])}"',
                 f'armature="{num(terms.armature[j])}"', f'damping="{num(terms.damping[j])}"',
                 f'frictionloss="{num(terms.friction[j])}"']
        limits = chain.limits[j] if j < len(chain.limits) else None
        if limits is not None:
            attrs.append(f'range="{num(limits[0])} {num(limits[1])}"')
        lines.append(f"{pad}  <joint {' '.join(attrs)}/>")
        lines.append(f"{pad}  {_inertial(standard_in_frame(phis[j], chain.post[j]))}")
        if not np.allclose(chain.post[j], np.eye(4), rtol=0, atol=0):
            lines.append(f"{pad}  <site name={quoteattr(chain.link_names[j] + '_dh')} {_pose(chain.post[j])}/>")
        for child in chain.children(j):
            emit(child, depth + 1)
        lines.append(f"{pad}</body>")

    for j in range(chain.n):
        if chain.parents[j] < 0:
            emit(j, 2)
    lines.append("  </worldbody>")
    lines.append("  <actuator>")
    for j in range(chain.n):
        effort = chain.effort_limits[j] if j < len(chain.effort_limits) else None
        bound = None if effort is None else effort / abs(float(terms.gear[j]))  # actuator force: torque / gear
        limit = "" if bound is None else f' forcerange="{num(-bound)} {num(bound)}"'
        lines.append(f"    <motor name={quoteattr(chain.joint_names[j] + '_motor')} joint={quoteattr(chain.joint_names[j])} "
                     f'gear="{num(terms.gear[j])}"{limit}/>')
    lines.append("  </actuator>")
    lines.append("</mujoco>")
    return "\n".join(lines) + "\n"
