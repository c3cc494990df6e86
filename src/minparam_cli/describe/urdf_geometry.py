"""The box a URDF link's shapes fill, in the link's frame: what ``identify --physical`` turns into the
ellipsoid its mass must stay inside (identify/physical/geometry.py).

The link's ``<collision>`` shapes, or its ``<visual>`` ones when it has no collision shape: ``box``,
``cylinder`` (axis z), ``sphere``, and ``mesh`` only where the file is an STL (binary or ASCII) that
the URDF's lookup finds (``describe/mesh_files.py``: a relative path, ``file://``, or ``package://``
under the URDF's folder, a folder above it or ``ROS_PACKAGE_PATH``) and is within the size cap; its
``scale`` applies.  Each shape's own bounding box, moved by its ``<origin>``, gives eight corners; the link's box holds them all.  A shape that cannot be read (a
missing or malformed number, another mesh format, a missing file) is skipped, and a link with no
readable shape has no box: the shapes are a hint for the physical fit, never needed to load the robot.
"""

from __future__ import annotations

import struct
from itertools import product
from pathlib import Path

import numpy as np

from minparam_cli.describe.mesh_files import find_mesh

MAX_MESH_BYTES = 64 * 2**20  # an STL larger than this is skipped


def _numbers(text: str | None, n: int) -> np.ndarray | None:
    try:
        v = np.array([float(x) for x in (text or "").split()])
    except ValueError:
        return None
    return v if v.size == n and np.all(np.isfinite(v)) else None


def _stl_box(path: Path) -> tuple[np.ndarray, np.ndarray] | None:
    """The bounding box of an STL file's vertices, or None."""
    try:
        if not path.is_file() or path.stat().st_size > MAX_MESH_BYTES:
            return None
        data = path.read_bytes()
    except OSError:
        return None
    if len(data) >= 84:
        count = struct.unpack_from("<I", data, 80)[0]
        if 84 + 50 * count == len(data) and count > 0:  # binary: 50 bytes per triangle
            tri = np.frombuffer(data, dtype=np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")]), count=count, offset=84)
            v = tri["v"].reshape(-1, 3).astype(float)
            return (v.min(axis=0), v.max(axis=0)) if np.all(np.isfinite(v)) else None
    try:
        lines = data.decode("ascii").split("\n")
    except UnicodeDecodeError:
        return None
    pts = [_numbers(" ".join(s.split()[1:]), 3) for s in lines if s.strip().startswith("vertex")]
    good = [p for p in pts if p is not None]
    if not good or len(good) != len(pts):
        return None
    v = np.array(good)
    return v.min(axis=0), v.max(axis=0)


def _shape_box(geom, base_dir: Path | None) -> tuple[np.ndarray, np.ndarray] | None:
    """The bounding box of one <geometry>'s shape in its own frame, or None."""
    for shape in geom:
        tag = shape.tag
        if tag == "box":
            size = _numbers(shape.get("size"), 3)
            return None if size is None or np.any(size < 0) else (-size / 2, size / 2)
        if tag in ("cylinder", "sphere"):
            r = _numbers(shape.get("radius"), 1)
            h = _numbers(shape.get("length"), 1) if tag == "cylinder" else (None if r is None else 2 * r)
            if r is None or h is None or r[0] < 0 or h[0] < 0:
                return None
            half = np.array([r[0], r[0], h[0] / 2])
            return -half, half
        if tag == "mesh":
            name = shape.get("filename") or ""
            found = None if base_dir is None or not name.lower().endswith(".stl") else find_mesh(name, base_dir)
            if found is None:
                return None
            box = _stl_box(found)
            scale = _numbers(shape.get("scale"), 3) if shape.get("scale") else np.ones(3)
            if box is None or scale is None:
                return None
            lo, hi = box[0] * scale, box[1] * scale
            return np.minimum(lo, hi), np.maximum(lo, hi)
    return None


def _origin(xyz: np.ndarray, rpy: np.ndarray) -> np.ndarray:
    """The URDF <origin>: translation xyz, rotation Rz(yaw)·Ry(pitch)·Rx(roll)."""
    (cr, cp, cy), (sr, sp, sy) = np.cos(rpy), np.sin(rpy)
    X = np.eye(4)
    X[:3, :3] = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]]) @ np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]]) \
        @ np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    X[:3, 3] = xyz
    return X


def link_box(link_el, base_dir: Path | None) -> tuple[str, tuple[float, ...], tuple[float, ...]] | None:
    """(source, lo, hi): the box in the link's frame that holds its collision (else visual) shapes."""
    for kind in ("collision", "visual"):
        corners = []
        for el in link_el.findall(kind):
            geom = el.find("geometry")
            box = None if geom is None else _shape_box(geom, base_dir)
            if box is None:
                continue
            origin = el.find("origin")
            xyz = _numbers(origin.get("xyz", "0 0 0") if origin is not None else "0 0 0", 3)
            rpy = _numbers(origin.get("rpy", "0 0 0") if origin is not None else "0 0 0", 3)
            if xyz is None or rpy is None:
                continue
            X = _origin(xyz, rpy)
            for c in product(*zip(box[0], box[1], strict=True)):
                corners.append(X[:3, :3] @ np.array(c) + X[:3, 3])
        if corners:
            pts = np.array(corners)
            return kind, tuple(float(x) for x in pts.min(axis=0)), tuple(float(x) for x in pts.max(axis=0))
    return None


def moved_box(box, X: np.ndarray):
    """A link's box seen from the body it is lumped into (X: body frame → link frame), as a box again."""
    kind, lo, hi = box
    pts = np.array([X[:3, :3] @ np.array(c) + X[:3, 3] for c in product(*zip(lo, hi, strict=True))])
    return kind, tuple(float(x) for x in pts.min(axis=0)), tuple(float(x) for x in pts.max(axis=0))


def merged_box(a, b):
    """The box that holds two boxes (None: no box)."""
    if a is None or b is None:
        return a if b is None else b
    kind = a[0] if a[0] == b[0] else "collision+visual"
    return kind, tuple(min(x, y) for x, y in zip(a[1], b[1], strict=True)), tuple(max(x, y) for x, y in zip(a[2], b[2], strict=True))
