"""Synthetic motor-side data (``simulate --side motor``): the motor parameters' torques, and the
conversion of a simulation's joint-side signals to what motor encoders and drives record.

θ_m = N (q − zero), θ̇_m = N q̇, θ̈_m = N q̈, τ_m = N⁻ᵀ τ (a current i = τ_m / g with drive gains g);
see ``dynamics/transmission.py`` and docs/methods/transmission.md.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from minparam_cli.dynamics.transmission import (
    motor_column,
    motor_from_joint,
    motor_matrix,
    motor_torque,
)
from minparam_cli.errors import InputError
from minparam_cli.params import MOTOR_KINDS


def parse_motor_params(text: str, chain) -> dict[str, float]:
    """``Fcm6=0.05,Fvm6=6e-4`` -> {name: value}, every name one of the chain's motor-side columns."""
    names = motor_names(chain)
    out: dict[str, float] = {}
    for item in filter(None, (x.strip() for x in (text or "").split(","))):
        if "=" not in item:
            raise InputError(f"--motor-params: expected NAME=VALUE items, got {item!r}")
        name, value = (x.strip() for x in item.split("=", 1))
        if name not in names:
            have = ", ".join(names) or "none: declare motor_friction or motor_inertia in the transmission"
            raise InputError(f"--motor-params: {name!r} is not a motor-side parameter of {chain.source} (it has {have})")
        try:
            v = float(value)
        except ValueError:
            v = float("nan")
        if not np.isfinite(v):
            raise InputError(f"--motor-params: {name}={value!r} is not a finite number")
        out[name] = v
    return out


def motor_names(chain) -> tuple[str, ...]:
    layout = chain.layout
    return tuple(layout.names[layout.n_inertial + c] for c, (_, kind) in enumerate(layout.extra_columns) if kind in MOTOR_KINDS)


def motor_param_torque(chain, dq: np.ndarray, ddq: np.ndarray, values: dict[str, float]) -> np.ndarray:
    """Joint torques (N, n) of the motor-side parameters ``values`` (names of the chain's layout)."""
    layout = chain.layout
    N = motor_matrix(chain)
    out = np.zeros_like(np.asarray(dq, dtype=float))
    for c, (k, kind) in enumerate(layout.extra_columns):
        name = layout.names[layout.n_inertial + c]
        if kind in MOTOR_KINDS and name in values:
            out += values[name] * motor_column(N, k, kind, dq, ddq, chain.coulomb_smoothing)
    return out


def with_motor_params(sim, chain, values: dict[str, float]):
    """The simulation with the motor parameters' torques added to τ (and to the effects' share)."""
    if not values:
        return sim
    extra = motor_param_torque(chain, sim.dq, sim.ddq, values)
    return replace(sim, tau=sim.tau + extra, tau_effects=sim.tau_effects + extra)


def to_motor_side(sim, chain, gains=None):
    """The simulation's q, q̇, q̈, τ as motor angles, rates and torques (currents when ``gains``)."""
    tr = chain.transmission
    if tr is None:
        raise InputError(f"--side motor needs a transmission in {chain.source} (YAML 'transmission:' or a URDF's "
                         "ROBOT.transmission.yaml)")
    N = motor_matrix(chain)
    return replace(sim, q=motor_from_joint(sim.q, N, tr.zero), dq=motor_from_joint(sim.dq, N), ddq=motor_from_joint(sim.ddq, N),
                   tau=motor_torque(sim.tau, N, gains))
