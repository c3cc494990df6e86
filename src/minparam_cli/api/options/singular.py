"""``minparam singular``'s options."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from minparam_cli.api.common import OptionError, float_option
from minparam_cli.errors import InputError
from minparam_cli.kinematics.defaults import DEFAULT_DAMPING, DEFAULT_EPSILON, DEFAULT_STEP_DEG


def _joints(value: Any, option: str, count: int | None = None) -> tuple[int, ...]:
    """Joint numbers (from 1) from "2,3" or a sequence."""
    try:
        vals = tuple(int(p) for p in (value.replace(" ", "").split(",") if isinstance(value, str) else value))
    except (TypeError, ValueError):
        raise OptionError(option, f"expected joint numbers like 2,3, got {value!r}") from None
    if count is not None and len(vals) != count:
        raise OptionError(option, f"expected {count} joint numbers, got {len(vals)}")
    if any(v < 1 for v in vals):
        raise OptionError(option, "joints are numbered from 1")
    return vals


@dataclass(frozen=True)
class SingularOptions:
    """The options of ``minparam singular`` / ``minparam.singular``, checked on construction.

    ``q``: joint values, in degrees for revolute joints when ``degrees`` (the command line's default;
    radians with --rad), metres for prismatic joints; ``step`` (--scan's grid) in the same angle
    unit (None: 15°).  ``twist``: wx,wy,wz (rad/s), vx,vy,vz (m/s) of the tool point; ``hold`` and
    ``joints`` (the --plot map's two joints) are numbered from 1."""

    q: tuple[float, ...] | None = None
    twist: tuple[float, ...] | None = None
    degrees: bool = False
    epsilon: float = DEFAULT_EPSILON
    hold: tuple[int, ...] | None = None
    damping: float = DEFAULT_DAMPING
    scan: bool = False
    step: float | None = None
    plot: Path | None = None
    joints: tuple[int, int] | None = None
    symbolic: bool = False
    seed: int = 0
    tool: str | None = None

    def __post_init__(self) -> None:
        put = object.__setattr__  # normalising a field of this record while it is being built
        if self.q is not None:
            put(self, "q", float_option(self.q, None, "--q"))
        if self.twist is not None:
            put(self, "twist", float_option(self.twist, 6, "--twist"))
        if not (math.isfinite(self.epsilon) and 0 < self.epsilon < 1):
            raise OptionError("--epsilon", f"expected a number between 0 and 1 (exclusive), got {self.epsilon:g}")
        if self.hold is not None:
            put(self, "hold", _joints(self.hold, "--hold"))
        if not (math.isfinite(self.damping) and self.damping >= 0):
            raise OptionError("--damping", f"expected a number >= 0, got {self.damping:g}")
        if self.step is not None and not (math.isfinite(self.step) and self.step > 0):
            raise OptionError("--step", f"expected a positive step, got {self.step:g}")
        if self.joints is not None:
            put(self, "joints", _joints(self.joints, "--joints", 2))
        if self.seed < 0:
            raise OptionError("--seed", f"must be >= 0, got {self.seed}")
        if self.plot is not None:
            put(self, "plot", Path(self.plot))
        if self.q is None and (self.twist is not None or self.hold is not None):
            raise InputError("--twist and --hold need a configuration --q")
        if self.q is None and not (self.scan or self.plot or self.symbolic):
            raise InputError("give --q for the local test, or --scan, --plot or --symbolic")

    @property
    def step_rad(self) -> float:
        """--scan's grid step in rad."""
        if self.step is None:
            return math.radians(DEFAULT_STEP_DEG)
        return math.radians(self.step) if self.degrees else self.step
