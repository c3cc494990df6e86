"""The box an MJCF link's geoms fill, in the link's frame: the MJCF counterpart of
``urdf_geometry.link_box``, what ``identify --physical`` turns into the ellipsoid its mass must stay
inside (identify/physical/geometry.py).

A link gathers the geoms of its body and of the bodies welded to it (no joints).  Its collision
geoms are those with ``contype`` or ``conaffinity`` nonzero (MuJoCo's own test for whether a geom
can collide; Menagerie's "collision" classes, group 3, keep the default 1, its "visual" classes,
group 2, set both to 0); a link with no collision geom takes its other geoms (source "visual").
Planes and height fields are skipped (not a body's extent).  Each geom's box is MuJoCo's compiled
``geom_aabb`` (centre and half-sizes in the geom's frame: meshes included, as MuJoCo scaled and
centred them), its eight corners moved by ``geom_pos/geom_quat`` (geom frame in the body frame) and
by the body's frame in the link frame; the link's box holds all the corners.
"""

from __future__ import annotations

from itertools import product

import numpy as np

from minparam_cli.describe.mjcf_tree import quat_matrix

GEOM_PLANE, GEOM_HFIELD = 0, 1  # mujoco.mjtGeom


def geom_corners(m, g: int, X: np.ndarray) -> np.ndarray:
    """(8, 3): the corners of geom g's box, in the frame where its body's frame is X (4x4)."""
    aabb = np.asarray(m.geom_aabb[g], dtype=float)
    R = X[:3, :3] @ quat_matrix(m.geom_quat[g])
    p = X[:3, :3] @ np.asarray(m.geom_pos[g], dtype=float) + X[:3, 3]
    corners = np.array([aabb[:3] + np.array(s) * aabb[3:] for s in product((-1.0, 1.0), repeat=3)])
    return corners @ R.T + p


def link_boxes(m, frames: dict) -> dict[int, tuple[str, tuple[float, ...], tuple[float, ...]]]:
    """record -> (source, lo, hi) for every record whose bodies carry geoms; ``frames``: body ->
    (record, body frame in that record's link frame), as ``mjcf_tree.build_description`` walks them."""
    found: dict[int, dict[str, list[np.ndarray]]] = {}
    for b, (rec, X) in frames.items():
        if rec < 0 or b == 0:
            continue
        start = int(m.body_geomadr[b])
        for g in range(start, start + int(m.body_geomnum[b])) if start >= 0 else ():
            if int(m.geom_type[g]) in (GEOM_PLANE, GEOM_HFIELD):
                continue
            kind = "collision" if m.geom_contype[g] or m.geom_conaffinity[g] else "visual"
            found.setdefault(rec, {}).setdefault(kind, []).append(geom_corners(m, g, X))
    out = {}
    for rec, kinds in found.items():
        kind = "collision" if "collision" in kinds else "visual"
        pts = np.concatenate(kinds[kind])
        out[rec] = (kind, tuple(float(x) + 0.0 for x in pts.min(axis=0)), tuple(float(x) + 0.0 for x in pts.max(axis=0)))
    return out
