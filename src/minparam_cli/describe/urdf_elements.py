"""URDF elements -> plain records: the links' inertials and the joints' types, origins, axes,
limits and mimics, every value checked and named in the error (``describe/urdf.py`` gives the
reader's rules; ``describe/urdf_tree.py`` builds the description from these records)."""

from __future__ import annotations

import math

from pathlib import Path

import numpy as np

from minparam_cli.describe.urdf_geometry import link_box
from minparam_cli.safety import MAX_ABS_VALUE, MAX_NUMBER_CHARS, bounded, short_repr
from minparam_cli.errors import DescriptionError, UnsupportedError

ACTUATED = {"revolute": "revolute", "continuous": "revolute", "prismatic": "prismatic"}
KNOWN_TYPES = set(ACTUATED) | {"fixed", "floating", "planar"}
INERTIA_KEYS = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")


def _floats(text: str | None, n: int, src: str, where: str, default: str | None = None, bound: bool = True) -> list[str]:
    if text is None:
        if default is None:
            raise DescriptionError("missing required attribute", src, where)
        text = default
    parts = text.split()
    if len(parts) != n:
        raise DescriptionError(f"expected {n} numbers, got {short_repr(text)}", src, where)
    for p in parts:
        if len(p) > MAX_NUMBER_CHARS:
            raise DescriptionError(f"a number written with {len(p)} characters (at most {MAX_NUMBER_CHARS})", src, where)
        try:
            x = float(p)
        except ValueError:
            raise DescriptionError(f"expected a number, got {p!r}", src, where) from None
        if not math.isfinite(x):
            raise DescriptionError(f"expected a finite number, got {p!r}", src, where)
        if bound:
            bounded(x, src, where)
    return parts


def _number_attr(el, attr: str, src: str, where: str, bound: bool = True) -> float:
    v = el.get(attr)
    if v is None:
        raise DescriptionError(f"missing required attribute '{attr}'", src, where)
    return float(_floats(v, 1, src, f"{where}@{attr}", bound=bound)[0])


def read_elements(root, src: str):
    """({link name: {"inertial": ...}}, [joint dicts]) of a parsed <robot> element, in document order."""
    links: dict[str, dict] = {}
    for el in root.findall("link"):
        name = el.get("name")
        if not name:
            raise DescriptionError("a <link> has no name", src, "link")
        if name in links:
            raise DescriptionError(f"link '{name}' is defined twice", src, f"link[{name}]")
        links[name] = {"inertial": _read_inertial(el.find("inertial"), src, f"link[{name}]/inertial"),
                       "box": link_box(el, Path(src).parent)}  # its shapes' box (urdf_geometry.py), or None
    joints = []
    names = set()
    for el in root.findall("joint"):
        name = el.get("name")
        if not name:
            raise DescriptionError("a <joint> has no name", src, "joint")
        where = f"joint[{name}]"
        if name in names:
            raise DescriptionError(f"joint '{name}' is defined twice", src, where)
        names.add(name)
        jtype = el.get("type")
        if jtype is None:
            raise DescriptionError("missing required attribute 'type'", src, where)
        if jtype not in KNOWN_TYPES:
            raise DescriptionError(f"unknown joint type {short_repr(jtype)}", src, where)
        if jtype == "planar":
            raise UnsupportedError("planar joints are not supported yet", src, where)
        mimic = None
        mimic_el = el.find("mimic")
        if mimic_el is not None:
            master = (mimic_el.get("joint") or "").strip()
            if not master:
                raise DescriptionError("missing required attribute 'joint'", src, f"{where}/mimic")
            # URDF specification: multiplier 1 and offset 0 when absent
            mult = _floats(mimic_el.get("multiplier"), 1, src, f"{where}/mimic@multiplier", "1")[0]
            off = _floats(mimic_el.get("offset"), 1, src, f"{where}/mimic@offset", "0")[0]
            mimic = (master, mult, off)
        parent, child = el.find("parent"), el.find("child")
        if parent is None or not parent.get("link"):
            raise DescriptionError("missing <parent link=...>", src, where)
        if child is None or not child.get("link"):
            raise DescriptionError("missing <child link=...>", src, where)
        origin = el.find("origin")
        xyz = _floats(origin.get("xyz") if origin is not None else None, 3, src, f"{where}/origin@xyz", "0 0 0")
        rpy = _floats(origin.get("rpy") if origin is not None else None, 3, src, f"{where}/origin@rpy", "0 0 0")
        axis_el = el.find("axis")
        # URDF specification: the default axis is (1, 0, 0)
        axis = [float(x) for x in _floats(axis_el.get("xyz") if axis_el is not None else None, 3, src, f"{where}/axis@xyz", "1 0 0")]
        if jtype != "fixed" and np.linalg.norm(axis) == 0:
            raise DescriptionError("joint axis is the zero vector", src, f"{where}/axis")
        if jtype != "fixed" and np.linalg.norm(axis) < 1e-6:
            raise DescriptionError(f"joint axis {' '.join(axis_el.get('xyz').split())} is too short to give a direction (length below 1e-6)", src, f"{where}/axis")
        limits = None
        lim = el.find("limit")
        if jtype in ("revolute", "prismatic") and lim is not None and lim.get("lower") is not None and lim.get("upper") is not None:
            # finite but huge limits (-1e16 .. 1e16) are a common way of writing "no limit"
            lo = _number_attr(lim, "lower", src, f"{where}/limit", bound=False)
            hi = _number_attr(lim, "upper", src, f"{where}/limit", bound=False)
            # reversed limits are a typing error; equal ones leave the joint no motion.  lower = upper = 0 is
            # what a <limit> without lower/upper means (the specification's defaults): no limits, as before
            if lo > hi:
                raise DescriptionError(f"lower limit {lo:g} is above upper limit {hi:g}", src, f"{where}/limit")
            if lo == hi and lo != 0:
                raise DescriptionError(f"lower and upper limit are both {lo:g}: the {jtype} joint cannot move "
                                       "(make it fixed, or widen the limits)", src, f"{where}/limit")
            if lo < hi and max(abs(lo), abs(hi)) <= MAX_ABS_VALUE:
                limits = (lo, hi)
        # <limit velocity= effort=>: positive values are limits; 0 or below (placeholders seen in real
        # files, which derive does not need), absent or huge: no limit
        rates: dict[str, float | None] = {"velocity": None, "effort": None}
        if jtype in ("revolute", "prismatic", "continuous") and lim is not None:
            for key in rates:
                if lim.get(key) is not None:
                    x = _number_attr(lim, key, src, f"{where}/limit", bound=False)
                    if 0 < x <= MAX_ABS_VALUE:
                        rates[key] = x
        joints.append(
            dict(
                name=name, type=jtype, parent=parent.get("link"), child=child.get("link"),
                xyz=xyz, rpy=list(rpy), rpy_deg=[None] * 3, axis=axis, limits=limits, mimic=mimic, frozen=None,
                max_velocity=rates["velocity"], max_effort=rates["effort"],
            )
        )
    for j in joints:
        for role in ("parent", "child"):
            if j[role] not in links:
                raise DescriptionError(f"{role} link '{j[role]}' is not defined", src, f"joint[{j['name']}]")
    return links, joints


def _read_inertial(el, src: str, where: str):
    """(mass, xyz, rpy, inertia6) from <inertial>, checking every value is present."""
    if el is None:
        return None
    mass_el = el.find("mass")
    if mass_el is None:
        raise DescriptionError("missing <mass>", src, where)
    mass = _number_attr(mass_el, "value", src, f"{where}/mass")
    if mass < 0:
        raise DescriptionError(f"negative mass {mass}", src, f"{where}/mass")
    inertia_el = el.find("inertia")
    if inertia_el is None:
        raise DescriptionError("missing <inertia>", src, where)
    inertia = [_number_attr(inertia_el, k, src, f"{where}/inertia") for k in INERTIA_KEYS]
    origin = el.find("origin")
    xyz = [float(x) for x in _floats(origin.get("xyz") if origin is not None else None, 3, src, f"{where}/origin@xyz", "0 0 0")]
    rpy = [float(x) for x in _floats(origin.get("rpy") if origin is not None else None, 3, src, f"{where}/origin@rpy", "0 0 0")]
    return mass, xyz, rpy, inertia
