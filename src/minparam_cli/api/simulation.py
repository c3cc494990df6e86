"""Synthetic measured data: ``simulate`` (the stage of ``minparam simulate``, arrays in memory).

``prepare_simulation`` turns the command's options into what the stream needs (the chain, the
options, a given trajectory, the per-chunk transforms for a payload and motor-side signals) and the
truth record's extra sections; ``minparam simulate`` streams it to a file, ``simulate`` collects it in
memory.  One function for both, so the API and the CLI accept and refuse the same inputs.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping, cast

from minparam_cli.api.common import robot_path, warn
from minparam_cli.api.options.simulate import SimulateOptions
from minparam_cli.api.results import Robot
from minparam_cli.api.simulation_result import SCHEMA, Simulation
from minparam_cli.errors import InputError


@dataclass
class SimulationSetup:
    """Everything a simulation run needs after its options are checked (``prepare_simulation``)."""

    robot: Path
    chain: Any
    options: Any  # identify.simulate_spec.SimulationOptions
    seed: int
    samples: int
    given: Any = None  # a given trajectory (excite's series or samples), or None: a random Fourier series
    trajectory_label: str | None = None  # the --trajectory file, for the summary
    transforms: tuple[Callable, ...] = ()  # per-chunk maps: payload torque, motor parameters, motor signals
    notes: tuple[str, ...] = ()
    extra_record: dict[str, Any] = field(default_factory=dict)  # the truth record's payload / motor_side sections

    def stream(self, progress=None):
        """The plan (first pass) and its stream of chunks (second pass), from one generator seeded with
        ``seed``."""
        import numpy as np

        from minparam_cli.experiment.simulate import Stream, plan as make_plan

        p = make_plan(self.chain, self.options, np.random.default_rng(self.seed), progress=progress, given=self.given)
        return p, Stream(p, progress=progress, transforms=self.transforms)

    def record(self, plan, include_ddq: bool, limits) -> dict[str, Any]:
        """The truth record (``--truth``) of a streamed plan."""
        from minparam_cli.experiment.simulate_truth import truth_record

        record = truth_record(plan, str(self.robot), self.seed, self.chain.name, include_ddq, limits=limits)
        record.update(self.extra_record)
        return {"schema": SCHEMA, **record}


def read_given_trajectory(trajectory: str | Path, n: int):
    """``--trajectory``: 'fourier' (None), or excite's .json (the series) or .csv (the samples)."""
    text = str(trajectory)
    if text == "fourier":
        return None
    from minparam_cli.experiment.trajectory_file import MAX_BYTES, parse_trajectory_csv, parse_trajectory_json

    path = Path(text)
    suffix = path.suffix.lower()
    if suffix not in (".json", ".csv"):
        raise InputError(f"--trajectory {text}: expected 'fourier' or an excite output file (.json or .csv)")
    if not path.is_file():
        raise InputError(f"--trajectory {text}: no such file")
    if path.stat().st_size > MAX_BYTES:
        raise InputError(f"--trajectory {text}: larger than {MAX_BYTES >> 20} MiB")
    try:
        content = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise InputError(f"--trajectory {text}: cannot read ({e})") from None
    if suffix == ".json":
        return parse_trajectory_json(content, n, text)
    return parse_trajectory_csv(content, n, text)


def _drive_gains(chain, current: bool, side: str = "motor", option=None):
    """The drive gains --current divides by (None for torques): the transmission's on the motor side,
    on the joint side --drive-gains or the description's ``drive_gains:`` (tau_j = k_j i_j)."""
    if not current:
        return None
    from minparam_cli.dynamics.transmission import joint_gains

    if side == "joint":
        gains = joint_gains(chain, option)
        if gains is None:
            raise InputError(f"--current needs drive gains: 'drive_gains: [k1, ...]' in {chain.source} or --drive-gains "
                             "(joint side, tau_j = k_j i_j), or drive_gains in the transmission with --side motor")
        return gains
    if option is not None:
        raise InputError("--drive-gains are joint-side gains (tau_j = k_j i_j): with --side motor declare drive_gains "
                         "in the transmission")
    tr = chain.transmission
    if tr is None or tr.drive_gains is None:
        raise InputError(f"--current needs drive_gains in the transmission of {chain.source}")
    return tr.drive_gains


def _motor_values(motor_params: str, chain) -> dict[str, float]:
    from minparam_cli.identify.physical.motor_side import parse_motor_params

    return parse_motor_params(motor_params, chain)


def prepare_simulation(robot: Robot | str | Path, opts: SimulateOptions) -> SimulationSetup:
    """Build ``minparam simulate``'s setup from its options (the chain, the simulation options, the
    given trajectory, the payload and motor-side transforms); every refusal is one ``InputError`` line."""
    from minparam_cli.chain import build_chain
    from minparam_cli.describe import load_description
    from minparam_cli.experiment.simulate_spec import SimulationOptions, parse_effects, validate_options
    from minparam_cli.loops.coupling import with_loops
    from minparam_cli.robot import require_fixed_base

    path = robot_path(robot)
    desc = load_description(path, mimic=opts.mimic)
    chain = with_loops(desc, build_chain(desc))  # a closed chain: the actuated joints, the loops as the coupling
    require_fixed_base(chain, "simulate")
    side = opts.side
    motor_values, gains = _motor_values(opts.motor_params, chain), _drive_gains(chain, opts.current, side, opts.drive_gains)
    payload = opts.payload()
    try:
        specs = parse_effects(opts.effects, chain.dof)
    except InputError as e:
        raise InputError(f"--effects: {e}") from None
    given = read_given_trajectory(opts.trajectory, chain.dof)
    harmonics, base_frequency, rate, duration = opts.harmonics, opts.base_frequency, opts.rate, opts.duration
    if given is not None and hasattr(given, "harmonics"):  # excite's series: its own harmonics and period
        harmonics, base_frequency = given.harmonics, given.base_frequency
    elif given is not None:  # samples: their own length and rate
        import numpy as np

        step = float(np.median(np.diff(given.t)))
        rate, duration = 1.0 / step, given.t.size * step
    sim = SimulationOptions(duration=float(duration), rate=float(rate), harmonics=int(harmonics),
                            base_frequency=float(base_frequency), effects=specs, strength=opts.strength,
                            noise=opts.noise, noise_q=opts.noise_q, random_inertia=opts.random_inertia,
                            coulomb_smoothing=opts.coulomb_smoothing)
    samples = validate_options(sim)
    notes = []
    if chain.phi_nominal is None and not opts.random_inertia:
        notes.append(f"{path} does not give inertial data for every link; using random physically consistent "
                     "parameters (as with --random-inertia)")

    transforms: list[Callable] = []
    extra: dict[str, Any] = {}
    if payload is not None:  # identify/physical/payload.py: the payload's torque Y_n φ_L
        from minparam_cli.identify.physical.payload import with_payload

        transforms.append(lambda c: with_payload(c, chain, payload))
        extra["payload"] = {"mass": payload.mass, "com": list(payload.com), "inertia": list(payload.inertia),
                            "standard_parameters": payload.known()}
    if motor_values or side == "motor":  # motor parameters and motor-side signals: identify/physical/motor_side.py
        from minparam_cli.identify.physical.motor_side import to_motor_side, with_motor_params

        smooth = chain.with_coulomb_smoothing(sim.coulomb_smoothing)
        transforms.append(lambda c: with_motor_params(c, smooth, motor_values))
        if side == "motor":
            transforms.append(lambda c: to_motor_side(c, chain, gains))
        extra["motor_side"] = {"side": side, "current": opts.current, "drive_gains": list(gains) if gains else None,
                               "motor_parameters": motor_values}
    if side == "joint" and gains is not None:  # joint-side currents i_j = tau_j / k_j
        transforms.append(lambda c: _to_currents(c, gains))
        extra["current"] = {"side": "joint", "drive_gains": list(gains)}
    return SimulationSetup(robot=path, chain=chain, options=sim, seed=opts.seed, samples=samples, given=given,
                           trajectory_label=None if given is None else opts.trajectory, transforms=tuple(transforms),
                           notes=tuple(notes), extra_record=extra)


def _to_currents(sim, gains):
    """The simulation with its joint torques as joint-side currents, i_j = tau_j / k_j."""
    from dataclasses import replace

    import numpy as np

    return replace(sim, tau=sim.tau / np.asarray(gains, dtype=float))


def effort_notes(limits) -> list[str]:
    """One note per joint whose largest |τ| exceeds its effort limit."""
    return [f"joint {j + 1}: max |tau| {limits.max_abs_tau[j]:.4g} exceeds its effort limit "
            f"{limits.effort[j]:g} (reported, not enforced: a slower motion lowers only its inertial part)"
            for j in (limits.over_effort if limits is not None else ())]


def simulate(robot: Robot | str | Path, *, effects: str | Iterable[str] = "", strength: float = 0.1,
             noise: float = 0.0, noise_q: float = 0.0, seed: int = 0, duration: float = 20.0, rate: float = 200.0,
             harmonics: int = 5, base_frequency: float = 0.1, random_inertia: bool = False, ddq: bool = True,
             coulomb_smoothing: float = 0.0, mimic: str = "coupled", trajectory: str | Path = "fourier",
             side: str = "joint", current: bool = False, drive_gains: Any = None, motor_params: str | Mapping[str, float] = "",
             payload_mass: float | None = None, payload_com: Any = None, payload_inertia: Any = None) -> Simulation:
    """Synthetic joint data (``minparam simulate``): a random Fourier excitation (Swevers et al. 1997)
    inside the joint limits from one generator seeded with ``seed`` (or ``trajectory``, an excite
    output file), torques from the file's inertial values (or random physically consistent ones),
    injected ``effects`` (the CLI's syntax, e.g. "coulomb,viscous,spring@2") and Gaussian noise; a
    payload on the last link (``payload_mass``, ``payload_com`` X,Y,Z, ``payload_inertia`` about its
    centre of mass), motor-side parameters (``motor_params``, e.g. {"Fcm6": 0.06}) and motor-side
    signals (``side="motor"``, ``current=True`` for currents through the drive gains); on the joint
    side ``current=True`` writes i_j = tau_j / k_j with the description's ``drive_gains:`` or ``drive_gains``.
    ``to_dict()`` is the truth record (``--truth``); the arrays are those the CLI writes, bit for bit.
    """
    import numpy as np

    # cast(Any, ...): raw values (text, sequences, mappings) that the record normalises on construction (its fields: the stored types)
    opts = SimulateOptions(trajectory=cast(Any, trajectory), effects=cast(Any, effects), strength=strength, noise=noise, noise_q=noise_q,
                           seed=seed, duration=duration, rate=rate, harmonics=harmonics, base_frequency=base_frequency,
                           random_inertia=random_inertia, ddq=ddq, coulomb_smoothing=coulomb_smoothing, mimic=mimic,
                           side=side, current=current, drive_gains=drive_gains, motor_params=cast(Any, motor_params), payload_mass=payload_mass,
                           payload_com=payload_com, payload_inertia=payload_inertia)
    setup = prepare_simulation(robot, opts)
    warn(setup.notes)
    plan, stream = setup.stream()
    parts = list(stream)
    warn(effort_notes(stream.limits))

    def stack(name):
        return np.concatenate([getattr(c, name) for c in parts])

    return Simulation(t=stack("t"), q=stack("q"), dq=stack("dq"), ddq=stack("ddq"), tau=stack("tau"), seed=opts.seed,
                      truth=setup.record(plan, opts.ddq, stream.limits))
