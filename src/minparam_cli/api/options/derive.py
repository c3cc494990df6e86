"""``minparam derive``'s options: what is computed for each robot file."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Iterable

from minparam_cli.api.common import OptionError, choice_option, float_option, friction_option
from minparam_cli.describe.records import MIMIC_MODES

METHODS = ("qr", "projection")


@dataclass(frozen=True)
class DeriveOptions:
    """The options of ``minparam derive`` / ``minparam.derive``, checked on construction (one
    ``OptionError`` naming the flag, exit code 2).  ``friction`` and ``gravity`` take the command
    line's text ("coulomb,viscous", "0,0,-9.81") or sequences, and hold tuples."""

    method: str = "qr"  # "qr" (random samples + QR) or "projection" (Krutikov, exact)
    friction: tuple[str, ...] = ()  # any of coulomb, viscous, offset, on every joint
    rotor_inertia: bool = False
    gravity: tuple[float, float, float] | None = None  # m/s², overrides the file
    samples: int = 100  # random states of the QR method
    seed: int = 0
    symbolic: bool = False  # regrouping coefficients in the geometry symbols
    symbolic_numbers: bool = False  # ... with the file's lengths as exact numbers
    snap_angles: float | None = None  # rad: round angles this close to a multiple of 15°
    mimic: str = "coupled"  # URDF mimic joints: coupled or fixed
    floating_base: bool = False  # the URDF's root link is free

    def __post_init__(self) -> None:
        put = object.__setattr__  # normalising a field of this record while it is being built
        put(self, "method", choice_option(self.method, METHODS, "--method"))
        put(self, "friction", friction_option(_text(self.friction)))
        if self.samples < 1:
            raise OptionError("--samples", "must be positive")
        if self.gravity is not None:
            g = float_option(self.gravity, 3, "--gravity")
            put(self, "gravity", (g[0], g[1], g[2]))
        if self.snap_angles is not None:
            from minparam_cli.describe.snap import MAX_TOLERANCE

            if not 0.0 < self.snap_angles < MAX_TOLERANCE:
                raise OptionError("--snap-angles", f"must be a tolerance in radians in (0, {MAX_TOLERANCE:.4g}) (half of 15°), got {self.snap_angles:g}")
        if self.seed < 0:
            raise OptionError("--seed", f"must be >= 0, got {self.seed}")
        put(self, "mimic", choice_option(self.mimic, MIMIC_MODES, "--mimic"))
        put(self, "rotor_inertia", bool(self.rotor_inertia))
        put(self, "symbolic", bool(self.symbolic))
        put(self, "symbolic_numbers", bool(self.symbolic_numbers))
        put(self, "floating_base", bool(self.floating_base))

    def stage(self):
        """The record the loader and the stages take (``robot.DeriveOptions``)."""
        from minparam_cli.robot import DeriveOptions as StageOptions

        return StageOptions(self.method, self.friction, self.rotor_inertia, self.gravity, self.samples, self.seed,
                            self.symbolic or None, self.snap_angles, mimic=self.mimic, floating_base=self.floating_base,
                            symbolic_numbers=self.symbolic_numbers)


def _text(value: Any) -> str | Iterable[str] | None:
    return value if value is None or isinstance(value, str) else [str(k) for k in value]
