"""Loaders: robot files -> :class:`RobotDescription` records."""

from __future__ import annotations

from pathlib import Path

from minparam_cli.describe.records import GeomValue, Inertial, JointRecord, RobotDescription
from minparam_cli.errors import DescriptionError

ROBOT_SUFFIXES = (".yaml", ".yml", ".urdf")

__all__ = ["GeomValue", "Inertial", "JointRecord", "RobotDescription", "load_description", "ROBOT_SUFFIXES"]


def load_description(path: str | Path) -> RobotDescription:
    """Load a YAML DH/MDH table or a URDF, chosen by the file suffix."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix in (".yaml", ".yml"):
        from minparam_cli.describe.yaml_dh import load_yaml

        return load_yaml(path)
    if suffix == ".urdf":
        from minparam_cli.describe.urdf import load_urdf

        return load_urdf(path)
    raise DescriptionError(f"unknown file type {suffix!r}; expected one of .yaml, .yml, .urdf", str(path))
