"""Transmissions: motor coordinates, coupled gears and the motor-side columns of the regressor.

A declared transmission (``describe/transmission.py``) relates the motor angles θ_m to the joint
coordinates q by a constant, invertible matrix N (Khalil & Dombre 2002, §9.3; the Stäubli TX40
wrist: motor 6 turns with joints 5 and 6):

    θ_m = N (q − q_zero),    θ̇_m = N q̇,    θ̈_m = N q̈,    τ_joint = Nᵀ τ_m

(the last by virtual work: τ_mᵀ δθ_m = τ_mᵀ N δq).  A motor-side effect of motor k is a torque
f_k(θ̇_m,k, θ̈_m,k) on that motor's shaft; at the joints it is Nᵀ e_k f_k, i.e. row k of N scaled
by f_k.  Its regressor column, parameter times column = joint torques:

    Iamk:  Nᵀ e_k (N q̈)_k            (rotor inertia of motor k: kinetic energy ½ Iam_k (N q̇)_k²)
    Fvmk:  Nᵀ e_k (N q̇)_k            (viscous friction on the motor speed)
    Fcmk:  Nᵀ e_k sign((N q̇)_k)      (Coulomb friction on the motor speed; tanh(·/v_c) when smoothed)

When row k of N has a single entry r (an uncoupled motor) these are r²·q̈_k, r²·q̇_k and
|r| sign(q̇_k) on joint k: a joint rotor inertia or friction, with which the base set regroups
them.  When it has more (a coupled motor) they spread over several joints and no joint column
can stand in for them.
"""

from __future__ import annotations

import numpy as np

from minparam_cli.params import MOTOR_KINDS


def motor_matrix(chain) -> np.ndarray:
    """N (dof × dof): the chain's declared transmission, the identity when none is declared."""
    tr = getattr(chain, "transmission", None)
    if tr is None:
        return np.eye(chain.dof)
    return np.asarray(tr.matrix, dtype=float)


def coupled_motors(N: np.ndarray) -> tuple[int, ...]:
    """Motors (0-based) whose row of N moves more than one joint."""
    return tuple(int(k) for k in np.flatnonzero(np.count_nonzero(N, axis=1) > 1))


def motor_column(N: np.ndarray, k: int, kind: str, qd: np.ndarray, qdd: np.ndarray, smoothing: float = 0.0) -> np.ndarray:
    """(samples, dof) joint torques of a unit motor-side parameter ``kind`` of motor k."""
    if kind == "motor_inertia":
        f = qdd @ N[k]
    elif kind == "motor_viscous":
        f = qd @ N[k]
    elif kind == "motor_coulomb":
        v = qd @ N[k]
        f = np.tanh(v / smoothing) if smoothing > 0.0 else np.sign(v)
    else:
        raise ValueError(f"not a motor-side kind: {kind!r}")
    return f[:, None] * N[k][None, :]


def add_motor_columns(chain, Y: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> None:
    """Fill the motor-side columns of ``chain.layout`` in Y (samples, dof, P), in place."""
    layout = chain.layout
    columns = [(layout.n_inertial + c, k, kind) for c, (k, kind) in enumerate(layout.extra_columns) if kind in MOTOR_KINDS]
    if not columns:
        return
    N = motor_matrix(chain)
    for col, k, kind in columns:
        Y[:, :, col] = motor_column(N, k, kind, qd, qdd, chain.coulomb_smoothing)


def joint_from_motor(theta, N: np.ndarray, zero=None) -> np.ndarray:
    """q = N⁻¹ θ_m + q_zero for (samples, n) motor angles (rates: pass zero=None)."""
    q = np.linalg.solve(N, np.asarray(theta, dtype=float).T).T
    return q if zero is None else q + np.asarray(zero, dtype=float)


def motor_from_joint(q, N: np.ndarray, zero=None) -> np.ndarray:
    """θ_m = N (q − q_zero) for (samples, n) joint coordinates (rates: pass zero=None)."""
    q = np.asarray(q, dtype=float)
    if zero is not None:
        q = q - np.asarray(zero, dtype=float)
    return q @ N.T


def joint_torque(tau_m, N: np.ndarray, gains=None) -> np.ndarray:
    """τ_joint = Nᵀ diag(g) τ_m for (samples, n) motor torques (or current signals with gains g)."""
    t = np.asarray(tau_m, dtype=float)
    if gains is not None:
        t = t * np.asarray(gains, dtype=float)
    return t @ N


def motor_torque(tau, N: np.ndarray, gains=None) -> np.ndarray:
    """τ_m = N⁻ᵀ τ_joint (divided by the gains g: the current signal), the inverse of ``joint_torque``."""
    t = np.linalg.solve(N.T, np.asarray(tau, dtype=float).T).T
    return t if gains is None else t / np.asarray(gains, dtype=float)


ARBITRARY_UNIT = ("the torque columns are currents and no drive gains are declared: the torque unit is arbitrary and "
                  "every parameter is identified up to one common scale")
ARBITRARY_JOINT_UNIT = ("the torque columns are currents and no drive gains are given (drive_gains: in the YAML or "
                        "--drive-gains): the torque unit is arbitrary (unit gains assumed; with unequal gains the joints' "
                        "rows are in different units); identify the gains with --payload-data and --payload-mass")


def joint_gains(chain, gains=None) -> tuple[float, ...] | None:
    """The joint-side drive gains k (tau_j = k_j i_j) for ``--current`` without ``--side motor``: the
    option's ``gains`` (``--drive-gains``) when given, else the description's ``drive_gains:``; None: neither."""
    from minparam_cli.errors import InputError

    if gains is None:
        return getattr(chain, "drive_gains", None)
    if len(gains) != chain.dof:
        raise InputError(f"--drive-gains: expected {chain.dof} gains (one per joint of {chain.source}), got {len(gains)}")
    return tuple(float(g) for g in gains)


def motor_side_spec(chain, side: str, current: bool, gains=None) -> tuple[tuple | None, str | None]:
    """What ``identify --side/--current`` asks of the data reader: (N rows, zero, gains) or None
    for joint-side data, and a note for the report when the torque unit is arbitrary.  Joint-side
    currents (``--current`` alone) read with N = I and the joint gains (``joint_gains``; ``gains``:
    ``--drive-gains``), tau_j = k_j i_j."""
    from minparam_cli.errors import InputError

    if side == "joint":
        if not current:
            return None, None
        k = joint_gains(chain, gains)
        if k is None:  # unit gains: the currents are read as torques
            return None, ARBITRARY_JOINT_UNIT
        n = len(k)
        eye = tuple(tuple(float(i == j) for j in range(n)) for i in range(n))
        return (eye, (0.0,) * n, k), None
    if gains is not None:
        raise InputError("--drive-gains are joint-side gains (tau_j = k_j i_j): with --side motor declare drive_gains "
                         "in the transmission")
    tr = chain.transmission
    if tr is None:
        raise InputError(f"--side motor needs a transmission in {chain.source} (YAML 'transmission:' or a URDF's "
                         "ROBOT.transmission.yaml): the gear ratios that turn motor signals into joint ones")
    gains = tr.drive_gains if current else None
    note = ARBITRARY_UNIT if current and gains is None else None
    return (tr.matrix, tr.zero, gains), note
