"""Loaders: robot files -> :class:`RobotDescription` records."""

from __future__ import annotations

from pathlib import Path

from minparam_cli.describe.records import GeomValue, Inertial, JointRecord, RobotDescription
from minparam_cli.errors import DescriptionError

ROBOT_SUFFIXES = (".yaml", ".yml", ".urdf", ".xml")

__all__ = ["GeomValue", "Inertial", "JointRecord", "RobotDescription", "load_description", "ROBOT_SUFFIXES"]


def load_description(path: str | Path, snap_angles: float | None = None, mimic: str = "coupled", floating_base: bool = False) -> RobotDescription:
    """Load a YAML DH/MDH table, a URDF or an MJCF (``.xml``, through MuJoCo's compiler), chosen by the file suffix;
    every geometry symbol then names one value (``describe/symbols.py``).

    ``snap_angles`` (rad): round angles within it of a multiple of 15° (``describe/snap.py``).
    ``mimic``: URDF mimic joints move with their master ("coupled") or stay at their offset ("fixed").
    ``floating_base``: a URDF's root link is free (six virtual base joints); YAML tables refuse it.
    """
    from minparam_cli.describe.symbols import distinct_symbols

    return distinct_symbols(_load(Path(path), snap_angles, mimic, floating_base))


def _load(path: Path, snap_angles: float | None, mimic: str, floating_base: bool) -> RobotDescription:
    suffix = path.suffix.lower()
    if suffix in (".yaml", ".yml"):
        from minparam_cli.describe.closed_yaml import load_closed
        from minparam_cli.describe.yaml_dh import load_yaml

        if floating_base:
            raise DescriptionError("--floating-base applies to URDF files (a DH table describes a fixed base)", str(path))
        closed = load_closed(path)  # a closed chain (kind: closed_chain, or a platform with dynamics), else None
        if closed is not None:
            return closed
        desc = load_yaml(path)
        if snap_angles is not None:
            from minparam_cli.describe.snap import snap_description

            desc = snap_description(desc, snap_angles)
        return desc
    if suffix == ".urdf":
        from minparam_cli.describe.urdf import load_urdf

        desc = load_urdf(path, snap_angles, mimic, floating_base)
        from minparam_cli.describe.transmission import load_side_file

        if not floating_base:  # robot.transmission.yaml beside robot.urdf (a URDF has no place for it)
            from dataclasses import replace

            tr = load_side_file(path, tuple(j.type for j in desc.joints if j.mimic is None))
            if tr is not None:
                desc = replace(desc, transmission=tr)
        return desc
    if suffix == ".xml":
        from minparam_cli.describe.mjcf import load_mjcf

        return load_mjcf(path, snap_angles, mimic, floating_base)
    raise DescriptionError(f"unknown file type {suffix!r}; expected one of .yaml, .yml, .urdf, .xml", str(path))
