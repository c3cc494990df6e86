"""``excite --collisions``: the robot file's collision shapes compiled by MuJoCo, and the pairs to check
(``collisions`` says which pairs and how they are measured)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from minparam_cli.errors import InputError
from minparam_cli.experiment.excite import constraints as cons
from minparam_cli.experiment.excite.collisions import FLOOR_NAME, PROBE_POSITIONS, Collisions, urdf_for_mujoco


def load_collisions(robot: Path, chain, limits: cons.Limits, clearance: float, floor: float | None,
                    rng: np.random.Generator) -> tuple[Collisions, list[str]]:
    """The shapes of ``robot`` (URDF or MJCF) and their pairs (``collisions``), and the notes to show."""
    from minparam_cli.optional import import_optional

    mj = import_optional("mujoco", "mujoco", "excite --collisions")
    if not (hasattr(mj, "MjSpec") and hasattr(mj, "mj_geomDistance")):
        raise InputError(f"excite --collisions needs mujoco 3.2 or newer (MjSpec, mj_geomDistance); this is {mj.__version__}")
    src, suffix = str(robot), robot.suffix.lower()
    notes: list[str] = []
    if suffix == ".urdf":
        text, source = urdf_for_mujoco(robot), "URDF <collision> elements"
    elif suffix == ".xml":
        from minparam_cli.describe.mjcf import check_mjcf_text
        from minparam_cli.safety import read_bounded

        data = read_bounded(robot)
        check_mjcf_text(data, src)
        text, source = None, "MJCF geoms"
    else:
        raise InputError(f"{src}: --collisions needs collision shapes, and a DH/MDH YAML description has none; give the robot "
                         "as a URDF with <collision> elements or as an MJCF file (or use --box / --floor, which need no shapes)")
    from minparam_cli.describe.mjcf import captured_warnings, one_line

    def build():
        spec = mj.MjSpec.from_string(text) if text is not None else mj.MjSpec.from_file(str(robot))
        if floor is not None:
            _add_floor(mj, spec, cons.up_direction(chain), floor)
        return spec.compile()

    try:
        model, warned = captured_warnings(mj, build)
    except ValueError as e:
        raise InputError(f"{src}: --collisions: MuJoCo cannot compile the file's shapes: {one_line(e)}") from None
    notes += [f"{src}: MuJoCo: {w}" for w in warned]
    qpos, dof = _joint_addresses(mj, model, chain, src)
    pairs, labels, floor_pairs, all_geoms = _pairs(mj, model, src)
    if all_geoms:
        notes.append(f"{src}: no geom has a contype or conaffinity; --collisions uses every geom")
    c = Collisions(mj, model, mj.MjData(model), qpos, dof, pairs, labels, float(clearance), source, floor_pairs)
    lo, hi = limits.shrunk_range()
    probe = cons.joint_states(chain, lo + (hi - lo) * rng.random((PROBE_POSITIONS, limits.n)))
    dist, _ = c.distances(probe)
    stuck = np.all(dist < c.clearance, axis=0)
    if stuck.any():
        left = tuple(labels[k] for k in np.flatnonzero(stuck))
        notes.append(f"--collisions: left out {len(left)} pair(s) closer than the clearance ({c.clearance:g} m) in all "
                     f"{PROBE_POSITIONS} random positions within the joint limits: " + "; ".join(left))
        kept = tuple(label for label, s in zip(labels, stuck, strict=True) if not s)
        c = Collisions(mj, model, c.data, qpos, dof, pairs[~stuck], kept, c.clearance, source,
                       sum(label.startswith("the floor") for label in kept), left)
    if not len(c.pairs):
        raise InputError(f"{src}: --collisions: no pair of collision shapes to check (shapes on bodies that move against "
                         "each other, not parent and child)")
    return c, notes


def _add_floor(mj, spec, up: np.ndarray, height: float) -> None:
    """A plane through up·height with normal ``up`` (the base frame's direction against gravity)."""
    z = np.array([0.0, 0.0, 1.0])
    axis = np.cross(z, up)
    s, cth = float(np.linalg.norm(axis)), float(z @ up)
    if s < 1e-12:
        quat = [1.0, 0.0, 0.0, 0.0] if cth > 0 else [0.0, 1.0, 0.0, 0.0]
    else:
        angle = np.arctan2(s, cth)
        quat = [float(np.cos(angle / 2)), *(np.sin(angle / 2) * axis / s)]
    geom = spec.worldbody.add_geom()
    geom.name = FLOOR_NAME
    geom.type = mj.mjtGeom.mjGEOM_PLANE
    geom.size = [0.0, 0.0, 1.0]
    geom.pos = list(up * height)
    geom.quat = quat


def _joint_addresses(mj, model, chain, src: str) -> tuple[np.ndarray, np.ndarray]:
    qpos, dof = [], []
    for name in chain.joint_names:
        j = mj.mj_name2id(model, mj.mjtObj.mjOBJ_JOINT, name)
        if j < 0:
            raise InputError(f"{src}: --collisions: MuJoCo's model of the file has no joint {name!r}")
        qpos.append(int(model.jnt_qposadr[j]))
        dof.append(int(model.jnt_dofadr[j]))
    return np.array(qpos, dtype=int), np.array(dof, dtype=int)


def _pairs(mj, model, src: str):
    """(P, 2) geom ids, their labels, how many are floor pairs, and whether every geom had to be used."""
    def name(b):
        return mj.mj_id2name(model, mj.mjtObj.mjOBJ_BODY, int(b)) or ("the base" if b == 0 else f"body {b}")

    floor = mj.mj_name2id(model, mj.mjtObj.mjOBJ_GEOM, FLOOR_NAME)
    flat = (int(mj.mjtGeom.mjGEOM_PLANE), int(mj.mjtGeom.mjGEOM_HFIELD))
    shapes = [g for g in range(model.ngeom) if g != floor and int(model.geom_type[g]) not in flat]
    ct, ca = model.geom_contype, model.geom_conaffinity
    colliding = [g for g in shapes if ct[g] or ca[g]]
    all_geoms = not colliding
    geoms = colliding or shapes
    weld, body = model.body_weldid, model.geom_bodyid
    parent = weld[model.body_parentid[weld]]  # per body: the weld group of its weld group's parent
    excluded = {int(s) for s in model.exclude_signature}
    if not any(weld[body[g]] for g in geoms):
        raise InputError(f"{src}: --collisions: the file has no collision shapes on the moving links")
    per_body: dict[int, list[int]] = {}
    for g in geoms:
        per_body.setdefault(int(body[g]), []).append(g)

    def shape(g):  # the body's name, and which of its shapes when it has several (in file order)
        mine = per_body[int(body[g])]
        return name(body[g]) + (f" (shape {mine.index(g) + 1} of {len(mine)})" if len(mine) > 1 else "")

    pairs, labels = [], []
    for i, a in enumerate(geoms):
        for b in geoms[i + 1:]:
            wa, wb = int(weld[body[a]]), int(weld[body[b]])
            if wa == wb or parent[wa] == wb or parent[wb] == wa:
                continue
            if not all_geoms and not (ct[a] & ca[b] or ct[b] & ca[a]):
                continue
            ba, bb = int(body[a]), int(body[b])
            if (min(ba, bb) << 16) + max(ba, bb) in excluded or (max(ba, bb) << 16) + min(ba, bb) in excluded:
                continue
            pairs.append((a, b))
            labels.append(f"{shape(a)} and {shape(b)}")
    floor_pairs = 0
    if floor >= 0:
        for g in geoms:
            if weld[body[g]]:
                pairs.append((floor, g))
                labels.append(f"the floor and {shape(g)}")
                floor_pairs += 1
    return np.array(pairs, dtype=int).reshape(-1, 2), tuple(labels), floor_pairs, all_geoms
