"""Angles in description files: numbers in the file's unit, or multiples of pi as text ('-pi/2',
'7*pi/6') under ``units: {angle: rad}``, with the exact value in degrees kept for the symbolic route.
One parser for robot files, transmissions and platform files."""

from __future__ import annotations

import math
import re
from fractions import Fraction
from typing import Any

from minparam_cli.safety import MAX_ABS_VALUE, finite_number, short_repr
from minparam_cli.errors import DescriptionError

_PI_RE = re.compile(r"^\s*([+-]?(?:\d+(?:\.\d*)?|\.\d+)?)\s*\*?\s*pi\s*(?:/\s*(\d+(?:\.\d*)?))?\s*$")


def parse_angle(v: Any, unit: str, src: str, where: str) -> tuple[float, Fraction | None]:
    """Angle -> (radians, exact degrees or None).  Accepts numbers, and 'pi/2'-style strings under
    ``angle: rad`` (under ``angle: deg`` they are refused: the file would mix two angle units)."""
    if isinstance(v, str):
        m = _PI_RE.match(v) if len(v) <= 64 else None
        if not m:
            raise DescriptionError(f"expected a number or an expression like '-pi/2' or '7*pi/6', got {short_repr(v)}", src, where)
        coef = m.group(1)
        num = Fraction(coef) if coef not in ("", "+", "-") else Fraction(-1 if coef == "-" else 1)
        den = Fraction(m.group(2)) if m.group(2) else Fraction(1)
        if den == 0:
            raise DescriptionError(f"division by zero in {v!r}", src, where)
        deg = num / den * 180
        if abs(deg) > MAX_ABS_VALUE:
            raise DescriptionError(f"{v!r} is out of range: expected at most {MAX_ABS_VALUE:g} degrees", src, where)
        if unit == "deg":  # a multiple of pi is a value in radians: one file, one angle unit
            raise DescriptionError(f"{v!r} is in radians, but units.angle is 'deg'; write {float(deg):g} "
                                   "or set units: {angle: rad}", src, where)
        return float(deg) * math.pi / 180, deg
    x = finite_number(v, src, where)
    if unit == "deg":
        return math.radians(x), Fraction(repr(x))
    # radians given as a plain number: exact only when zero
    return x, (Fraction(0) if x == 0 else None)
