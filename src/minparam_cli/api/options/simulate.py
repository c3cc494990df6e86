"""``minparam simulate``'s options."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

from minparam_cli.api.common import choice_option
from minparam_cli.errors import InputError
from minparam_cli.describe.records import MIMIC_MODES
from minparam_cli.api.options.identify import SIDES, drive_gains_option



@dataclass(frozen=True)
class SimulateOptions:
    """The options of ``minparam simulate`` / ``minparam.simulate``, checked on construction (the
    checks that need the robot, such as the effects' joints, where it is loaded).

    ``trajectory``: "fourier" (a random series from ``seed``) or an excite output (.json: the
    series; .csv: the samples); ``effects`` in the command line's syntax ("coulomb,viscous,spring@2";
    a list is joined); ``motor_params`` "Fcm6=0.06,..." or a mapping; the payload on the last link:
    ``payload_mass`` (kg), ``payload_com`` X,Y,Z (m), ``payload_inertia`` IXX,IXY,IXZ,IYY,IYZ,IZZ
    about its centre of mass (kg·m²)."""

    trajectory: str = "fourier"
    effects: str = ""
    strength: float = 0.1
    noise: float = 0.0
    noise_q: float = 0.0
    seed: int = 0
    duration: float = 20.0
    rate: float = 200.0
    harmonics: int = 5
    base_frequency: float = 0.1
    random_inertia: bool = False
    ddq: bool = True  # write the ddq columns
    coulomb_smoothing: float = 0.0
    mimic: str = "coupled"
    side: str = "joint"
    current: bool = False
    drive_gains: Any = None  # joint-side gains, tau_j = k_j i_j (--current without --side motor)
    motor_params: str = ""
    payload_mass: float | None = None
    payload_com: Any = None
    payload_inertia: Any = None

    def __post_init__(self) -> None:
        put = object.__setattr__  # normalising a field of this record while it is being built
        if self.seed < 0:
            raise InputError(f"--seed must be >= 0, got {self.seed}")
        put(self, "mimic", choice_option(self.mimic, MIMIC_MODES, "--mimic"))
        side = str(getattr(self.side, "value", self.side))
        if side not in SIDES:
            raise InputError(f"--side: expected joint or motor, got {side!r}")
        put(self, "side", side)
        put(self, "current", bool(self.current))
        put(self, "drive_gains", drive_gains_option(self.drive_gains, self.current))
        if isinstance(self.motor_params, Mapping):
            put(self, "motor_params", ",".join(f"{k}={v}" for k, v in self.motor_params.items()))
        put(self, "motor_params", str(self.motor_params))
        if not isinstance(self.effects, str):
            put(self, "effects", ",".join(self.effects))
        put(self, "trajectory", str(self.trajectory))
        try:  # the CLI's types: a 20 given for a float option is 20.0 in the truth record
            for key in ("duration", "rate", "base_frequency", "strength", "noise", "noise_q", "coulomb_smoothing"):
                put(self, key, float(getattr(self, key)))
            put(self, "harmonics", int(self.harmonics))
        except (TypeError, ValueError) as e:
            raise InputError(f"simulate: expected numbers for duration, rate, harmonics, base_frequency, strength and noise ({e})") from None
        put(self, "random_inertia", bool(self.random_inertia))
        put(self, "ddq", bool(self.ddq))
        self.payload()  # its checks

    def payload(self):
        """The simulated payload (None without a mass)."""
        from minparam_cli.api.common import float_option

        if self.payload_mass is None:
            if self.payload_com is not None or self.payload_inertia is not None:
                raise InputError("--payload-com and --payload-inertia need --payload-mass")
            return None
        from minparam_cli.identify.physical.payload import PayloadSpec, check_spec

        try:
            m = float(self.payload_mass)
        except (TypeError, ValueError):
            raise InputError(f"--payload-mass: expected a number, got {self.payload_mass!r}") from None
        c = float_option(self.payload_com, 3, "--payload-com") if self.payload_com is not None else (0.0, 0.0, 0.0)
        spec = PayloadSpec(m, (c[0], c[1], c[2]),
                           float_option(self.payload_inertia, 6, "--payload-inertia") if self.payload_inertia is not None else (0.0,) * 6)
        check_spec(spec)
        return spec
