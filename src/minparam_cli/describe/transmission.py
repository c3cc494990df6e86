"""The ``transmission:`` block of a robot description (YAML table, or a URDF's side file).

Schema (docs/methods/transmission.md has the equations)::

    transmission:
      ratios: [32, 32, 45, -48, 45, 32]   # diagonal of N: motor turns per joint turn (non-zero)
      coupling: [[6, 5, 32]]              # optional off-diagonal entries [motor, joint, N_kj], 1-based
      # matrix: [[...], ...]              # or N in full, row k = motor k (instead of ratios/coupling)
      zero: [0, -pi/2, pi/2, 0, 0, 0]     # joint coordinates where every motor reads 0 (file's units)
      motor_friction: [coulomb, viscous]  # friction on the motor speed (N qd)_k
      motor_inertia: true                 # motor rotor inertia on (N qdd)_k
      motors: [6]                         # the motors that get these columns (default: every motor)
      drive_gains: [0.9, ...]             # motor torque per unit of current signal, > 0 (identify --current)

with theta_m = N (q - zero) and tau_joint = Nᵀ tau_m.  N must be square (one motor per independent
joint coordinate), finite and invertible; anything else is one line naming the field.

A URDF has no place for this: ``ROBOT.transmission.yaml`` beside ``ROBOT.urdf`` holds the same
block (``transmission:`` at the top, optional ``units: {angle: deg}`` for ``zero``).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from minparam_cli.describe.records import Transmission
from minparam_cli.safety import finite_number, key_list, read_yaml, short_repr
from minparam_cli.errors import DescriptionError
from minparam_cli.params import MOTOR_FRICTION_KINDS, MOTOR_KINDS

KEYS = {"ratios", "coupling", "matrix", "zero", "motor_friction", "motor_inertia", "motors", "drive_gains"}
# N is refused as singular when its smallest singular value is below this share of its largest
SINGULAR_RTOL = 1e-10
SIDE_SUFFIX = ".transmission.yaml"


def side_file(urdf: Path) -> Path:
    """Where a URDF's transmission lives: ``robot.transmission.yaml`` beside ``robot.urdf``."""
    return urdf.with_name(urdf.name[: -len(urdf.suffix)] + SIDE_SUFFIX) if urdf.suffix else urdf.with_name(urdf.name + SIDE_SUFFIX)


def load_side_file(urdf: Path, types: tuple[str, ...]) -> Transmission | None:
    """The transmission of a URDF from its side file, None when there is none."""
    path = side_file(Path(urdf))
    if not path.exists():
        return None
    doc = read_yaml(path)
    src = str(path)
    if not isinstance(doc, dict) or "transmission" not in doc:
        raise DescriptionError("expected a mapping with 'transmission' (and optional 'units')", src)
    unknown = set(doc) - {"transmission", "units"}
    if unknown:
        raise DescriptionError(f"unknown key(s) {key_list(unknown)}", src)
    units = doc.get("units") or {}
    if not isinstance(units, dict) or set(units) - {"angle", "length"}:
        raise DescriptionError("expected a mapping like {angle: deg, length: mm}", src, "units")
    angle = units.get("angle", "rad")
    length = units.get("length", "m")
    if angle not in ("rad", "deg") or length not in ("m", "mm"):
        raise DescriptionError(f"unknown units {short_repr(units)}; expected angle rad|deg, length m|mm", src, "units")
    return parse_transmission(doc["transmission"], types, angle, 1.0 if length == "m" else 1e-3, src)


def parse_transmission(v: Any, types: tuple[str, ...], angle_unit: str, length_scale: float, src: str) -> Transmission:
    """Validate a ``transmission:`` mapping for joints of ``types`` (revolute|prismatic)."""
    from minparam_cli.describe.angles import parse_angle

    where = "transmission"
    n = len(types)
    if not isinstance(v, dict):
        raise DescriptionError("expected a mapping with 'ratios' (and 'coupling') or 'matrix'", src, where)
    unknown = set(v) - KEYS
    if unknown:
        raise DescriptionError(f"unknown key(s) {key_list(unknown)}", src, where)
    if "matrix" in v:
        if "ratios" in v or "coupling" in v:
            raise DescriptionError("give either 'matrix' or 'ratios' (with 'coupling'), not both", src, where)
        N = _matrix(v["matrix"], n, src, f"{where}.matrix")
    elif "ratios" in v:
        N = np.diag(_numbers(v["ratios"], n, src, f"{where}.ratios"))
        if np.any(np.diag(N) == 0):
            k = int(np.flatnonzero(np.diag(N) == 0)[0]) + 1
            raise DescriptionError(f"gear ratio of motor {k} is 0: a motor that does not move its joint", src, f"{where}.ratios")
        for i, entry in enumerate(_list(v.get("coupling", []), src, f"{where}.coupling")):
            w = f"{where}.coupling[{i + 1}]"
            if not isinstance(entry, list) or len(entry) != 3:
                raise DescriptionError(f"expected [motor, joint, value], got {short_repr(entry)}", src, w)
            k, j = (_index(x, n, src, w) for x in entry[:2])
            if k == j:
                raise DescriptionError(f"[{k + 1}, {j + 1}, ...] is a diagonal entry: give it in 'ratios'", src, w)
            N[k, j] = finite_number(entry[2], src, w)
    else:
        raise DescriptionError("missing 'ratios' (or 'matrix'): the gear ratio of every motor", src, where)
    check_matrix(N, src, where)
    zero = np.zeros(n)
    if v.get("zero") is not None:
        raw = _list(v["zero"], src, f"{where}.zero")
        if len(raw) != n:
            raise DescriptionError(f"expected {n} values (one per joint), got {len(raw)}", src, f"{where}.zero")
        for j, x in enumerate(raw):
            if types[j] == "revolute":
                zero[j] = parse_angle(x, angle_unit, src, f"{where}.zero")[0]
            else:
                zero[j] = finite_number(x, src, f"{where}.zero") * length_scale
    kinds: list[str] = []
    friction = v.get("motor_friction", [])
    if isinstance(friction, str):
        friction = [s.strip() for s in friction.split(",") if s.strip()]
    for f in _list(friction, src, f"{where}.motor_friction"):
        if not isinstance(f, str) or f not in MOTOR_FRICTION_KINDS:
            raise DescriptionError(f"unknown motor friction {short_repr(f)}; expected any of {list(MOTOR_FRICTION_KINDS)}", src,
                                   f"{where}.motor_friction")
        kinds.append(MOTOR_FRICTION_KINDS[f])
    inertia = v.get("motor_inertia", False)
    if not isinstance(inertia, bool):
        raise DescriptionError(f"expected true or false, got {short_repr(inertia)}", src, f"{where}.motor_inertia")
    if inertia:
        kinds.append("motor_inertia")
    motors = set(range(n))
    if v.get("motors") is not None:
        motors = {_index(x, n, src, f"{where}.motors") for x in _list(v["motors"], src, f"{where}.motors")}
    ordered = tuple(k for k in MOTOR_KINDS if k in kinds)
    extras = tuple(ordered if k in motors else () for k in range(n))
    gains = None
    if v.get("drive_gains") is not None:
        gains = tuple(float(g) for g in _numbers(v["drive_gains"], n, src, f"{where}.drive_gains"))
        check_gains(gains, src, f"{where}.drive_gains")
    return Transmission(tuple(tuple(float(x) for x in row) for row in N), tuple(float(z) for z in zero), extras, gains)


def check_matrix(N: np.ndarray, src: str, where: str) -> None:
    """Refuse a coupling matrix that is not square, not finite or not invertible (one line)."""
    if N.ndim != 2 or N.shape[0] != N.shape[1]:
        raise DescriptionError(f"the coupling matrix must be square (one motor per joint), got shape {N.shape}", src, where)
    if not np.all(np.isfinite(N)):
        raise DescriptionError("the coupling matrix has a value that is not finite", src, where)
    s = np.linalg.svd(N, compute_uv=False)
    if s[0] == 0 or s[-1] <= SINGULAR_RTOL * s[0]:
        rel = 0.0 if s[0] == 0 else s[-1] / s[0]
        raise DescriptionError(f"the coupling matrix is singular (smallest singular value {rel:.3g} of the largest): "
                               "the motors cannot move every joint independently", src, where)


def check_gains(gains, src: str, where: str) -> None:
    for k, g in enumerate(gains):
        if not (math.isfinite(g) and g > 0):
            raise DescriptionError(f"drive gain of motor {k + 1} is {g:g}: a gain must be positive", src, where)


def parse_joint_gains(v: Any, n: int, src: str, where: str) -> tuple[float, ...]:
    """The top-level ``drive_gains: [k1, ..., kn]`` of a YAML robot: joint torque per unit of current
    signal, tau_j = k_j i_j (joint angles with motor currents, no transmission needed), each > 0."""
    items = _list(v, src, where)
    if len(items) != n:
        raise DescriptionError(f"expected {n} numbers (one per joint), got {len(items)}", src, where)
    gains = tuple(finite_number(x, src, where) for x in items)
    for j, g in enumerate(gains):
        if not g > 0:
            raise DescriptionError(f"drive gain of joint {j + 1} is {g:g}: a gain must be positive", src, where)
    return gains


def _list(v: Any, src: str, where: str) -> list:
    if not isinstance(v, list):
        raise DescriptionError(f"expected a list, got {short_repr(v)}", src, where)
    return v


def _numbers(v: Any, n: int, src: str, where: str) -> np.ndarray:
    items = _list(v, src, where)
    if len(items) != n:
        raise DescriptionError(f"expected {n} numbers (one per motor), got {len(items)}", src, where)
    return np.array([finite_number(x, src, where) for x in items], dtype=float)


def _matrix(v: Any, n: int, src: str, where: str) -> np.ndarray:
    rows = _list(v, src, where)
    if any(not isinstance(r, list) for r in rows):
        raise DescriptionError("expected a list of rows (lists of numbers)", src, where)
    widths = {len(r) for r in rows}
    if len(widths) != 1 or len(rows) != widths.pop() or len(rows) == 0:
        shape = f"{len(rows)} rows of {sorted({len(r) for r in rows})} numbers"
        raise DescriptionError(f"the coupling matrix must be square (one motor per joint), got {shape}", src, where)
    if len(rows) != n:
        raise DescriptionError(f"expected a {n}x{n} matrix (one motor per joint), got {len(rows)}x{len(rows)}", src, where)
    return np.array([[finite_number(x, src, where) for x in r] for r in rows], dtype=float)


def _index(v: Any, n: int, src: str, where: str) -> int:
    if isinstance(v, bool) or not isinstance(v, int) or not 1 <= v <= n:
        raise DescriptionError(f"expected a motor or joint number 1..{n}, got {short_repr(v)}", src, where)
    return v - 1
