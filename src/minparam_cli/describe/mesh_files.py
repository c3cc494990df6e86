"""Where a URDF's mesh file lies: one lookup for every reader of ``<mesh filename=...>`` (the physical
fit's link boxes, ``describe/urdf_geometry.py``; excite's collision shapes,
``experiment/excite/collisions.py``).

* ``package://PKG/REST``: under the URDF's folder or any folder above it, as ``PKG/REST`` or as
  ``REST`` (a package checked out beside or above the file, or the file inside its own package), then
  under each entry of ``ROS_PACKAGE_PATH`` the same two ways;
* ``file://PATH``: PATH itself when absolute, else relative to the URDF's folder;
* anything else: relative to the URDF's folder.

Only existing regular files are returned; ``None`` otherwise (the caller says what that means: a
skipped shape for the physical fit, a one-line error for excite).
"""

from __future__ import annotations

import os
from pathlib import Path


def find_mesh(name: str, folder: Path) -> Path | None:
    """The file a URDF in ``folder`` means by the mesh ``name`` (module docstring), or None."""
    if name.startswith("file://"):
        p = Path(name[len("file://"):])
        p = p if p.is_absolute() else folder / p
        return p if p.is_file() else None
    if name.startswith("package://"):
        rest = name[len("package://"):]
        tail = rest.split("/", 1)[1] if "/" in rest else rest
        roots = [folder.resolve(), *folder.resolve().parents]
        roots += [Path(e) for e in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep) if e]
        for root in roots:
            for candidate in (root / rest, root / tail):
                if candidate.is_file():
                    return candidate
        return None
    p = folder / name
    return p if p.is_file() else None
