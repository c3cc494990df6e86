"""Synthetic recordings of the planar 2R arm with white or coloured (low-pass filtered) torque noise."""

from __future__ import annotations

import numpy as np
from scipy.signal import butter, sosfiltfilt

from minparam_cli.experiment.simulate import rigid_torque
from minparam_cli.robot import DeriveOptions, load_chain

ROBOT = "robots/planar2r.yaml"
RATE = 100.0  # Hz


def chain(friction=("viscous", "coulomb")):
    return load_chain(ROBOT, DeriveOptions(friction=friction))[1]


def motion(duration: float, seed: int = 0):
    """A sum of sines per joint (fixed by ``seed``), with exact velocities and accelerations."""
    rng = np.random.default_rng(1000 + seed)
    t = np.arange(0.0, duration, 1.0 / RATE)
    q, dq, ddq = (np.zeros((len(t), 2)) for _ in range(3))
    for j in range(2):
        for k in range(1, 5):
            a, w, ph = rng.uniform(0.2, 0.5) / k, 2 * np.pi * 0.1 * k * rng.uniform(0.8, 1.2), rng.uniform(0, 2 * np.pi)
            q[:, j] += a * np.sin(w * t + ph)
            dq[:, j] += a * w * np.cos(w * t + ph)
            ddq[:, j] -= a * w * w * np.sin(w * t + ph)
    return t, q, dq, ddq


def torque(ch, m, viscous=0.5):
    """Rigid body (nominal inertias) plus viscous ``viscous`` N·m·s/rad and Coulomb 0.3 N·m on both joints."""
    _, q, dq, ddq = m
    return rigid_torque(ch, q, dq, ddq, np.array(ch.phi_nominal, dtype=float)) + viscous * dq + 0.3 * np.sign(dq)


def noise(n: int, scale: float, seed: int, cutoff_hz: float | None) -> np.ndarray:
    """White Gaussian noise, or the same low-pass filtered at ``cutoff_hz`` (order 4, zero phase) and
    rescaled to the same rms: correlated over about 1 / cutoff_hz."""
    e = np.random.default_rng(seed).normal(size=(n, 2))
    if cutoff_hz is not None:
        e = sosfiltfilt(butter(4, cutoff_hz, fs=RATE, output="sos"), e, axis=0)
        e /= e.std(axis=0)
    return scale * e


def write(path, duration: float, seed: int, cutoff_hz: float | None, scale: float = 0.2, motion_seed: int = 0, ch=None,
          viscous=0.5):
    ch = ch if ch is not None else chain()
    m = motion(duration, motion_seed)
    t, q, dq, ddq = m
    tau = torque(ch, m, viscous) + noise(len(t), scale, seed, cutoff_hz)
    header = ["t", "q1", "q2", "dq1", "dq2", "ddq1", "ddq2", "tau1", "tau2"]
    np.savetxt(path, np.column_stack([t, q, dq, ddq, tau]), delimiter=",", header=",".join(header), comments="", fmt="%.10g")
    return path
