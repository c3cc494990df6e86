"""The truth record of a simulation: everything the data were made from, JSON-ready (what
``simulate --truth`` writes)."""

from __future__ import annotations

from minparam_cli.experiment.simulate import Plan, Simulation
from minparam_cli.experiment.simulate_spec import MotionLimits
from minparam_cli.experiment.trajectory import FourierTrajectory


def truth_record(sim: Simulation | Plan, robot: str, seed: int, robot_name: str = "", include_ddq: bool = True,
                 limits: MotionLimits | None = None) -> dict:
    """JSON-ready record of everything the data was made from (joints numbered from 1); from a
    ``Simulation``, or from a streamed ``Plan`` with the ``limits`` its stream found."""
    limits = limits if limits is not None else getattr(sim, "limits", None)
    o = sim.options
    effects = []
    for e in sim.effects:
        effects.append(
            {
                "effect": e.effect,
                "joints": [j + 1 for j in e.joints],
                "coefficients": {str(j + 1): list(c) for j, c in zip(e.joints, e.coefficients, strict=True)},
                "hyper": e.hyper,
                "hyper_name": e.hyper_name or None,
                "columns": list(e.column_names),
                "rms": {str(j + 1): r for j, r in zip(e.joints, e.rms, strict=True)},
            }
        )
    traj = sim.trajectory
    if isinstance(traj, FourierTrajectory):
        motion = {
            "type": "fourier",
            "reference": "Swevers et al., IEEE T-RA 13(5), 1997",
            "harmonics": traj.harmonics,
            "base_frequency": traj.base_frequency,
            "q0": traj.q0.tolist(),
            "a": traj.a.tolist(),
            "b": traj.b.tolist(),
            "ranges": [list(r) for r in sim.ranges],
            "margin": o.margin,
        }
    else:
        motion = {"type": "samples", "source": str(traj.source), "samples": int(traj.t.size)}
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
        "samples": sim.samples,
        "rate": o.rate,
        "duration": o.duration,
        "ddq_included": include_ddq,
        "trajectory": motion,
        "limits": limits.to_dict() if limits is not None else None,
        "units": {"t": "s", "q": "rad or m", "dq": "rad/s or m/s", "ddq": "rad/s^2 or m/s^2", "tau": "N·m or N"},
    }
