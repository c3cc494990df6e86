"""The constant transforms of every joint, (Pre, axis, Post) of ``chain.py``'s frame convention,
from a description's records (DH/MDH rows or URDF origins), in float or exact arithmetic: the
elementary transforms are generic over float and Fraction entries; exact arithmetic holds for
rational lengths and angles at multiples of 90 deg (``exact_matrices``), else ``NotExact``."""

from __future__ import annotations

from collections.abc import Sequence
from fractions import Fraction
from typing import Any, Protocol

import numpy as np

from minparam_cli.describe.records import GeomValue, RobotDescription


# --- elementary transforms, generic over float and Fraction entries ---------


def _eye(one, zero):
    return [[one if i == k else zero for k in range(4)] for i in range(4)]


def _rot(axis: int, c, s, one, zero):
    m = _eye(one, zero)
    i, k = [(1, 2), (2, 0), (0, 1)][axis]
    m[i][i], m[i][k], m[k][i], m[k][k] = c, -s, s, c
    return m


def _trans(v, one, zero):
    m = _eye(one, zero)
    for i in range(3):
        m[i][3] = v[i]
    return m


def _mul(a, b, zero):
    return [[sum((a[i][k] * b[k][j] for k in range(4)), zero) for j in range(4)] for i in range(4)]


def _chain_mul(mats, one, zero):
    out = _eye(one, zero)
    for m in mats:
        out = _mul(out, m, zero)
    return out


def exact_cos_sin(deg: Fraction) -> tuple[Fraction, Fraction] | None:
    """cos and sin of an angle in degrees, when both are rational (multiples of 90 deg)."""
    if deg.denominator != 1 or deg.numerator % 90:
        return None
    return [(Fraction(1), Fraction(0)), (Fraction(0), Fraction(1)), (Fraction(-1), Fraction(0)), (Fraction(0), Fraction(-1))][
        (deg.numerator // 90) % 4
    ]


class Numbers:
    """Accessors turning GeomValues into float or exact numbers."""

    def __init__(self, exact: bool, values: dict[str, float] | None):
        self.exact = exact
        self.values = values or {}
        self.one = Fraction(1) if exact else 1.0
        self.zero = Fraction(0) if exact else 0.0

    def length(self, g: GeomValue):
        if g.symbol in self.values:
            return self.values[g.symbol]
        if self.exact:
            if g.exact is None:
                raise NotExact
            return g.exact
        return g.value

    def cos_sin(self, g: GeomValue):
        if g.symbol in self.values:
            v = self.values[g.symbol]
            return np.cos(v), np.sin(v)
        if self.exact:
            cs = exact_cos_sin(g.exact) if g.exact is not None else None
            if cs is None:
                raise NotExact
            return cs
        return np.cos(g.value), np.sin(g.value)


class NotExact(Exception):
    """The geometry has a value that is not exact (an irrational length, an angle off 90° multiples, ...)."""


class NumberAccess(Protocol):
    """What ``joint_matrices`` asks of its arithmetic: ``Numbers``, or the symbolic route's own."""

    exact: bool
    one: Any
    zero: Any

    def length(self, g: GeomValue) -> Any: ...

    def cos_sin(self, g: GeomValue) -> tuple[Any, Any]: ...


class JointRows(Protocol):
    """What ``joint_matrices`` reads of a joint record (``JointRecord``, or a view of one)."""

    @property
    def type(self) -> str: ...
    @property
    def dh(self) -> dict[str, GeomValue] | None: ...
    @property
    def origin(self) -> dict[str, GeomValue] | None: ...
    @property
    def pre_fixed(self) -> tuple[tuple[float, ...], ...] | None: ...
    @property
    def axis(self) -> tuple[float, ...]: ...


class JointsRecords(Protocol):
    """What ``joint_matrices`` reads of a description (``RobotDescription``, or a view of one)."""

    @property
    def convention(self) -> str: ...
    @property
    def joints(self) -> Sequence[JointRows]: ...


def joint_matrices(desc: JointsRecords, num: NumberAccess) -> list[tuple[list[list[Any]], tuple[Any, ...], list[list[Any]]]]:
    """(pre, axis, post) per joint in the arithmetic of ``num``."""
    one, zero = num.one, num.zero
    out = []
    axis: tuple[Any, ...]
    for jr in desc.joints:
        if jr.dh is not None:
            al_c, al_s = num.cos_sin(jr.dh["alpha"])
            th_c, th_s = num.cos_sin(jr.dh["theta"])
            a = num.length(jr.dh["a"])
            d = num.length(jr.dh["d"])
            Rx = _rot(0, al_c, al_s, one, zero)
            Rz = _rot(2, th_c, th_s, one, zero)
            Tx = _trans((a, zero, zero), one, zero)
            Tz = _trans((zero, zero, d), one, zero)
            axis = (zero, zero, one)
            if desc.convention == "mdh":
                pre, post = _chain_mul([Rx, Tx, Rz, Tz], one, zero), _eye(one, zero)
            elif jr.type == "revolute":  # chain.REVOLUTE (chain imports this module)
                pre, post = _eye(one, zero), _chain_mul([Rz, Tz, Tx, Rx], one, zero)
            else:
                pre, post = Rz, _chain_mul([Tz, Tx, Rx], one, zero)
        else:
            o = jr.origin
            assert o is not None  # a joint without DH parameters is a URDF joint, with its origin
            xyz = [num.length(o[k]) for k in ("x", "y", "z")]
            rc, rs = num.cos_sin(o["roll"])
            pc, ps = num.cos_sin(o["pitch"])
            yc, ys = num.cos_sin(o["yaw"])
            origin = _chain_mul(
                [_trans(xyz, one, zero), _rot(2, yc, ys, one, zero), _rot(1, pc, ps, one, zero), _rot(0, rc, rs, one, zero)],
                one,
                zero,
            )
            fixed = jr.pre_fixed
            if fixed is not None:
                if num.exact:
                    raise NotExact
                origin = _mul([list(r) for r in fixed], origin, zero)
            pre, post = origin, _eye(one, zero)
            if num.exact:
                ax = []
                for c in jr.axis:
                    if c not in (0.0, 1.0, -1.0):
                        raise NotExact
                    ax.append(Fraction(int(c)))
                axis = tuple(ax)
            else:
                axis = tuple(jr.axis)
        out.append((pre, axis, post))
    return out


def exact_matrices(desc: RobotDescription) -> tuple | None:
    """(pre, axis, post) per joint as nested tuples of Fraction, or None if the geometry is not exact."""
    try:
        emats = joint_matrices(desc, Numbers(True, None))
    except NotExact:
        return None
    return tuple((tuple(tuple(r) for r in p), tuple(a), tuple(tuple(r) for r in q)) for p, a, q in emats)
