"""Platform YAML (hexapods, the 3-3 dodekapod, the free 12-leg truss) -> PlatformDescription.

Schema (docs/platform.md has the full page)::

    kind: platform                 # required: marks the file as a platform, not an arm
    name: Dodekapod, Dang (2013)
    units: {length: mm, angle: deg}
    base:                          # nodes by radius and polar angles ...
      radius: 90
      angles: [90, 210, 330]
      names: [B1, B2, B3]          # optional, default B1, B2, ...
    platform:                      # ... or by explicit coordinates in the platform frame
      nodes: {P1: [0, 81, 0], P2: [70.1, 40.5, 0], P3: [-70.1, 40.5, 0]}
    legs:                          # pairs of nodes; six for a base and a platform
      - [B1, P2]
      - {name: L2, nodes: [B1, P3], limits: [150, 300]}
    leg_limits: [150, 300]         # optional: limits of every leg that gives none
    workspace: {x: [-150, 150], y: [-150, 150], z: [0, 300], roll: [-10, 10]}   # optional box

A free truss (the general dodekapod, 12 DOF) has ``nodes`` instead of
``base`` and ``platform``: six nodes and twelve legs on the edges of an
octahedron.  Lengths keep the file's unit; angles are stored in radians.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from minparam_cli.describe.angles import parse_angle
from minparam_cli.safety import finite_number, key_list, read_yaml, short_repr
from minparam_cli.errors import DescriptionError

LENGTH_UNITS = ("mm", "cm", "m")
ANGLE_UNITS = ("deg", "rad")
TOP_KEYS = {"kind", "name", "description", "units", "base", "platform", "nodes", "legs", "leg_limits", "workspace",
            "dynamics"}  # dynamics: the inertial data of the legs and platform (describe/platform_chain.py)
SIDE_KEYS = {"radius", "angles", "names", "nodes"}
LEG_KEYS = {"name", "nodes", "limits"}
BOX_KEYS = ("x", "y", "z", "roll", "pitch", "yaw")
MAX_NODES = 64


@dataclass(frozen=True)
class LegRecord:
    """One leg: the nodes it joins (base node first for a platform) and its length limits."""

    name: str
    base: str
    platform: str
    limits: tuple[float, float] | None


@dataclass(frozen=True)
class PlatformDescription:
    """A parallel platform or a free truss, as read from the file.

    ``structure`` is "platform" (base frame + moving platform frame) or
    "truss" (six free nodes, coordinates in ``base_coords``, no platform).
    ``workspace`` maps the keys of :data:`BOX_KEYS` present in the file to
    (low, high), angles in radians.
    """

    name: str
    source: str
    structure: str
    base_names: tuple[str, ...]
    base_coords: tuple[tuple[float, float, float], ...]
    platform_names: tuple[str, ...]
    platform_coords: tuple[tuple[float, float, float], ...]
    legs: tuple[LegRecord, ...]
    length_unit: str
    angle_unit: str
    workspace: tuple[tuple[str, tuple[float, float]], ...] = ()


def load_platform(path: Path) -> PlatformDescription:
    """Read and validate a platform YAML file."""
    return platform_from_mapping(read_yaml(Path(path)), str(path))


def platform_from_mapping(doc: Any, src: str) -> PlatformDescription:
    """Validate a parsed YAML document and build the description record."""
    if not isinstance(doc, dict):
        raise DescriptionError("expected a mapping with 'kind: platform', 'units' and 'legs'", src)
    if doc.get("kind") != "platform":
        got = "missing" if "kind" not in doc else short_repr(doc.get("kind"))
        raise DescriptionError(f"expected 'kind: platform' ({got}); arm tables are read by 'derive'", src, "kind")
    unknown = set(doc) - TOP_KEYS
    if unknown:
        raise DescriptionError(f"unknown key(s) {key_list(unknown)}", src)
    has_sides = "base" in doc or "platform" in doc
    if has_sides and "nodes" in doc:
        raise DescriptionError("give either 'base' and 'platform' or 'nodes' (a free truss), not both", src)
    if not has_sides and "nodes" not in doc:
        raise DescriptionError(
            "missing nodes: expected 'base' and 'platform' (a hexapod or 3-3 dodekapod) or 'nodes' (a 12-leg truss)",
            src,
        )
    structure = "platform" if has_sides else "truss"
    for key in ("units", "legs") + (("base", "platform") if has_sides else ()):
        if key not in doc:
            raise DescriptionError(f"missing required field '{key}'", src)
    length_unit, angle_unit = _units(doc["units"], src, need_angle=structure == "platform")
    name = _name(doc.get("name"), src, "name") if doc.get("name") not in (None, "") else Path(src).stem

    if structure == "platform":
        bnames, bcoords = _side(doc["base"], "base", "B", angle_unit, src)
        pnames, pcoords = _side(doc["platform"], "platform", "P", angle_unit, src)
        clash = set(bnames) & set(pnames)
        if clash:
            raise DescriptionError(f"node name(s) {sorted(clash)} used on both base and platform", src, "platform")
        _check_spread(bcoords, src, "base")
        _check_spread(pcoords, src, "platform")
    else:
        bnames, bcoords = _explicit(doc["nodes"], src, "nodes")
        _check_distinct(bnames, bcoords, src)
        pnames, pcoords = (), ()

    default_limits = None
    if doc.get("leg_limits") is not None:
        default_limits = _limits(doc["leg_limits"], src, "leg_limits")
    legs = _legs(doc["legs"], structure, bnames, pnames, default_limits, src)
    if structure == "platform":
        used = {leg.base for leg in legs} | {leg.platform for leg in legs}
        for n in list(bnames) + list(pnames):
            if n not in used:
                raise DescriptionError(f"node {n!r} is not joined by any leg", src, "legs")
    else:
        _check_octahedron(bnames, legs, src)
    workspace = _workspace(doc.get("workspace"), angle_unit, src)
    return PlatformDescription(
        name=name,
        source=src,
        structure=structure,
        base_names=bnames,
        base_coords=bcoords,
        platform_names=pnames,
        platform_coords=pcoords,
        legs=legs,
        length_unit=length_unit,
        angle_unit=angle_unit or "rad",
        workspace=workspace,
    )


# ---------------------------------------------------------------- pieces


def _units(units, src, need_angle):
    if not isinstance(units, dict):
        raise DescriptionError("expected a mapping like {length: mm, angle: deg}", src, "units")
    unknown = set(units) - {"length", "angle"}
    if unknown:
        raise DescriptionError(f"unknown key(s) {key_list(unknown)}", src, "units")
    if "length" not in units:
        raise DescriptionError(f"missing 'length' (one of {', '.join(LENGTH_UNITS)})", src, "units")
    lu = units["length"]
    if not isinstance(lu, str) or lu not in LENGTH_UNITS:
        raise DescriptionError(f"unknown length unit {short_repr(lu)}; expected one of {', '.join(LENGTH_UNITS)}", src, "units.length")
    au = units.get("angle")
    if au is None and need_angle:
        raise DescriptionError("missing 'angle' (deg or rad): poses and polar angles need it", src, "units")
    if au is not None and (not isinstance(au, str) or au not in ANGLE_UNITS):
        raise DescriptionError(f"unknown angle unit {short_repr(au)}; expected 'deg' or 'rad'", src, "units.angle")
    return lu, au


def _number(value, src, where) -> float:
    return finite_number(value, src, where)


def _name(value, src, where) -> str:
    """A node or leg name: text or a number, at most 64 characters."""
    if isinstance(value, bool) or not isinstance(value, (str, int, float)) or len(str(value)) > 64:
        raise DescriptionError(f"expected a name (text of at most 64 characters), got {short_repr(value)}", src, where)
    return str(value)


def _angle(value, angle_unit, src, where) -> float:
    """An angle in the file's unit, or an expression like '7*pi/6' (radians only) -> radians."""
    return parse_angle(value, angle_unit, src, where)[0]


def _vector(value, src, where, n=3) -> tuple[float, ...]:
    if not isinstance(value, (list, tuple)) or len(value) != n:
        raise DescriptionError(f"expected a list of {n} numbers, got {short_repr(value)}", src, where)
    return tuple(_number(v, src, f"{where}[{i}]") for i, v in enumerate(value))


def _explicit(nodes, src, where):
    if not isinstance(nodes, dict) or not nodes:
        raise DescriptionError("expected a mapping of node names to [x, y, z]", src, where)
    if len(nodes) > MAX_NODES:
        raise DescriptionError(f"{len(nodes)} nodes exceed the limit of {MAX_NODES}", src, where)
    names = tuple(_name(k, src, where) for k in nodes)
    coords = tuple(_vector(v, src, f"{where}.{k}") for k, v in nodes.items())
    return names, coords


def _side(spec, side, prefix, angle_unit, src):
    if not isinstance(spec, dict):
        raise DescriptionError("expected a mapping with 'radius' and 'angles', or 'nodes'", src, side)
    unknown = set(spec) - SIDE_KEYS
    if unknown:
        raise DescriptionError(f"unknown key(s) {key_list(unknown)}", src, side)
    if "nodes" in spec:
        extra = {"radius", "angles", "names"} & set(spec)
        if extra:
            raise DescriptionError(f"give either 'nodes' or 'radius' and 'angles', not both ({sorted(extra)})", src, side)
        return _explicit(spec["nodes"], src, f"{side}.nodes")
    for key in ("radius", "angles"):
        if key not in spec:
            raise DescriptionError(f"missing required field '{key}' (or give explicit 'nodes')", src, side)
    radius = _number(spec["radius"], src, f"{side}.radius")
    if radius <= 0:
        raise DescriptionError(f"radius must be positive, got {radius:g}", src, f"{side}.radius")
    angles = spec["angles"]
    if not isinstance(angles, list) or not angles:
        raise DescriptionError("expected a non-empty list of polar angles", src, f"{side}.angles")
    if len(angles) > MAX_NODES:
        raise DescriptionError(f"{len(angles)} nodes exceed the limit of {MAX_NODES}", src, f"{side}.angles")
    rad = [_angle(a, angle_unit, src, f"{side}.angles[{i}]") for i, a in enumerate(angles)]
    names = spec.get("names")
    if names is None:
        names = [f"{prefix}{i + 1}" for i in range(len(rad))]
    if not isinstance(names, list) or len(names) != len(rad):
        raise DescriptionError(f"expected a list of {len(rad)} node names, one per angle", src, f"{side}.names")
    names = [_name(n, src, f"{side}.names") for n in names]
    if len(set(names)) != len(names):
        raise DescriptionError("node names must be unique", src, f"{side}.names")
    coords = tuple((radius * math.cos(a), radius * math.sin(a), 0.0) for a in rad)
    return tuple(names), coords


def _check_spread(coords, src, side):
    """At least three nodes, not all on one line (else the pose is not fixed by the legs)."""
    if len(coords) < 3:
        raise DescriptionError(f"needs at least 3 nodes, got {len(coords)}", src, side)
    import numpy as np

    c = np.array(coords)
    span = c - c.mean(axis=0)
    sv = np.linalg.svd(span, compute_uv=False)
    if sv[1] <= 1e-9 * max(sv[0], 1e-300):
        raise DescriptionError(f"the nodes are collinear (singular values {sv[0]:.3g}, {sv[1]:.3g})", src, side)


def _check_distinct(names, coords, src):
    """A truss's nodes are one frame's points: two at the same place (within 1e-9 of the nodes' extent)
    would give a leg of no length and an octahedron without a shape."""
    import numpy as np

    c = np.array(coords, dtype=float)
    tol = 1e-9 * max(float(np.ptp(c, axis=0).max()) if len(c) else 0.0, 1e-300)
    d = np.linalg.norm(c[:, None, :] - c[None, :, :], axis=2)
    i, j = np.nonzero(np.triu(d <= tol, k=1))
    if len(i):
        raise DescriptionError(f"nodes {names[i[0]]!r} and {names[j[0]]!r} are at the same place {list(coords[i[0]])}", src, "nodes")


def _limits(value, src, where) -> tuple[float, float]:
    lo, hi = _vector(value, src, where, n=2)
    if lo < 0:
        raise DescriptionError(f"lower limit {lo:g} is negative", src, where)
    if not lo < hi:
        raise DescriptionError(f"lower limit {lo:g} is not below upper limit {hi:g}", src, where)
    return lo, hi


def _legs(items, structure, bnames, pnames, default_limits, src):
    if not isinstance(items, list) or not items:
        raise DescriptionError("expected a non-empty list of legs", src, "legs")
    want = 6 if structure == "platform" else 12
    if len(items) != want:
        what = "a base and a platform need six legs (six degrees of freedom)" if want == 6 else (
            "a free truss needs twelve legs (an octahedron)")
        raise DescriptionError(f"{what}, got {len(items)}", src, "legs")
    legs, seen_pairs, seen_names = [], set(), set()
    for i, item in enumerate(items):
        where = f"legs[{i + 1}]"
        name, limits = f"L{i + 1}", default_limits
        if isinstance(item, dict):
            unknown = set(item) - LEG_KEYS
            if unknown:
                raise DescriptionError(f"unknown key(s) {key_list(unknown)}", src, where)
            if "nodes" not in item:
                raise DescriptionError("missing required field 'nodes'", src, where)
            name = _name(item.get("name", name), src, f"{where}.name")
            if item.get("limits") is not None:
                limits = _limits(item["limits"], src, f"{where}.limits")
            pair = item["nodes"]
        else:
            pair = item
        if not isinstance(pair, (list, tuple)) or len(pair) != 2:
            raise DescriptionError(f"expected a pair of node names, got {short_repr(pair)}", src, where)
        a, b = _name(pair[0], src, where), _name(pair[1], src, where)
        known = set(bnames) | set(pnames)
        for n in (a, b):
            if n not in known:
                raise DescriptionError(f"unknown node {n!r}", src, where)
        if a == b:
            raise DescriptionError(f"a leg joins two different nodes, got {a!r} twice", src, where)
        if structure == "platform":
            if (a in bnames) == (b in bnames):
                side = "base" if a in bnames else "platform"
                raise DescriptionError(f"leg {a}-{b} joins two {side} nodes; a leg joins base to platform", src, where)
            if a in pnames:
                a, b = b, a
        key = frozenset((a, b))
        if key in seen_pairs:
            raise DescriptionError(f"nodes {a!r} and {b!r} are joined twice", src, where)
        if name in seen_names:
            raise DescriptionError(f"leg name {name!r} is used twice", src, where)
        seen_pairs.add(key)
        seen_names.add(name)
        legs.append(LegRecord(name=name, base=a, platform=b, limits=limits))
    return tuple(legs)


def _check_octahedron(names, legs, src):
    if len(names) != 6:
        raise DescriptionError(f"a free truss needs six nodes (an octahedron), got {len(names)}", src, "nodes")
    degree = {n: 0 for n in names}
    for leg in legs:
        degree[leg.base] += 1
        degree[leg.platform] += 1
    for n, d in degree.items():
        if d != 4:
            raise DescriptionError(
                f"node {n!r} has {d} legs; an octahedral truss joins each node to four others", src, "legs"
            )


def _workspace(spec, angle_unit, src):
    if spec is None:
        return ()
    if not isinstance(spec, dict):
        raise DescriptionError("expected a mapping like {x: [-100, 100], z: [0, 300]}", src, "workspace")
    unknown = set(spec) - set(BOX_KEYS)
    if unknown:
        raise DescriptionError(f"unknown key(s) {key_list(unknown)}", src, "workspace")
    out = []
    for key in BOX_KEYS:
        if key not in spec:
            continue
        where = f"workspace.{key}"
        v = spec[key]
        if not isinstance(v, (list, tuple)) or len(v) != 2:
            raise DescriptionError(f"expected [low, high], got {short_repr(v)}", src, where)
        if key in ("roll", "pitch", "yaw"):
            lo, hi = (_angle(x, angle_unit or "rad", src, where) for x in v)
        else:
            lo, hi = (_number(x, src, where) for x in v)
        if lo > hi:
            raise DescriptionError(f"low {v[0]} is above high {v[1]}", src, where)
        out.append((key, (lo, hi)))
    return tuple(out)
