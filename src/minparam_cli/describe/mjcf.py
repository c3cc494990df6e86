"""MJCF (MuJoCo's XML) -> RobotDescription, through MuJoCo's own compiler (docs/mjcf.md).

The file is compiled by ``mujoco.MjModel.from_xml_path`` and only the COMPILED model is read, so
includes, default classes, ``<compiler angle/eulerseq/inertiafromgeom>``, ``<frame>`` elements and
meshes mean exactly what MuJoCo makes of them; the XML itself is never interpreted here.  Before
MuJoCo sees it, the file is size-bounded (``safety.read_bounded``), must have a ``<mujoco>`` root
(other ``.xml`` files are not robots: ``NotARobotError``, skipped in folders) and must carry no
DOCTYPE or entity declaration.

* hinge and slide joints move; a body with several joints gets one record per joint, the frames
  between them massless (``JointRecord.massless``, no columns); bodies without joints are welded
  to their parent (inertias lumped about the moving body's frame);
* one free joint on a child of the world body: a floating base, six virtual joints in front of
  that body as for a URDF (q = 0 puts it at its compiled pose);
* joint equalities (``eq_type`` JOINT) with polycoef (c0, c1, 0, 0, 0): y - y0 = c0 + c1 (x - x0),
  a mimic joint (``mimic`` as for URDF); one without a second joint locks its joint at y0 + c0
  (welded); inactive equalities are ignored;
* ``armature``, ``damping``, ``frictionloss`` of a joint's dof: its nominal rotor inertia, viscous
  and Coulomb friction (``JointRecord.nominal_extras``), and their columns (``extras``);
* active ``connect`` and ``weld`` equalities close kinematic loops: the tree of bodies is the spanning
  tree and each equality a cut (``ClosedLoops``, origin "mjcf"; ``mjcf_loops``), the actuated joints
  those an ``<actuator>`` with a joint transmission drives, the reference configuration qpos0;
* each link's geoms give its box (``JointRecord.geometry``, ``mjcf_geometry``): the physical fit's shape;
* gravity from ``<option gravity>``, zero when ``<flag gravity="disable"/>``;
* other free bodies under the world (a ball, a cube beside the robot) are left out, with a warning;
* refused in one line (exit 2), naming the element: ball joints, a free joint below the world
  body's children or beside other joints, tendon/flex equalities, joint equalities
  with nonzero quadratic or higher coefficients.

The joint coordinate is MuJoCo's qpos (not qpos - qpos0): the reference ``ref`` is folded into
the joint's origin.  The walk over the compiled bodies is ``mjcf_tree``'s.
"""

from __future__ import annotations

import re
import threading
import warnings
from pathlib import Path

from minparam_cli.describe.mjcf_tree import (EQ_CONNECT, EQ_JOINT, EQ_TENDON, EQ_WELD, JNT_BALL, JNT_FREE,
                                              JNT_HINGE, JNT_SLIDE, build_description)
from minparam_cli.describe.mjcf_files import DECLARATION, check_mjcf_files
from minparam_cli.describe.records import MIMIC_MODES, RobotDescription
from minparam_cli.errors import DescriptionError, MinparamWarning, NotARobotError, UnsupportedError
from minparam_cli.safety import read_bounded

EQ_WORDS = {EQ_TENDON: "a tendon equality (a tendon coupling)"}

_WARNING_LOCK = threading.Lock()
_ROOT = re.compile(rb"<([A-Za-z_][\w.\-:]*)")


def root_tag(data: bytes) -> str | None:
    """The name of the first element of an XML text (after the prolog's declaration, comments and
    processing instructions), or None when there is none."""
    text = data[3:] if data.startswith(b"\xef\xbb\xbf") else data
    pos = 0
    while True:
        start = text.find(b"<", pos)
        if start < 0:
            return None
        if text.startswith(b"<?", start):
            pos = text.find(b"?>", start)
        elif text.startswith(b"<!--", start):
            pos = text.find(b"-->", start)
        elif text.startswith(b"<!", start):
            pos = text.find(b">", start)
        else:
            m = _ROOT.match(text, start)
            return None if m is None else m.group(1).decode("ascii", "replace")
        if pos < 0:
            return None


def check_mjcf_text(data: bytes, src: str) -> None:
    """Refuse what must not reach MuJoCo's parser: a DOCTYPE or an entity declaration (TinyXML2 does
    not expand entities, but a robot file never needs them), and a root other than <mujoco>."""
    if DECLARATION.search(data):
        raise DescriptionError("DOCTYPE and entity declarations are not allowed in an MJCF file", src)
    tag = root_tag(data)
    if tag != "mujoco":
        raise NotARobotError(f"root element is <{tag}>, expected <mujoco> (an MJCF file)" if tag else "no XML element: not an MJCF file", src)


def captured_warnings(mujoco, build):
    """``build()`` (a MuJoCo compile) with MuJoCo's global warning handler replaced, under the one lock that
    guards it: (its result, the warnings it raised).  MuJoCo's own handler would write MUJOCO_LOG.TXT into
    the working folder and print to stderr; the handler before is put back.  Exceptions pass through."""
    notes: list[str] = []
    with _WARNING_LOCK:
        before = mujoco.get_mju_user_warning()
        mujoco.set_mju_user_warning(notes.append)
        try:
            return build(), notes
        finally:
            mujoco.set_mju_user_warning(before)


def one_line(error: Exception) -> str:
    """A MuJoCo compiler message (several lines) as one line."""
    return "; ".join(part.strip() for part in str(error).splitlines() if part.strip())


def compile_model(path: Path, src: str):
    """The compiled ``mujoco.MjModel`` of the file, or MuJoCo's message in one line; the compiler's
    warnings become MinparamWarning notes (one line each) once its numbers are known to be usable
    (``_check_values``: a refused file shows the refusal alone)."""
    from minparam_cli.optional import import_optional

    mujoco = import_optional("mujoco", "mujoco", "reading MJCF (.xml) robot files")
    try:
        model, notes = captured_warnings(mujoco, lambda: mujoco.MjModel.from_xml_path(str(path)))
    except ValueError as e:
        raise DescriptionError(f"MuJoCo cannot compile the file: {one_line(e)}", src) from None
    _check_values(model, _Names(model), src)
    for note in notes:  # several lines ("...\nElement name 'f', id 0"): one
        warnings.warn(f"{src}: MuJoCo: {one_line(Exception(note))}", MinparamWarning, stacklevel=4)
    return model


def load_mjcf(path: Path, snap_angles: float | None = None, mimic: str = "coupled", floating_base: bool = False) -> RobotDescription:
    """Read an MJCF file (module docstring).  ``snap_angles`` (rad): joint origin angles within it of a
    multiple of 15° are rounded to it, each change recorded.  ``mimic``: joint equalities "coupled"
    (move with their master) or "fixed" (frozen where the master's q = 0 puts them).
    ``floating_base``: an MJCF says so itself (a free joint); asking for one without it is refused."""
    if mimic not in MIMIC_MODES:
        raise ValueError(f"mimic must be one of {MIMIC_MODES}, got {mimic!r}")
    src = str(path)
    data = read_bounded(path)
    check_mjcf_text(data, src)
    check_mjcf_files(path, data, src)
    m = compile_model(path, src)
    names = _Names(m)
    free, left_out = _check_joints(m, names, src)
    if floating_base and free is None:
        raise DescriptionError("--floating-base: an MJCF file declares its floating base itself (a free joint, <freejoint/>), and this one has none", src)
    locked, masters, loops = _equalities(m, names, src, mimic, left_out)
    desc, frames, index = build_description(m, names, src, free, locked, masters, snap_angles, left_out)
    from dataclasses import replace

    from minparam_cli.describe.mjcf_geometry import link_boxes

    boxes = link_boxes(m, frames)  # the links' geoms: the physical fit's shapes
    desc = replace(desc, joints=tuple(j if j.massless else replace(j, geometry=boxes.get(k)) for k, j in enumerate(desc.joints)))
    if not loops:
        return desc
    from minparam_cli.describe.mjcf_loops import closed_loops

    return replace(desc, loops=closed_loops(m, names, src, loops, frames, index, free, masters))


# the compiled arrays the reader uses, by element kind: (attribute, bounded by MAX_ABS_VALUE or only finite)
_VALUES = {
    "body": (("body_pos", True), ("body_quat", True), ("body_ipos", True), ("body_iquat", True), ("body_mass", True), ("body_inertia", True)),
    "joint": (("jnt_pos", True), ("jnt_axis", True), ("jnt_range", False), ("jnt_actfrcrange", False)),
    "site": (("site_pos", True),),
    "equality": (("eq_data", True),),
}
_DOF_VALUES = ("dof_armature", "dof_damping", "dof_frictionloss")


def _check_values(m, names: "_Names", src: str) -> None:
    """Every compiled number the reader uses is finite, and within MAX_ABS_VALUE where it is a length, a
    mass or an inertia: MuJoCo compiles NaN (with a warning), inf and 1e308, which would break the chain
    far from the file."""
    import numpy as np

    from minparam_cli.safety import MAX_ABS_VALUE

    def check(values, bound: bool, where: str, attr: str) -> None:
        v = np.asarray(values, dtype=float).ravel()
        if not np.all(np.isfinite(v)):
            raise DescriptionError(f"{attr} is not finite after compiling ({' '.join(f'{x:g}' for x in v[:7])})", src, where)
        if bound and v.size and float(np.max(np.abs(v))) > MAX_ABS_VALUE:
            raise DescriptionError(f"{attr} is out of range after compiling: a magnitude of at most {MAX_ABS_VALUE:g} is expected "
                                   f"(got {float(np.max(np.abs(v))):g})", src, where)

    label = {"body": lambda i: f"body[{names.body[i]}]", "joint": lambda i: f"joint[{names.joint[i]}]",
             "site": lambda i: f"site[{names.site[i] or i}]", "equality": lambda i: names.equality[i]}
    for kind, attrs in _VALUES.items():
        for attr, bound in attrs:
            arr = np.asarray(getattr(m, attr), dtype=float)
            if not arr.size:
                continue
            arr = arr.reshape(len(arr), -1)
            bad = ~np.all(np.isfinite(arr), axis=1)
            if bound:
                bad |= np.max(np.abs(np.where(np.isfinite(arr), arr, 0.0)), axis=1) > MAX_ABS_VALUE
            for i in np.flatnonzero(bad)[:1]:
                check(arr[i], bound, label[kind](int(i)), attr)
    for j in range(m.njnt):
        check(m.qpos0[m.jnt_qposadr[j]], True, label["joint"](j), "qpos0")
        dof = int(m.jnt_dofadr[j])
        for attr in _DOF_VALUES:
            check(getattr(m, attr)[dof], True, label["joint"](j), attr)
    check(m.opt.gravity, True, "option", "gravity")


class _Names:
    """Names of the compiled model's bodies, joints and equalities; unnamed ones get a made-up, unique
    name (``body3``, ``<body>_joint2``, ``equality #1``)."""

    def __init__(self, m):
        import mujoco

        def name(kind, i):
            return mujoco.mj_id2name(m, kind, i) or ""

        self.body = [name(mujoco.mjtObj.mjOBJ_BODY, b) or (f"body{b}" if b else "world") for b in range(m.nbody)]
        taken = set(self.body)
        self.joint = []
        for j in range(m.njnt):
            given = name(mujoco.mjtObj.mjOBJ_JOINT, j)
            b = int(m.jnt_bodyid[j])
            text = given or (f"{self.body[b]}_joint" + (str(j - int(m.body_jntadr[b]) + 1) if m.body_jntnum[b] > 1 else ""))
            while not given and text in taken:
                text += "_"
            taken.add(text)
            self.joint.append(text)
        self.equality = [f"equality[{n}]" if (n := name(mujoco.mjtObj.mjOBJ_EQUALITY, e)) else f"equality #{e + 1}" for e in range(m.neq)]
        self.model = bytes(m.names).split(b"\0", 1)[0].decode("utf-8", "replace") or "mjcf"
        self.site = [name(mujoco.mjtObj.mjOBJ_SITE, s) for s in range(m.nsite)]


def _check_joints(m, names: _Names, src: str) -> tuple[int | None, frozenset[int]]:
    """(the body with the free joint of the floating base or None, the world's children left out);
    refuses ball joints and free joints beside other joints.

    Several free bodies under the world, or free bodies beside a fixed-base tree with more hinge and
    slide joints: the robot is the tree with the most of them (the first written on a tie), the other
    free bodies are separate objects (a ball, a cube to push) and are left out, with a warning; their
    dynamics do not touch the robot's."""
    frees = []
    for j in range(m.njnt):
        kind, b = int(m.jnt_type[j]), int(m.jnt_bodyid[j])
        where = f"joint[{names.joint[j]}]"
        if kind == JNT_BALL:
            raise UnsupportedError(f"ball joints are not supported yet (body '{names.body[b]}')", src, where)
        if kind != JNT_FREE:
            continue
        if int(m.body_parentid[b]) != 0:  # MuJoCo's compiler refuses it too
            raise UnsupportedError(f"a free joint not at the root (body '{names.body[b]}' hangs on '{names.body[int(m.body_parentid[b])]}') is not supported yet",
                                   src, where)
        if m.body_jntnum[b] > 1:
            raise UnsupportedError(f"body '{names.body[b]}' has a free joint and other joints: not supported", src, where)
        frees.append(b)
    if not frees:
        return None, frozenset()
    moving: dict[int, int] = {}  # world child -> hinge and slide joints of its tree
    for j in range(m.njnt):
        if int(m.jnt_type[j]) in (JNT_HINGE, JNT_SLIDE):
            root = int(m.body_rootid[int(m.jnt_bodyid[j])])
            moving[root] = moving.get(root, 0) + 1
    best_free = max(frees, key=lambda b: (moving.get(b, 0), -b))
    fixed = [r for r in moving if r not in frees]
    free = None if fixed and max(moving[r] for r in fixed) > moving.get(best_free, 0) else best_free
    left_out = frozenset(b for b in frees if b != free)
    if left_out:
        shown = ", ".join(f"'{names.body[b]}'" for b in sorted(left_out))
        warnings.warn(f"{src}: free bodies {shown} left out: separate objects beside the robot (one floating base is modelled)",
                      MinparamWarning, stacklevel=4)
    return free, left_out


def _equalities(m, names: _Names, src: str, mimic: str,
                left_out: frozenset[int]) -> tuple[dict[int, float], dict[int, tuple[int, float, float]], list[int]]:
    """({locked joint: its value}, {mimic joint: (independent joint, multiplier, offset)}, [connect and
    weld equalities]) from the active equalities, q_mimic = multiplier·q_master + offset in qpos units;
    refuses the others."""
    locked: dict[int, float] = {}
    direct: dict[int, tuple[int, float, float]] = {}
    loops: list[int] = []
    for e in range(m.neq):
        if not m.eq_active0[e]:
            continue  # switched off at the start (it may be switched on by a controller: not modelled)
        kind, where = int(m.eq_type[e]), names.equality[e]
        if kind in (EQ_CONNECT, EQ_WELD):  # a loop-closing cut (describe/mjcf_loops.py)
            loops.append(e)
            continue
        if kind != EQ_JOINT:
            word = EQ_WORDS.get(kind, f"an equality of type {kind} (flex)")
            raise UnsupportedError(f"{word} is not supported yet", src, where)
        y, x = int(m.eq_obj1id[e]), int(m.eq_obj2id[e])
        if int(m.body_rootid[int(m.jnt_bodyid[y])]) in left_out:
            continue  # a joint of a free object left out (_check_joints)
        c = [float(v) for v in m.eq_data[e, :5]]
        if any(c[2:]):
            raise UnsupportedError(f"a polynomial joint coupling (polycoef {' '.join(f'{v:g}' for v in c)}: quadratic or higher terms) is not supported yet",
                                   src, where)
        for jnt in (y, x):
            if jnt >= 0 and int(m.jnt_type[jnt]) not in (JNT_HINGE, JNT_SLIDE):
                raise UnsupportedError(f"a joint equality on joint '{names.joint[jnt]}', which is not a hinge or slide joint, is not supported", src, where)
        if y in direct or y in locked:
            raise UnsupportedError(f"joint '{names.joint[y]}' is constrained by two joint equalities: not supported", src, where)
        y0 = float(m.qpos0[m.jnt_qposadr[y]])
        if x < 0 or c[1] == 0.0:
            locked[y] = y0 + c[0]
            continue
        if x == y:
            raise DescriptionError("a joint equality couples a joint with itself", src, where)
        x0 = float(m.qpos0[m.jnt_qposadr[x]])
        direct[y] = (x, c[1], y0 + c[0] - c[1] * x0)
    masters: dict[int, tuple[int, float, float]] = {}
    for y, (x, k, o) in direct.items():  # a mimic of a mimic: followed to the independent joint
        seen = [y]
        while x in direct:
            if x in seen:
                raise UnsupportedError("joint equalities form a loop: " + " -> ".join(names.joint[i] for i in [*seen, x]), src, f"joint[{names.joint[y]}]")
            seen.append(x)
            x2, k2, o2 = direct[x]
            x, k, o = x2, k * k2, k * o2 + o
        if x in locked:
            locked[y] = k * locked[x] + o
        else:
            masters[y] = (x, k, o)
    if mimic == "fixed":  # frozen where the master's q = 0 puts them, as for URDF's --mimic fixed
        locked.update({y: o for y, (_, _, o) in masters.items()})
        masters = {}
    return locked, masters, loops
