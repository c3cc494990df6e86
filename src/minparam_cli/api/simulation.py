"""Synthetic measured data: ``simulate`` (the stage of ``minparam simulate``, arrays in memory)."""

from __future__ import annotations

from pathlib import Path
from typing import Iterable

from minparam_cli.api.common import choice, robot_path, warn
from minparam_cli.api.results import Robot, Simulation
from minparam_cli.errors import InputError


def simulate(robot: Robot | str | Path, *, effects: str | Iterable[str] = "", strength: float = 0.1,
             noise: float = 0.0, noise_q: float = 0.0, seed: int = 0, duration: float = 20.0, rate: float = 200.0,
             harmonics: int = 5, base_frequency: float = 0.1, random_inertia: bool = False, ddq: bool = True,
             coulomb_smoothing: float = 0.0, mimic: str = "coupled") -> Simulation:
    """Synthetic joint data (``minparam simulate``): a random Fourier excitation (Swevers et al. 1997)
    inside the joint limits from one generator seeded with ``seed``, torques from the file's inertial
    values (or random physically consistent ones), injected ``effects`` (the CLI's syntax, e.g.
    "coulomb,viscous,spring@2") and Gaussian noise.  ``to_dict()`` is the truth record (``--truth``).
    """
    import numpy as np

    from minparam_cli.chain import build_chain
    from minparam_cli.describe import load_description
    from minparam_cli.identify.simulate import SimulationOptions, parse_effects, simulate as run, truth_record, validate_options
    from minparam_cli.pipeline import require_fixed_base

    if seed < 0:
        raise InputError(f"--seed must be >= 0, got {seed}")
    path = robot_path(robot)
    chain = build_chain(load_description(path, mimic=choice(mimic, ("coupled", "fixed"), "mimic")))
    require_fixed_base(chain, "simulate")
    text = effects if isinstance(effects, str) else ",".join(effects)
    try:
        specs = parse_effects(text, chain.dof)
    except InputError as e:
        raise InputError(f"--effects: {e}") from None
    try:  # the CLI's types: a 20 given for a float option is 20.0 in the truth record
        opts = SimulationOptions(duration=float(duration), rate=float(rate), harmonics=int(harmonics),
                                 base_frequency=float(base_frequency), effects=specs, strength=float(strength),
                                 noise=float(noise), noise_q=float(noise_q), random_inertia=bool(random_inertia),
                                 coulomb_smoothing=float(coulomb_smoothing))
    except (TypeError, ValueError) as e:
        raise InputError(f"simulate: expected numbers for duration, rate, harmonics, base_frequency, strength and noise ({e})") from None
    validate_options(opts)
    notes = []
    if chain.phi_nominal is None and not random_inertia:
        notes.append(f"{path} does not give inertial data for every link; using random physically consistent "
                     "parameters (as with --random-inertia)")
    sim = run(chain, opts, np.random.default_rng(seed))
    limits = sim.limits
    for j in limits.over_effort if limits is not None else ():
        assert limits is not None
        notes.append(f"joint {j + 1}: max |tau| {limits.max_abs_tau[j]:.4g} exceeds its effort limit "
                     f"{limits.effort[j]:g} (reported, not enforced: a slower motion lowers only its inertial part)")
    warn(notes)
    record = truth_record(sim, str(path), seed, chain.name, ddq)
    return Simulation(t=sim.t, q=sim.q, dq=sim.dq, ddq=sim.ddq, tau=sim.tau, seed=seed, _report=record)
