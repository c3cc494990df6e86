"""What ``simulate`` is asked for: options, the ``--effects`` syntax, the data columns, the limits record.

The engine that turns these into data is ``identify.simulate``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from minparam_cli.errors import InputError
from minparam_cli.dynamics.effects import EFFECT_IDS, EFFECTS
from minparam_cli.experiment.trajectory import LIMIT_MARGIN

MAX_SIZE = 1e6  # --noise (N·m), --noise-q (rad), --strength (x the rigid-body RMS), --coulomb-smoothing (rad/s)
MAX_SAMPLES = 10**8  # samples a simulate run may write: 28 h at 1 kHz, tens of GB of CSV

# Hyper-parameter of the grid effects: spec key and default (each default lies on its effect's grid).
HYPER_KEY: dict[str, str] = {"stribeck": "vs", "cogging": "k", "position_error": "k"}
HYPER_DEFAULT: dict[str, float] = {"stribeck": 0.05, "cogging": 12.0, "position_error": 2.0}


@dataclass(frozen=True)
class EffectSpec:
    """One parsed item of the ``--effects`` list."""

    effect: str
    joints: tuple[int, ...]  # 0-based
    amplitude: float | None = None  # N·m or N: RMS of the injected torque; None = strength × RMS(τ_rigid)
    gain: float | None = None  # only for 'gain'; None = strength
    hyper: float | None = None  # the grid value (stribeck vs, cogging k); None for effects without one
    text: str = ""  # the item as written, for messages
    rest: float | None = None  # only for 'spring': the rest angle q₀ of K·(q − q₀); None = 0


@dataclass(frozen=True)
class SimulationOptions:
    """Everything ``simulate`` needs besides the chain and the generator (SI units)."""

    duration: float = 20.0  # s
    rate: float = 200.0  # Hz
    harmonics: int = 5
    base_frequency: float = 0.1  # Hz
    effects: tuple[EffectSpec, ...] = ()
    strength: float = 0.1  # default effect amplitude, as a fraction of the joint's rigid-body RMS torque
    noise: float = 0.0  # std of the torque noise, N·m or N
    noise_q: float = 0.0  # std of the position noise, rad or m
    random_inertia: bool = False  # ignore the description's inertial values
    margin: float = LIMIT_MARGIN  # fraction of each joint range kept free at both ends
    coulomb_smoothing: float = 0.0  # > 0: injected friction uses tanh(q̇ / this) for sign(q̇)


@dataclass(frozen=True)
class InjectedEffect:
    """An effect as it went into the torques: coefficients per joint, in the effect's column order."""

    effect: str
    joints: tuple[int, ...]  # 0-based
    column_names: tuple[str, ...]
    coefficients: tuple[tuple[float, ...], ...]  # one tuple per joint
    hyper: float | None
    hyper_name: str
    rms: tuple[float, ...]  # RMS of the injected torque per joint



@dataclass(frozen=True)
class MotionLimits:
    """Per independent joint: the description's velocity, acceleration and effort limits (SI, None: none),
    and the largest |q̇|, |q̈|, |τ| of the data.  Velocity and acceleration are enforced by the
    trajectory; effort is only checked (``over_effort``: 0-based joints whose torque exceeds it)."""

    velocity: tuple[float | None, ...]
    acceleration: tuple[float | None, ...]
    effort: tuple[float | None, ...]
    max_abs_dq: tuple[float, ...]
    max_abs_ddq: tuple[float, ...]
    max_abs_tau: tuple[float, ...]

    @property
    def over_effort(self) -> tuple[int, ...]:
        return tuple(j for j, (lim, x) in enumerate(zip(self.effort, self.max_abs_tau, strict=True)) if lim is not None and x > lim)

    def any_given(self) -> bool:
        return any(v is not None for v in self.velocity + self.acceleration + self.effort)

    def to_dict(self) -> dict:
        return {
            "velocity": list(self.velocity), "acceleration": list(self.acceleration), "effort": list(self.effort),
            "max_abs_dq": list(self.max_abs_dq), "max_abs_ddq": list(self.max_abs_ddq), "max_abs_tau": list(self.max_abs_tau),
            "over_effort": [j + 1 for j in self.over_effort],
        }


# --- column names of the data files: defined once, read by identify ---------------------------------


def data_columns(n: int, include_ddq: bool = True) -> tuple[str, ...]:
    """Header of the CSV: t, q1..qn, dq1..dqn, [ddq1..ddqn,] tau1..taun."""
    groups = ("q", "dq", "ddq", "tau") if include_ddq else ("q", "dq", "tau")
    return ("t",) + tuple(f"{g}{j}" for g in groups for j in range(1, n + 1))


# --- the --effects syntax ----------------------------------------------------------------------------


def _joint_set(text: str, n: int, item: str) -> tuple[int, ...]:
    """'2' -> (1,); '1-3' -> (0, 1, 2); '1+4-5' -> (0, 3, 4); numbering from 1."""
    out: list[int] = []
    for part in text.split("+"):
        bounds = part.split("-")
        try:
            if len(bounds) == 1:
                lo = hi = int(bounds[0])
            elif len(bounds) == 2:
                lo, hi = int(bounds[0]), int(bounds[1])
            else:
                raise ValueError
        except ValueError:
            raise InputError(f"effect {item!r}: expected joints like 2, 1-3 or 1+3, got {text!r}") from None
        if lo > hi:
            raise InputError(f"effect {item!r}: empty joint range {lo}-{hi}")
        for j in (lo, hi):
            if not 1 <= j <= n:
                raise InputError(f"effect {item!r}: joint {j} is out of range 1..{n}")
        out.extend(k - 1 for k in range(lo, hi + 1) if k - 1 not in out)
    return tuple(sorted(out))


def _on_grid(effect: str, value: float, item: str) -> float:
    grid = np.asarray(EFFECTS[effect].grid, dtype=float)
    hit = np.flatnonzero(np.abs(grid - value) <= 1e-9 * np.abs(grid))
    if hit.size == 0:
        shown = f"{grid[0]:g}..{grid[-1]:g} in steps of 1" if EFFECTS[effect].grid_name == "k" else ", ".join(f"{g:g}" for g in grid)
        raise InputError(f"effect {item!r}: {HYPER_KEY[effect]}={value:g} is not on the grid searched by identify ({shown})")
    return float(grid[hit[0]])


def parse_effects(text: str, n: int) -> tuple[EffectSpec, ...]:
    """Parse ``ID[@JOINTS][:key=value...]`` items separated by commas.

    JOINTS: ``2``, ``1-3``, ``1+4-5`` (numbered from 1; default all joints).
    Keys: ``amp`` (RMS of the injected torque, N·m or N, > 0) for every effect
    but ``gain``, which takes ``g`` (the gain error, any finite number);
    ``vs`` for stribeck and ``k`` for cogging (on the effect's grid).
    """
    specs: list[EffectSpec] = []
    seen: set[tuple[str, int, float | None]] = set()
    for raw in (text or "").split(","):
        item = raw.strip()
        if not item:
            continue
        head, *pairs = item.split(":")
        name, _, joints_text = head.partition("@")
        name = name.strip()
        if name not in EFFECT_IDS:
            raise InputError(f"unknown effect {name!r} in {item!r}; expected one of {', '.join(EFFECT_IDS)}")
        joints = _joint_set(joints_text.strip(), n, item) if "@" in head else tuple(range(n))
        allowed = ("g",) if name == "gain" else ("amp",) + ((HYPER_KEY[name],) if name in HYPER_KEY else ()) \
            + (("q0",) if name == "spring" else ())
        values: dict[str, float] = {}
        for pair in pairs:
            key, eq, val = (s.strip() for s in pair.partition("="))
            if key not in allowed:
                raise InputError(f"effect {item!r}: unknown key {key!r} for {name}; expected {', '.join(allowed)}")
            if not eq:
                raise InputError(f"effect {item!r}: expected {key}=VALUE")
            if key in values:
                raise InputError(f"effect {item!r}: key {key!r} given twice")
            try:
                v = float(val)
            except ValueError:
                raise InputError(f"effect {item!r}: {key} must be a number, got {val!r}") from None
            if not math.isfinite(v):
                raise InputError(f"effect {item!r}: {key} must be finite, got {val!r}")
            values[key] = v
        amp = values.get("amp")
        if amp is not None and not amp > 0:
            raise InputError(f"effect {item!r}: amp must be positive, got {amp:g}")
        hyper = None
        if name in HYPER_KEY:
            hyper = _on_grid(name, values.get(HYPER_KEY[name], HYPER_DEFAULT[name]), item)
        for j in joints:
            key3 = (name, j, hyper)
            if key3 in seen:
                raise InputError(f"effect {item!r}: {name} is already injected on joint {j + 1}")
            seen.add(key3)
        specs.append(EffectSpec(name, joints, amp, values.get("g"), hyper, item, values.get("q0")))
    return tuple(specs)



def validate_options(options: SimulationOptions) -> int:
    """Check the options (messages name the CLI flags); return the number of samples."""
    o = options

    def finite_positive(value, flag, unit):
        if not (math.isfinite(value) and value > 0):
            raise InputError(f"{flag} must be a positive number of {unit}, got {value:g}")

    finite_positive(o.duration, "--duration", "seconds")
    finite_positive(o.rate, "--rate", "Hz")
    finite_positive(o.base_frequency, "--base-frequency", "Hz")
    if o.harmonics < 1:
        raise InputError(f"--harmonics must be at least 1, got {o.harmonics}")
    top = o.harmonics * o.base_frequency
    if top >= o.rate / 2:
        raise InputError(
            f"the highest harmonic ({o.harmonics} x {o.base_frequency:g} Hz = {top:g} Hz) must be below half "
            f"the --rate ({o.rate / 2:g} Hz)"
        )
    for value, flag, unit in ((o.noise, "--noise", "N·m"), (o.noise_q, "--noise-q", "rad"), (o.strength, "--strength", ""),
                              (o.coulomb_smoothing, "--coulomb-smoothing", "rad/s")):
        if not (math.isfinite(value) and value >= 0):
            raise InputError(f"{flag} must be a number >= 0{' ' + unit if unit else ''}, got {value:g}")
        if value > MAX_SIZE:  # 1e308 overflowed into samples of inf, written to the file
            raise InputError(f"{flag} must be at most {MAX_SIZE:g}{' ' + unit if unit else ''}, got {value:g}")
    if not 0 <= o.margin < 0.5:
        raise InputError(f"margin must be in [0, 0.5), got {o.margin:g}")
    samples = int(round(o.duration * o.rate))
    if samples < 2:
        raise InputError(f"--duration x --rate gives {samples} sample(s); need at least 2")
    if samples > MAX_SAMPLES:  # --duration 1e9 ran out of memory (exit 1); 1e6 wrote for hours
        raise InputError(f"--duration x --rate gives {samples:.3g} samples, more than the {MAX_SAMPLES:.0e}-sample limit "
                         "(about 28 h at 1 kHz); simulate several shorter recordings")
    return samples

