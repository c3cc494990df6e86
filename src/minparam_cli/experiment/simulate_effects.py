"""Coefficients of the effects ``simulate`` injects (the rule is in ``experiment/simulate.py``'s
module docstring, "Effect amplitudes"): from the Gram matrix of each effect's columns on the
trajectory, random weights scaled so that the effect's RMS torque is its amplitude."""

from __future__ import annotations

import math

import numpy as np

from minparam_cli.errors import InputError
from minparam_cli.dynamics.effects import EFFECTS
from minparam_cli.experiment.simulate_spec import EffectSpec, InjectedEffect

# Effects whose coefficients are drawn positive: those whose physical range is [0, inf) in the effect
# library (friction opposes the motion; inertia is positive), so simulate and the diagnosis agree.
POSITIVE_EFFECTS = frozenset(e.id for e in EFFECTS.values() if e.bounds is not None and e.bounds[0] == 0 and math.isinf(e.bounds[1]))
# Random column weights u_i are uniform in this range before the common scaling.
WEIGHT_RANGE = (0.5, 1.5)


def effect_coefficients(spec: EffectSpec, grams: list[np.ndarray], samples: int, rms_rigid: np.ndarray, strength: float,
                        rng: np.random.Generator) -> InjectedEffect:
    """Coefficients of one effect spec from the Gram matrices of its columns (one per joint);
    see the module docstring for the rule."""
    effect = EFFECTS[spec.effect]
    coefficients, rms = [], []
    for j, gram in zip(spec.joints, grams, strict=True):
        m: int = gram.shape[0]
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
            col_rms = np.sqrt(np.maximum(np.diag(gram), 0.0) / samples)
            if spec.effect in POSITIVE_EFFECTS:
                signs = np.ones(m)
            usable = col_rms > 0
            c = np.zeros(m)
            c[usable] = signs[usable] * weights[usable] / col_rms[usable]
            if spec.effect == "spring":  # K·(q − q₀), q₀ given by q0= (default 0), K of a random sign
                c = signs[0] * np.array([1.0, -(spec.rest or 0.0)])
            size = math.sqrt(max(float(c @ gram @ c), 0.0) / samples)
            if size == 0.0:
                raise InputError(f"effect {spec.text!r}: gives no torque on joint {j + 1} along this trajectory")
            c *= amplitude / size
        coefficients.append(tuple(float(x) for x in c))
        rms.append(math.sqrt(max(float(c @ gram @ c), 0.0) / samples))
    return InjectedEffect(
        effect=spec.effect,
        joints=spec.joints,
        column_names=effect.column_names,
        coefficients=tuple(coefficients),
        hyper=spec.hyper,
        hyper_name=effect.grid_name,
        rms=tuple(rms),
    )
