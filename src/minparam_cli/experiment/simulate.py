"""Synthetic measured data: a Fourier excitation, rigid-body torques, injected effects, noise.

The test bed for ``identify``: every number that goes into the data is also
returned, so a fit can be checked against the truth.  The measured torque is

    τ = Y(q, q̇, q̈)·φ  +  Σ_effects C_e(q, q̇, q̈, t, τ_rigid)·c_e  +  ε,   ε ~ N(0, σ²),

with Y the Newton–Euler regressor (``dynamics.regressor``), φ the standard
inertial parameters (the description's, or random physically consistent ones
from ``minparam_cli.dynamics.inertia``), C_e the columns of the effect library
(``identify.effects``, the same functions ``identify`` fits) and c_e their
coefficients.  The motion is Swevers' finite Fourier series
(``experiment.trajectory``) with exact q̇ and q̈.

Randomness: one ``numpy.random.Generator`` is passed in.  It draws five
seeds, one per child generator: trajectory, random inertia, effect
coefficients, torque noise, q noise.  Each part draws only from its own child,
so adding noise or effects never changes the trajectory of the same seed.

Streaming.  ``plan`` makes a first pass over the samples in chunks: it keeps
the rigid-body torque (N × n doubles) and, per injected effect and joint, the
Gram matrix CᵀC of its columns, from which every RMS above follows exactly
(RMS(C·c)² = cᵀ(CᵀC)c / N).  ``stream`` then yields the data chunk by chunk:
the motion is re-evaluated from the Fourier series, the effects from their
coefficients, and the noise is drawn chunk by chunk from the same generators
(numpy draws the same numbers whether asked for N rows at once or in pieces).
Memory is the stored rigid torque plus one chunk, whatever N.  ``simulate``
collects the stream into arrays for in-memory use.

Effect amplitudes.  An effect on joint j gets the amplitude A (N·m or N):
the spec's ``amp=``, else ``strength`` × RMS of the rigid-body torque of
joint j.  Each of its m columns gets the weight u_i/RMS(column i), u_i
uniform in [0.5, 1.5], with a random sign (a positive sign for the
dissipative effects and rotor inertia, so friction opposes the motion);
then all m coefficients are scaled together so that the RMS of the effect's
torque on this trajectory is exactly A.  ``gain`` is the exception: its one
coefficient is g (``g=``, default ``strength``), i.e. it adds g·τ_rigid.
``load_coulomb`` and ``gain`` read τ_rigid, never other effects or noise.

The options and effect specs are parsed in ``simulate_spec``, the coefficients drawn in
``simulate_effects``, and the truth record written by ``simulate_truth``.
"""


from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Callable, Iterator

import numpy as np

from minparam_cli.chain import Chain
from minparam_cli.dynamics.regressor import regressor
from minparam_cli.errors import InputError
from minparam_cli.dynamics.effects import EFFECTS, Signals
from minparam_cli.dynamics.inertia import RandomInertia, random_inertia
from minparam_cli.experiment.simulate_effects import effect_coefficients
from minparam_cli.experiment.simulate_spec import InjectedEffect, MotionLimits, SimulationOptions, validate_options
from minparam_cli.experiment.trajectory import FourierTrajectory, fourier_excitation, joint_ranges
from minparam_cli.runtime import workers

if TYPE_CHECKING:
    from minparam_cli.experiment.trajectory_file import SampledMotion

# Samples per regressor evaluation (bounds memory: chunk × n × 10n doubles).
REGRESSOR_CHUNK = 2048

Progress = Callable[[int, int], None]


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
    trajectory: "FourierTrajectory | SampledMotion"  # the series, or given sampled motion
    ranges: tuple[tuple[float, float], ...]
    effects: tuple[InjectedEffect, ...]
    options: SimulationOptions
    parameter_names: tuple[str, ...] = field(default=())
    limits: "MotionLimits | None" = None

    @property
    def samples(self) -> int:
        return int(self.t.size)



@dataclass(frozen=True, eq=False)
class Plan:
    """Everything the data are made from, after the first pass (see the module docstring)."""

    chain: Chain
    options: SimulationOptions
    samples: int
    trajectory: "FourierTrajectory | SampledMotion"  # the series, or given sampled motion
    ranges: tuple[tuple[float, float], ...]
    phi: np.ndarray
    inertia_source: str
    inertia: RandomInertia | None
    effects: tuple[InjectedEffect, ...]
    tau_rigid: np.ndarray  # (N, n), kept from the first pass
    limits_given: tuple[tuple[float | None, ...], tuple[float | None, ...], tuple[float | None, ...]]
    max_abs_dq: tuple[float, ...]
    max_abs_ddq: tuple[float, ...]
    noise_rng: np.random.Generator
    noise_q_rng: np.random.Generator
    chunk: int = REGRESSOR_CHUNK

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return self.chain.layout.names[: self.chain.layout.n_inertial]


@dataclass(frozen=True, eq=False)
class Chunk:
    """Samples [start, start + len(t)) of the data and the parts they are made of."""

    start: int
    t: np.ndarray
    q: np.ndarray  # as measured
    dq: np.ndarray
    ddq: np.ndarray
    tau: np.ndarray  # as measured
    q_true: np.ndarray
    tau_rigid: np.ndarray
    tau_effects: np.ndarray


def _require_finite(t: np.ndarray, q: np.ndarray, tau: np.ndarray) -> None:
    """Refuse to write a sample whose torque or position is not finite (an effect's amp= of 1e308, say):
    the output file is then not written at all."""
    bad = ~(np.isfinite(tau).all(axis=1) & np.isfinite(q).all(axis=1))
    if bad.any():
        i = int(np.argmax(bad))
        raise InputError(f"the simulated sample at t = {t[i]:.6g} s is not finite: an effect's size (amp=, --strength) "
                         "or the noise is too large")


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


def _bounds(samples: int, chunk: int) -> Iterator[tuple[int, int]]:
    for s in range(0, samples, chunk):
        yield s, min(s + chunk, samples)


def _motion(plan_rate: float, traj, s: int, e: int):
    """Samples [s, e) of the motion: the series evaluated at t = k / rate, or the given samples."""
    if isinstance(traj, FourierTrajectory):
        t = np.arange(s, e) / plan_rate
        return (t,) + tuple(traj.evaluate(t))
    return traj.t[s:e], traj.q[s:e], traj.dq[s:e], traj.ddq[s:e]


def plan(chain: Chain, options: SimulationOptions, rng: np.random.Generator, progress: Progress | None = None,
         chunk: int = REGRESSOR_CHUNK, given=None, threads: int | None = None) -> Plan:
    """The first pass: trajectory, inertial parameters, rigid torque, effect coefficients.
    ``progress(done, total)`` counts samples of both passes (this one is the first half).

    ``given``: None (draw the random Fourier series), a FourierTrajectory (e.g. ``excite``'s, evaluated
    at the options' duration and rate), or sampled motion (an object with arrays t (N,), q, dq, ddq
    (N, n) and a ``source`` name), used as it is.  The generator's five children are drawn either
    way, so the other random parts do not depend on it.  ``threads``: for the first pass (default:
    the CPUs this process may use, at most 4: ``runtime.workers``)."""
    samples = validate_options(options)
    threads = max(1, threads if threads is not None else workers(4))
    if given is not None and not isinstance(given, FourierTrajectory):
        if given.q.shape[1] != chain.dof:
            raise InputError(f"{given.source}: {given.q.shape[1]} joints in the trajectory, {chain.dof} in the robot")
        samples = int(given.t.size)
    for spec in options.effects:
        if any(not 0 <= j < chain.dof for j in spec.joints):
            raise InputError(f"effect {spec.text or spec.effect!r}: joints out of range 1..{chain.dof}")
    traj_rng, inertia_rng, effect_rng, noise_rng, noise_q_rng = child_generators(rng, 5)

    # the independent joints move (mimic joints follow their master: q_mimic = multiplier·q + offset)
    ranges = joint_ranges(chain.coordinate_types, [chain.limits[j] for j in chain.coordinates] if chain.limits else None)
    velocity, acceleration, effort = (_per_coordinate(chain, v) for v in
                                      (chain.velocity_limits, chain.acceleration_limits, chain.effort_limits))
    if given is None:
        traj = fourier_excitation(ranges, options.harmonics, options.base_frequency, traj_rng, options.margin,
                                  max_velocity=velocity, max_acceleration=acceleration)
    else:
        traj = given

    inertia = None
    if options.random_inertia or chain.phi_nominal is None:
        inertia = random_inertia(chain.n, chain.length_scale, inertia_rng)
        # an MJCF's massless frames between the joints of one body have no columns
        phi, source = inertia.phi[list(chain.layout.inertial_columns)], "random"
    else:
        from minparam_cli.dynamics.bodies import nominal_problems, nominal_problems_text

        problems = nominal_problems(chain)
        if problems:  # torques of impossible bodies are no data to identify from
            raise InputError(nominal_problems_text(chain.source, problems) + "; fix them or use --random-inertia")
        phi, source = np.array(chain.phi_nominal, dtype=float), "description"

    dof = chain.dof
    motor = None if chain.transmission is None else np.asarray(chain.transmission.matrix, dtype=float)  # coupled-motor effects
    tau_rigid = np.empty((samples, dof))
    grams = [[np.zeros((len(EFFECTS[s.effect].column_names),) * 2) for _ in s.joints] for s in options.effects]
    max_dq, max_ddq = np.zeros(dof), np.zeros(dof)
    def first_pass(bounds):
        """Chunk [s, e): its rigid torque (written in place), largest |q̇|, |q̈| and effect Gram terms."""
        s, e = bounds
        t, q, dq, ddq = _motion(options.rate, traj, s, e)
        tau_rigid[s:e] = regressor(chain, q, dq, ddq, include_extras=False) @ phi
        terms = []
        if options.effects:
            signals = Signals(t=t, q=q, dq=dq, ddq=ddq, tau_model=tau_rigid[s:e], t0=0.0,
                              coulomb_smoothing=options.coulomb_smoothing, motor=motor)
            for spec in options.effects:
                for j in spec.joints:
                    cols = EFFECTS[spec.effect].columns(signals, j, spec.hyper)
                    terms.append(cols.T @ cols)
        return e, np.abs(dq).max(axis=0), np.abs(ddq).max(axis=0), terms

    # The regressor kernel releases the GIL: chunks run on THREADS threads; their results are summed
    # in chunk order, so the numbers do not depend on the thread count or timing.
    from concurrent.futures import ThreadPoolExecutor

    flat = [g for spec_grams in grams for g in spec_grams]
    with ThreadPoolExecutor(max_workers=threads) as pool:
        for e, mdq, mddq, terms in pool.map(first_pass, _bounds(samples, chunk)):
            np.maximum(max_dq, mdq, out=max_dq)
            np.maximum(max_ddq, mddq, out=max_ddq)
            for g, term in zip(flat, terms, strict=True):
                g += term
            if progress:
                progress(e, 2 * samples)

    rms_rigid = np.sqrt(np.einsum("ij,ij->j", tau_rigid, tau_rigid) / samples)
    with np.errstate(over="ignore", invalid="ignore"):  # a huge amp= overflows: the stream refuses its torques
        injected = tuple(effect_coefficients(spec, spec_grams, samples, rms_rigid, options.strength, effect_rng)
                         for spec, spec_grams in zip(options.effects, grams, strict=True))
    return Plan(
        chain=chain, options=options, samples=samples, trajectory=traj, ranges=tuple(ranges), phi=phi,
        inertia_source=source, inertia=inertia, effects=injected, tau_rigid=tau_rigid,
        limits_given=(velocity, acceleration, effort),
        max_abs_dq=tuple(float(x) for x in max_dq), max_abs_ddq=tuple(float(x) for x in max_ddq),
        noise_rng=noise_rng, noise_q_rng=noise_q_rng, chunk=chunk,
    )


class Stream:
    """The second pass: iterate once for the data chunk by chunk; ``limits`` is complete afterwards.

    ``transforms``: functions Chunk -> Chunk applied in turn to every chunk after the limits are taken
    (per-sample maps only: a payload's torque, motor-side parameters, the change to motor signals)."""

    def __init__(self, plan: Plan, progress: Progress | None = None, transforms: tuple[Callable[[Chunk], Chunk], ...] = ()):
        self.plan = plan
        self.progress = progress
        self.transforms = tuple(transforms)
        self._max_tau = np.zeros(plan.chain.dof)
        self._used = False
        self.limits: MotionLimits | None = None

    def __iter__(self) -> Iterator[Chunk]:
        if self._used:
            raise RuntimeError("a simulation stream can be read only once (its noise generators advance)")
        self._used = True
        p, o = self.plan, self.plan.options
        for s, e in _bounds(p.samples, p.chunk):
            t, q, dq, ddq = _motion(o.rate, p.trajectory, s, e)
            rigid = p.tau_rigid[s:e]
            effects = np.zeros_like(rigid)
            if p.effects:
                motor = None if p.chain.transmission is None else np.asarray(p.chain.transmission.matrix, dtype=float)
                signals = Signals(t=t, q=q, dq=dq, ddq=ddq, tau_model=rigid, t0=0.0, coulomb_smoothing=o.coulomb_smoothing,
                                  motor=motor)
                for record in p.effects:
                    effect = EFFECTS[record.effect]
                    for j, c in zip(record.joints, record.coefficients, strict=True):
                        effects[:, j] += effect.columns(signals, j, record.hyper) @ np.asarray(c)
            tau = rigid + effects
            if o.noise > 0:
                tau = tau + p.noise_rng.normal(0.0, o.noise, size=tau.shape)
            q_measured = q + p.noise_q_rng.normal(0.0, o.noise_q, size=q.shape) if o.noise_q > 0 else q
            _require_finite(t, q_measured, tau)
            np.maximum(self._max_tau, np.abs(tau).max(axis=0), out=self._max_tau)
            if self.progress:
                self.progress(p.samples + e, 2 * p.samples)
            chunk = Chunk(s, t, q_measured, dq, ddq, tau, q, rigid, effects)
            for transform in self.transforms:
                chunk = transform(chunk)
            yield chunk
        self.limits = MotionLimits(*p.limits_given, p.max_abs_dq, p.max_abs_ddq, tuple(float(x) for x in self._max_tau))


def simulate(chain: Chain, options: SimulationOptions, rng: np.random.Generator, given=None,
             progress: Progress | None = None) -> Simulation:
    """Synthetic measured data for ``chain``, in memory (see the module docstring for every equation;
    ``given`` as for ``plan``)."""
    p = plan(chain, options, rng, progress, given=given)
    stream = Stream(p, progress)
    parts = list(stream)

    def stack(name):
        return np.concatenate([getattr(c, name) for c in parts])

    return Simulation(
        t=stack("t"), q=stack("q"), dq=stack("dq"), ddq=stack("ddq"), tau=stack("tau"), q_true=stack("q_true"),
        tau_rigid=p.tau_rigid, tau_effects=stack("tau_effects"), phi=p.phi, inertia_source=p.inertia_source,
        inertia=p.inertia, trajectory=p.trajectory, ranges=p.ranges, effects=p.effects, options=options,
        parameter_names=chain.layout.names[: chain.layout.n_inertial], limits=stream.limits,
    )


def _per_coordinate(chain: Chain, values) -> tuple[float | None, ...]:
    """A per-joint limit list, for the independent joints (None where none is given)."""
    if not values:
        return (None,) * len(chain.coordinates)
    return tuple(values[j] for j in chain.coordinates)
