"""Loaders: robot files -> :class:`RobotDescription` records."""

from __future__ import annotations

from pathlib import Path

from minparam_cli.describe.records import GeomValue, Inertial, JointRecord, RobotDescription
from minparam_cli.errors import DescriptionError

ROBOT_SUFFIXES = (".yaml", ".yml", ".urdf")

__all__ = ["GeomValue", "Inertial", "JointRecord", "RobotDescription", "load_description", "ROBOT_SUFFIXES"]


def load_description(path: str | Path, snap_angles: float | None = None, mimic: str = "coupled") -> RobotDescription:
    """Load a YAML DH/MDH table or a URDF, chosen by the file suffix.

    ``snap_angles`` (rad): round angles within it of a multiple of 15° (``describe/snap.py``).
    ``mimic``: URDF mimic joints move with their master ("coupled") or stay at their offset ("fixed").
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix in (".yaml", ".yml"):
        from minparam_cli.describe.yaml_dh import load_yaml

        desc = load_yaml(path)
        if snap_angles is not None:
            from minparam_cli.describe.snap import snap_description

            desc = snap_description(desc, snap_angles)
        return desc
    if suffix == ".urdf":
        from minparam_cli.describe.urdf import load_urdf

        return load_urdf(path, snap_angles, mimic)
    raise DescriptionError(f"unknown file type {suffix!r}; expected one of .yaml, .yml, .urdf", str(path))
