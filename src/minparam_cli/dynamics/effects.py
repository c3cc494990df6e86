"""The effect library: torque terms a rigid-body model lacks, as extra regressor columns.

Each effect has an id (the JSON ids are exactly these), a one-line physical
explanation, and a function giving its extra columns for one joint.  Effects
with a nonlinear parameter (Stribeck velocity, cogging order) are searched on
a grid.  The same functions inject effects in ``simulate``, so the diagnosis
and the test bed cannot disagree on what an effect is.

``--coulomb-smoothing v_c`` replaces every sign(q̇) of the friction effects
(coulomb, asymmetric_coulomb, stribeck, load_coulomb) by tanh(q̇/v_c), the
same smooth Coulomb as the declared Fc columns (``Chain.coulomb_smoothing``).

Columns for joint j live in row j only (the torque of joint j), except that
``gain`` and ``load_coulomb`` read the model torque of that joint.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np


@dataclass(frozen=True)
class Signals:
    """What effect columns may depend on, for N samples of n joints (SI units)."""

    t: np.ndarray  # (N,)
    q: np.ndarray  # (N, n)
    dq: np.ndarray
    ddq: np.ndarray
    tau_model: np.ndarray | None = None  # rigid-body model torque, for load-dependent effects
    t0: float | None = None  # time origin of the drift column (None: the first sample)
    coulomb_smoothing: float = 0.0  # > 0: every sign(q̇) of the friction effects becomes tanh(q̇ / this)
    motor: np.ndarray | None = None  # the transmission N (θ_m = N q) when the robot declares one: motor-side effects

    def sgn(self, j) -> np.ndarray:
        """The Coulomb signal of joint(s) j: sign(q̇), or its smooth version tanh(q̇ / v_c)."""
        if self.coulomb_smoothing > 0.0:
            return np.tanh(self.dq[:, j] / self.coulomb_smoothing)
        return np.sign(self.dq[:, j])


@dataclass(frozen=True)
class Effect:
    id: str
    explanation: str
    column_names: tuple[str, ...]
    grid: tuple[float, ...] = ()  # values of the nonlinear parameter, if any
    grid_name: str = ""
    needs_model: bool = False
    build: Callable[..., Any] = field(kw_only=True)  # (signals, joint, hyper) -> (N, m)
    bounds: tuple[float, float] | None = None  # physical range of every coefficient (None: any value)
    misfit: str = ""  # what a coefficient outside ``bounds`` most likely is instead
    # (signals, joint, grid values) -> [build(signals, joint, h) for h in them], cheaper than one by one
    sweep: Callable[..., list] | None = field(default=None, kw_only=True)

    def columns(self, s: Signals, joint: int, hyper: float | None = None) -> np.ndarray:
        return np.asarray(self.build(s, joint, hyper), dtype=float).reshape(len(s.t), -1)

    def names(self, joint: int, hyper: float | None = None) -> list[str]:
        tag = f"[{self.grid_name}={hyper:g}]" if self.grid else ""
        return [f"{c}{joint + 1}{tag}" for c in self.column_names]


LEGACY_SPRING = "spring_v1"
STRIBECK_GRID = (0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5)
COGGING_GRID = tuple(float(k) for k in range(2, 61))


MAX_PRODUCT_ORDER = 64  # higher orders (none on the grid) are computed by sin and cos


def _ripples(s: Signals, j, orders) -> list[np.ndarray]:
    """[sin kq, cos kq] of joint(s) j (stacked on axis 1) for each k of ``orders``.  Integer orders
    come from successive products of e^{iq}, one complex product an order instead of a sine and a
    cosine (eight times faster for the diagnosis's 59 orders; the rounding grows like k·eps, as the
    phase k·q's own does); the same numbers whether the orders are asked one at a time or together
    (one order k alone costs k − 1 products: at k = 60 about 1.7x a sine and a cosine)."""
    q = s.q[:, j]
    z1 = z = np.exp(1j * q)
    at = 1
    out = []
    for k in orders:
        if float(k).is_integer() and 1 <= k <= MAX_PRODUCT_ORDER:
            if k < at:  # orders not ascending: from e^{iq} again
                z, at = z1, 1
            while at < k:
                z = z * z1
                at += 1
            out.append(np.stack([z.imag, z.real], axis=1))
        else:
            out.append(np.stack([np.sin(k * q), np.cos(k * q)], axis=1))
    return out


def _asymmetric(s: Signals, j) -> np.ndarray:
    """[q̇ > 0] and −[q̇ < 0] (smooth: (1 + g)/2 and −(1 − g)/2, g = tanh(q̇/v_c)); they sum to the Coulomb signal."""
    if s.coulomb_smoothing > 0.0:
        g = s.sgn(j)
        return np.stack([0.5 * (1.0 + g), -0.5 * (1.0 - g)], axis=1)
    return np.stack([(s.dq[:, j] > 0).astype(float), -(s.dq[:, j] < 0).astype(float)], axis=1)


def _coupled_motor(s: Signals, j, kind: str) -> np.ndarray:
    """Joint j's share of the friction or inertia of the coupled motors that move it (rows of N
    with more than one entry, one of them on joint j): Σ_k N_kj f((N q̇)_k).  Zero without a
    declared transmission, or when no coupled motor moves joint j (then it adds nothing).

    Each joint of the term gets its own coefficient, so a motor k coupling joints 5 and 6 is fitted
    as N_k5·F and N_k6·F with two numbers where one would do (the declared Fcmk column has one):
    the per-joint diagnosis scores columns joint by joint."""
    from minparam_cli.dynamics.transmission import coupled_motors, motor_column

    if s.motor is None:
        return np.zeros_like(s.q[:, j])
    N = np.asarray(s.motor, dtype=float)
    out = np.zeros_like(s.q, dtype=float)
    for k in coupled_motors(N):
        out += motor_column(N, k, kind, s.dq, s.ddq, s.coulomb_smoothing)
    return out[:, j]


POSITIVE = (0.0, math.inf)
# the gain effect adds G·τ_model: the measured torque is (1 + G)·τ_model, a drive gain kept within 0.5..1.5
GAIN_RANGE = (-0.5, 0.5)

EFFECTS: dict[str, Effect] = {
    e.id: e
    for e in (
        Effect("coulomb", "dry friction of constant size against the motion: Fc·sign(q̇)", ("Fc",),
               build=lambda s, j, h: s.sgn(j), bounds=POSITIVE,
               misfit="a torque that helps the motion at every reversal: a standstill or reversal artefact "
                      "(static friction holding the joint while sign(q̇) = 0), or a sign error in the torque signal"),
        Effect("viscous", "friction proportional to velocity (lubricant, motor back-EMF): Fv·q̇", ("Fv",),
               build=lambda s, j, h: s.dq[:, j], bounds=POSITIVE,
               misfit="a torque that grows with speed in the direction of motion: a model error or a time lag "
                      "between the torque and motion signals, not friction"),
        Effect("offset", "a constant torque: sensor or current offset, unmodelled static load", ("OFF",),
               build=lambda s, j, h: np.ones_like(s.t)),
        Effect("rotor_inertia", "motor and gear inertia seen at the joint: Ia·q̈", ("Ia",),
               build=lambda s, j, h: s.ddq[:, j], bounds=POSITIVE,
               misfit="a negative inertia: a lag between the torque and acceleration signals (filter delay) "
                      "or an inertia error of the model, not a rotor"),
        Effect("stribeck", "friction that drops from breakaway to Coulomb level at low speed: Fs·exp(-(q̇/vs)²)·sign(q̇)",
               ("Fs",), STRIBECK_GRID, "vs", build=lambda s, j, h: np.exp(-((s.dq[:, j] / h) ** 2)) * s.sgn(j),
               bounds=POSITIVE,
               misfit="friction that rises gradually from zero at reversal instead of dropping from a breakaway "
                      "level: a smoothed (filtered) velocity or a smooth Coulomb law (try --coulomb-smoothing), "
                      "or a standstill artefact"),
        Effect("asymmetric_coulomb", "dry friction of different size in the two directions", ("Fcp", "Fcn"),
               build=lambda s, j, h: _asymmetric(s, j), bounds=POSITIVE,
               misfit="a torque that helps the motion in one direction: a gravity or offset error that "
                      "correlates with the direction of motion, not friction"),
        Effect("spring", "a spring with a rest angle (spring, cable, gravity compensator): K·(q − q₀) = Kq·q + K0",
               ("Kq", "K0"),
               build=lambda s, j, h: np.stack([s.q[:, j], np.ones_like(s.q[:, j])], axis=1)),
        Effect("gravity_error", "a torque of the form of a joint's own gravity load, A·sin q + B·cos q: a gravity "
               "model error (a link mass or centre of mass the rigid-body model gets wrong)", ("Gs", "Gc"),
               build=lambda s, j, h: np.stack([np.sin(s.q[:, j]), np.cos(s.q[:, j])], axis=1)),
        Effect("cogging", "a torque ripple periodic in the joint angle (motor cogging, gear tooth meshing)", ("Cs", "Cc"),
               COGGING_GRID, "k", build=lambda s, j, h: _ripples(s, j, (h,))[0], sweep=_ripples),
        Effect("position_error", "a smooth position-dependent model error, on the basis sin kq, cos kq: the data "
               "cover too few of its periods to call it a ripple (cogging)", ("Ps", "Pc"),
               COGGING_GRID, "k", build=lambda s, j, h: _ripples(s, j, (h,))[0], sweep=_ripples),
        Effect("load_coulomb", "gear friction that grows with the load the joint carries: sign(q̇)·|τ_model|", ("Fl",),
               needs_model=True, build=lambda s, j, h: s.sgn(j) * np.abs(s.tau_model[:, j]), bounds=POSITIVE,
               misfit="a load-proportional torque that helps the motion: a gain or model error, not friction"),
        Effect("gain", "a drive gain or torque-constant error: the measured torque is the model torque scaled", ("G",),
               needs_model=True, build=lambda s, j, h: s.tau_model[:, j], bounds=GAIN_RANGE,
               misfit="a rescaling far from 1: a unit or sign error in the data, or a model error compensated by "
                      "rescaling the whole joint torque"),
        Effect("motor_coulomb", "dry friction of a coupled motor (one that turns with several joints, as the TX40's "
               "motor 6 with joints 5 and 6), against the motor's motion: N_kj·Fcm·sign((N q̇)_k)", ("Fcmc",),
               build=lambda s, j, h: _coupled_motor(s, j, "motor_coulomb"), bounds=POSITIVE,
               misfit="a torque that helps the motor's motion: a sign error in the coupling or the torque signal"),
        Effect("motor_viscous", "viscous friction of a coupled motor, on the motor's speed: N_kj·Fvm·(N q̇)_k", ("Fvmc",),
               build=lambda s, j, h: _coupled_motor(s, j, "motor_viscous"), bounds=POSITIVE,
               misfit="a torque that grows with the motor's speed in its direction of motion: a coupling or model error"),
        Effect("motor_inertia", "rotor inertia of a coupled motor, on the motor's acceleration: N_kj·Iam·(N q̈)_k", ("Iamc",),
               build=lambda s, j, h: _coupled_motor(s, j, "motor_inertia"), bounds=POSITIVE,
               misfit="a negative inertia: a lag between the torque and acceleration signals, not a rotor"),
        Effect("drift", "a slow linear drift of the torque signal (temperature, sensor drift)", ("D",),
               build=lambda s, j, h: s.t - (s.t[0] if s.t0 is None else s.t0)),
        # model files of format version 1 saved this as "spring"; read there, never searched nor injected
        Effect(LEGACY_SPRING, "a position-dependent torque Kq·q + Ks·sin q + Kc·cos q (the spring of model files "
               "of format version 1)", ("Kq", "Ks", "Kc"),
               build=lambda s, j, h: np.stack([s.q[:, j], np.sin(s.q[:, j]), np.cos(s.q[:, j])], axis=1)),
    )
}

# the catalogue searched by identify and injected by simulate (the legacy spring only reads old model files)
EFFECT_IDS = tuple(e for e in EFFECTS if e != LEGACY_SPRING)
# a ripple is called cogging only when the data cover at least this many of its periods; below, the same
# columns are a smooth position-dependent model error (position_error)
MIN_PERIODS = 3.0


def periods_seen(q_range: float, k: float) -> float:
    """How many periods of sin kq, cos kq a motion spanning ``q_range`` (rad) covers."""
    return float(q_range) * float(k) / (2.0 * math.pi)


def source_columns(sources, first: int = 0) -> tuple[dict, int]:
    """The columns of (effect, grid value) ``sources`` side by side from column ``first``: the first
    column of each source, and the column after the last."""
    start, c = {}, first
    for e, h in sources:
        start[(e, h)] = c
        c += len(EFFECTS[e].column_names)
    return start, c


def in_bounds(effect_id: str, coefficients) -> bool:
    """Whether every coefficient lies in the effect's physical range (always, for an effect without one)."""
    b = EFFECTS[effect_id].bounds
    c = np.asarray(coefficients, dtype=float)
    return b is None or bool(np.all((c >= b[0]) & (c <= b[1])))


def evidence_text(ev: dict | None) -> str:
    """The evidence saved with one effect of a model (``identify``'s diagnosis step), in an ASCII line (generated code)."""
    if not ev:
        return "no evidence recorded"
    parts = [] if ev.get("named", True) else \
        ["a model error of this form, not named (its evidence does not hold under correlated residuals)"]
    if "delta_bic_eff" in ev:
        parts.append(f"delta BIC_eff {ev['delta_bic_eff']:.1f} (N_eff {ev.get('n_eff', float('nan')):.0f})")
    if ev.get("periods_seen") is not None:
        parts.append(f"{ev['periods_seen']:.2g} periods seen")
    if ev.get("replaces"):
        parts.append(f"replaces {ev['replaces']}")
    return ", ".join(parts) if parts else "no evidence recorded"

