"""``minparam excite``'s options."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from minparam_cli.api.common import choice_option, float_option, friction_option
from minparam_cli.errors import InputError
from minparam_cli.describe.records import MIMIC_MODES

CRITERIA = ("cond", "logdet")
DEFAULT_CLEARANCE = 0.01  # m, --clearance
SCALINGS = ("si", "columns")


@dataclass(frozen=True)
class ExciteOptions:
    """The options of ``minparam excite`` / ``minparam.excite``, checked on construction.

    ``box``: the Cartesian box of the tool point, base frame, m: the command line's
    "XMIN:XMAX,YMIN:YMAX,ZMIN:ZMAX" (a side may be empty) or [[XMIN, XMAX], ...] with None for a free
    side; held as ((min, max),) * 3 with NaN for free sides.  ``point``: X,Y,Z in the last link's frame.
    ``floor``: m; every link frame's origin and the tool point stay at least this high against gravity.
    ``collisions``: keep the robot file's collision shapes (URDF/MJCF, through MuJoCo) ``clearance`` m apart
    (default DEFAULT_CLEARANCE), and off the floor when ``floor`` is given."""

    harmonics: int = 5
    base_frequency: float = 0.1
    rate: float = 200.0
    periods: int = 1
    criterion: str = "cond"
    scaling: str = "si"
    rest: bool = False
    margin: float = 0.1
    friction: tuple[str, ...] = ()
    rotor_inertia: bool = False
    box: Any = None
    point: tuple[float, float, float] | None = None
    floor: float | None = None
    collisions: bool = False
    clearance: float | None = None
    starts: int = 4
    max_iterations: int = 150
    seed: int = 0
    mimic: str = "coupled"

    def __post_init__(self) -> None:
        from minparam_cli.api.excite_box import box_option

        put = object.__setattr__  # normalising a field of this record while it is being built
        if self.seed < 0:
            raise InputError(f"--seed must be >= 0, got {self.seed}")
        put(self, "friction", friction_option(self.friction if isinstance(self.friction, str) or self.friction is None
                                              else [str(k) for k in self.friction]))
        if self.box is not None:
            box = box_option(self.box)
            assert box is not None  # None only for a None box
            put(self, "box", tuple(tuple(float(v) for v in row) for row in box))
        if self.point is not None:
            p = float_option(self.point, 3, "--point")
            put(self, "point", (p[0], p[1], p[2]))
        if self.floor is not None:
            import math

            try:
                f = float(self.floor)
            except (TypeError, ValueError):
                raise InputError(f"--floor: expected a height in m, got {self.floor!r}") from None
            if not math.isfinite(f):
                raise InputError(f"--floor: expected a finite height in m, got {self.floor!r}")
            put(self, "floor", f)
        put(self, "collisions", bool(self.collisions))
        if self.clearance is not None:
            put(self, "clearance", _clearance(self.clearance, self.collisions))
        put(self, "criterion", choice_option(self.criterion, CRITERIA, "--criterion"))
        put(self, "scaling", choice_option(self.scaling, SCALINGS, "--scaling"))
        put(self, "mimic", choice_option(self.mimic, MIMIC_MODES, "--mimic"))
        put(self, "rotor_inertia", bool(self.rotor_inertia))
        self.design()  # the design's own checks (harmonics, rate, margin, ...)

    def design(self):
        """The design stage's options (``experiment.excite.design.ExciteOptions``), checked."""
        from minparam_cli.experiment.excite.design import ExciteOptions as DesignOptions
        from minparam_cli.experiment.excite.design import validate

        opts = DesignOptions(harmonics=int(self.harmonics), base_frequency=float(self.base_frequency), rate=float(self.rate),
                             periods=int(self.periods), criterion=self.criterion, scaled=self.scaling == "columns",
                             starts=int(self.starts), max_iterations=int(self.max_iterations), margin=float(self.margin),
                             rest=bool(self.rest))
        validate(opts)
        _bounded(opts)
        return opts


MAX_STARTS = 10_000  # --starts: each is an optimisation
MAX_SAMPLES = 10**7  # the CSV's samples (periods x rate / base frequency): 2.8 h at 1 kHz


def _bounded(o) -> None:
    """--starts and the CSV's sample count: 1e9 of either ran out of memory (exit 1)."""
    if o.starts > MAX_STARTS:
        raise InputError(f"--starts must be at most {MAX_STARTS}, got {o.starts}")
    samples = o.periods * o.rate / o.base_frequency
    if samples > MAX_SAMPLES:
        raise InputError(f"--periods x --rate / --base-frequency gives {samples:.3g} samples, more than the "
                         f"{MAX_SAMPLES:.0e}-sample limit of the CSV")


def _clearance(value, collisions: bool) -> float:
    """--clearance: a distance in m, in (0, 0.5], only with --collisions."""
    import math

    if not collisions:
        raise InputError("--clearance needs --collisions (it is the distance kept between collision shapes)")
    try:
        c = float(value)
    except (TypeError, ValueError):
        raise InputError(f"--clearance: expected a distance in m, got {value!r}") from None
    if not (math.isfinite(c) and 0 < c <= 0.5):
        raise InputError(f"--clearance: expected a distance in (0, 0.5] m, got {value!r}")
    return c
