"""Synthetic measured data: a Fourier excitation, rigid-body torques, injected effects, noise.

The test bed for ``identify``: every number that goes into the data is also
returned, so a fit can be checked against the truth.  The measured torque is

    τ = Y(q, q̇, q̈)·φ  +  Σ_effects C_e(q, q̇, q̈, t, τ_rigid)·c_e  +  ε,   ε ~ N(0, σ²),

with Y the Newton–Euler regressor (``dynamics.regressor``), φ the standard
inertial parameters (the description's, or random physically consistent ones
from ``identify.inertia``), C_e the columns of the effect library
(``identify.effects``, the same functions ``identify`` fits) and c_e their
coefficients.  The motion is Swevers' finite Fourier series
(``identify.trajectory``) with exact q̇ and q̈.

Randomness: one ``numpy.random.Generator`` is passed in.  It draws five
seeds, one per child generator: trajectory, random inertia, effect
coefficients, torque noise, q noise.  Each part draws only from its own child,
so adding noise or effects never changes the trajectory of the same seed.

Effect amplitudes.  An effect on joint j gets the amplitude A (N·m or N):
the spec's ``amp=``, else ``strength`` × RMS of the rigid-body torque of
joint j.  Each of its m columns gets the weight u_i/RMS(column i), u_i
uniform in [0.5, 1.5], with a random sign (a positive sign for the
dissipative effects and rotor inertia, so friction opposes the motion);
then all m coefficients are scaled together so that the RMS of the effect's
torque on this trajectory is exactly A.  ``gain`` is the exception: its one
coefficient is g (``g=``, default ``strength``), i.e. it adds g·τ_rigid.
``load_coulomb`` and ``gain`` read τ_rigid, never other effects or noise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from minparam_cli.chain import Chain
from minparam_cli.dynamics.regressor import regressor
from minparam_cli.errors import InputError
from minparam_cli.identify.effects import EFFECTS, Signals
from minparam_cli.identify.inertia import RandomInertia, random_inertia
from minparam_cli.identify.trajectory import LIMIT_MARGIN, FourierTrajectory, fourier_excitation, joint_ranges
from minparam_cli.params import standard_names

# Hyper-parameter of the grid effects: spec key and default (each default lies on its effect's grid).
HYPER_KEY: dict[str, str] = {"stribeck": "vs", "cogging": "k"}
HYPER_DEFAULT: dict[str, float] = {"stribeck": 0.05, "cogging": 12.0}
# Effects whose coefficients are drawn positive: those whose physical range is [0, inf) in the effect
# library (friction opposes the motion; inertia is positive), so simulate and the diagnosis agree.
POSITIVE_EFFECTS = frozenset(e.id for e in EFFECTS.values() if e.bounds is not None and e.bounds[0] == 0 and math.isinf(e.bounds[1]))
# Random column weights u_i are uniform in this range before the common scaling.
WEIGHT_RANGE = (0.5, 1.5)
# Samples per regressor evaluation (bounds memory: chunk × n × 10n doubles).
REGRESSOR_CHUNK = 2048


@dataclass(frozen=True)
class EffectSpec:
    """One parsed item of the ``--effects`` list."""

    effect: str
    joints: tuple[int, ...]  # 0-based
    amplitude: float | None = None  # N·m or N: RMS of the injected torque; None = strength × RMS(τ_rigid)
    gain: float | None = None  # only for 'gain'; None = strength
    hyper: float | None = None  # the grid value (stribeck vs, cogging k); None for effects without one
    text: str = ""  # the item as written, for messages


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


@dataclass(frozen=True, eq=False)
class Simulation:
    """Synthetic data and the truth it was made from."""

    t: np.ndarray  # (N,) s
    q: np.ndarray  # (N, n) as measured: with position noise when noise_q > 0
    dq: np.ndarray  # (N, n) exact
    ddq: np.ndarray  # (N, n) exact
    tau: np.ndarray  # (N, n) as measured: rigid + effects + noise
    q_true: np.ndarray
    tau_rigid: np.ndarray
    tau_effects: np.ndarray
    phi: np.ndarray  # (10 n,) standard parameters used
    inertia_source: str  # "description" | "random"
    inertia: RandomInertia | None
    trajectory: FourierTrajectory
    ranges: tuple[tuple[float, float], ...]
    effects: tuple[InjectedEffect, ...]
    options: SimulationOptions
    parameter_names: tuple[str, ...] = field(default=())
    limits: "MotionLimits | None" = None


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
        return tuple(j for j, (lim, x) in enumerate(zip(self.effort, self.max_abs_tau)) if lim is not None and x > lim)

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
        shown = f"{grid[0]:g}..{grid[-1]:g} in steps of 1" if effect == "cogging" else ", ".join(f"{g:g}" for g in grid)
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
        if name not in EFFECTS:
            raise InputError(f"unknown effect {name!r} in {item!r}; expected one of {', '.join(EFFECTS)}")
        joints = _joint_set(joints_text.strip(), n, item) if "@" in head else tuple(range(n))
        allowed = ("g",) if name == "gain" else ("amp",) + ((HYPER_KEY[name],) if name in HYPER_KEY else ())
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
        specs.append(EffectSpec(name, joints, amp, values.get("g"), hyper, item))
    return tuple(specs)


# --- the stage -------------------------------------------------------------------------------------


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
    if not 0 <= o.margin < 0.5:
        raise InputError(f"margin must be in [0, 0.5), got {o.margin:g}")
    samples = int(round(o.duration * o.rate))
    if samples < 2:
        raise InputError(f"--duration x --rate gives {samples} sample(s); need at least 2")
    return samples


def child_generators(rng: np.random.Generator, count: int) -> list[np.random.Generator]:
    """``count`` independent generators seeded from ``rng`` (works on every numpy >= 1.17)."""
    seeds = rng.integers(0, np.iinfo(np.int64).max, size=count, dtype=np.int64)
    return [np.random.default_rng(int(s)) for s in seeds]


def rigid_torque(chain: Chain, q, dq, ddq, phi) -> np.ndarray:
    """τ = Y(q, q̇, q̈)·φ (inverse dynamics through the regressor), evaluated in chunks."""
    phi = np.asarray(phi, dtype=float)
    out = np.empty_like(np.asarray(q, dtype=float))
    for s in range(0, out.shape[0], REGRESSOR_CHUNK):
        e = s + REGRESSOR_CHUNK
        out[s:e] = regressor(chain, q[s:e], dq[s:e], ddq[s:e], include_extras=False) @ phi
    return out


def _rms(x: np.ndarray, axis=0) -> np.ndarray:
    return np.sqrt(np.mean(np.square(x), axis=axis))


def _inject(spec: EffectSpec, signals: Signals, rms_rigid: np.ndarray, strength: float, rng: np.random.Generator):
    """Coefficients and torque (N, n) of one effect spec; see the module docstring for the rule."""
    effect = EFFECTS[spec.effect]
    torque = np.zeros_like(signals.q)
    coefficients, rms = [], []
    for j in spec.joints:
        cols = effect.columns(signals, j, spec.hyper)
        m = cols.shape[1]
        weights = rng.uniform(*WEIGHT_RANGE, size=m)
        signs = rng.choice((-1.0, 1.0), size=m)
        if spec.effect == "gain":
            c = np.array([strength if spec.gain is None else spec.gain])
        else:
            if spec.amplitude is not None:
                amplitude = spec.amplitude
            else:
                if strength > 0 and rms_rigid[j] <= np.finfo(float).eps * rms_rigid.max():
                    raise InputError(
                        f"effect {spec.text!r}: joint {j + 1} carries no rigid-body torque to scale the effect by; give amp="
                    )
                amplitude = strength * rms_rigid[j]
            col_rms = _rms(cols)
            if spec.effect in POSITIVE_EFFECTS:
                signs = np.ones(m)
            usable = col_rms > 0
            c = np.zeros(m)
            c[usable] = signs[usable] * weights[usable] / col_rms[usable]
            size = float(_rms(cols @ c))
            if size == 0.0:
                raise InputError(f"effect {spec.text!r}: gives no torque on joint {j + 1} along this trajectory")
            c *= amplitude / size
        contribution = cols @ c
        torque[:, j] += contribution
        coefficients.append(tuple(float(x) for x in c))
        rms.append(float(_rms(contribution)))
    injected = InjectedEffect(
        effect=spec.effect,
        joints=spec.joints,
        column_names=effect.column_names,
        coefficients=tuple(coefficients),
        hyper=spec.hyper,
        hyper_name=effect.grid_name,
        rms=tuple(rms),
    )
    return injected, torque


def simulate(chain: Chain, options: SimulationOptions, rng: np.random.Generator) -> Simulation:
    """Synthetic measured data for ``chain`` (see the module docstring for every equation)."""
    samples = validate_options(options)
    for spec in options.effects:
        if any(not 0 <= j < chain.dof for j in spec.joints):
            raise InputError(f"effect {spec.text or spec.effect!r}: joints out of range 1..{chain.dof}")
    traj_rng, inertia_rng, effect_rng, noise_rng, noise_q_rng = child_generators(rng, 5)

    # the independent joints move (mimic joints follow their master: q_mimic = multiplier·q + offset)
    ranges = joint_ranges(chain.coordinate_types, [chain.limits[j] for j in chain.coordinates] if chain.limits else None)
    velocity, acceleration, effort = (_per_coordinate(chain, v) for v in
                                      (chain.velocity_limits, chain.acceleration_limits, chain.effort_limits))
    traj = fourier_excitation(ranges, options.harmonics, options.base_frequency, traj_rng, options.margin,
                              max_velocity=velocity, max_acceleration=acceleration)
    t = np.arange(samples) / options.rate
    q, dq, ddq = traj.evaluate(t)

    inertia = None
    if options.random_inertia or chain.phi_nominal is None:
        inertia = random_inertia(chain.n, chain.length_scale, inertia_rng)
        phi, source = inertia.phi, "random"
    else:
        from minparam_cli.describe.bodies import nominal_problems, nominal_problems_text

        problems = nominal_problems(chain)
        if problems:  # torques of impossible bodies are no data to identify from
            raise InputError(nominal_problems_text(chain.source, problems) + "; fix them or use --random-inertia")
        phi, source = np.array(chain.phi_nominal, dtype=float), "description"

    tau_rigid = rigid_torque(chain, q, dq, ddq, phi)
    motor = None if chain.transmission is None else np.asarray(chain.transmission.matrix, dtype=float)  # coupled-motor effects
    signals = Signals(t=t, q=q, dq=dq, ddq=ddq, tau_model=tau_rigid, coulomb_smoothing=options.coulomb_smoothing, motor=motor)
    rms_rigid = _rms(tau_rigid)
    tau_effects = np.zeros_like(tau_rigid)
    injected = []
    for spec in options.effects:
        record, torque = _inject(spec, signals, rms_rigid, options.strength, effect_rng)
        injected.append(record)
        tau_effects += torque

    tau = tau_rigid + tau_effects
    if options.noise > 0:
        tau = tau + noise_rng.normal(0.0, options.noise, size=tau.shape)
    q_measured = q + noise_q_rng.normal(0.0, options.noise_q, size=q.shape) if options.noise_q > 0 else q

    return Simulation(
        t=t,
        q=q_measured,
        dq=dq,
        ddq=ddq,
        tau=tau,
        q_true=q,
        tau_rigid=tau_rigid,
        tau_effects=tau_effects,
        phi=phi,
        inertia_source=source,
        inertia=inertia,
        trajectory=traj,
        ranges=tuple(ranges),
        effects=tuple(injected),
        options=options,
        parameter_names=standard_names(chain.n),
        limits=MotionLimits(
            velocity, acceleration, effort,
            *(tuple(float(x) for x in np.abs(v).max(axis=0)) for v in (dq, ddq, tau)),
        ),
    )


def _per_coordinate(chain: Chain, values) -> tuple[float | None, ...]:
    """A per-joint limit list, for the independent joints (None where none is given)."""
    if not values:
        return (None,) * len(chain.coordinates)
    return tuple(values[j] for j in chain.coordinates)


# --- the truth record --------------------------------------------------------------------------------


def truth_record(sim: Simulation, robot: str, seed: int, robot_name: str = "", include_ddq: bool = True) -> dict:
    """JSON-ready record of everything the data was made from (joints numbered from 1)."""
    o = sim.options
    effects = []
    for e in sim.effects:
        effects.append(
            {
                "effect": e.effect,
                "joints": [j + 1 for j in e.joints],
                "coefficients": {str(j + 1): list(c) for j, c in zip(e.joints, e.coefficients)},
                "hyper": e.hyper,
                "hyper_name": e.hyper_name or None,
                "columns": list(e.column_names),
                "rms": {str(j + 1): r for j, r in zip(e.joints, e.rms)},
            }
        )
    traj = sim.trajectory
    return {
        "robot": robot,
        "robot_name": robot_name,
        "seed": seed,
        "effects": effects,
        "noise": o.noise,
        "noise_q": o.noise_q,
        "coulomb_smoothing": o.coulomb_smoothing,
        "strength": o.strength,
        "inertia_source": sim.inertia_source,
        "phi": [float(x) for x in sim.phi],
        "standard_parameters": list(sim.parameter_names),
        "samples": int(sim.t.size),
        "rate": o.rate,
        "duration": o.duration,
        "ddq_included": include_ddq,
        "trajectory": {
            "type": "fourier",
            "reference": "Swevers et al., IEEE T-RA 13(5), 1997",
            "harmonics": traj.harmonics,
            "base_frequency": traj.base_frequency,
            "q0": traj.q0.tolist(),
            "a": traj.a.tolist(),
            "b": traj.b.tolist(),
            "ranges": [list(r) for r in sim.ranges],
            "margin": o.margin,
        },
        "limits": sim.limits.to_dict() if sim.limits is not None else None,
        "units": {"t": "s", "q": "rad or m", "dq": "rad/s or m/s", "ddq": "rad/s^2 or m/s^2", "tau": "N·m or N"},
    }
