"""What each effect of the final model means, written from its fitted values.

The library's one-line explanation says what an effect could be; the report
says what it is on this robot: the size and sign of what was fitted, in
physical units.  A candidate the diagnosis rejected for its sign is
described by what it most likely is instead of by its physical name.
"""

from __future__ import annotations

import math

import numpy as np

from minparam_cli.identify.passes.design import Design, Term
from minparam_cli.identify.diagnosis.diagnose import Rejected, term_coefficients
from minparam_cli.dynamics.effects import EFFECTS, MIN_PERIODS, in_bounds, periods_seen
from minparam_cli.identify.estimate.fit import full_theta


# one line per single-column effect: {v} its fitted values (1 + G for a gain, % for load_coulomb), {T} the
# torque unit (mass or inertia for rotor_inertia), {V} the velocity unit, {on} the joints
ONE_COLUMN = {
    "coulomb": "dry friction against the motion, Fc = {v} {T} on {on}",
    "viscous": "friction proportional to velocity, Fv = {v} {T} per {V} on {on}",
    "offset": "a constant torque of {v} {T} on {on}: a sensor or current offset, or a static load",
    "rotor_inertia": "an inertia seen at the joint (motor, gears), Ia = {v} {T} on {on}",
    "load_coulomb": "friction that grows with the load, {v} % of |τ_model| against the motion on {on}",
    "gain": "the measured torque is {v} × the model torque on {on}: a drive gain or torque-constant error",
    "drift": "a drift of {v} {T}/s over the recording on {on} (temperature, sensor drift)",
}


def _units(design: Design, joints) -> tuple[str, str]:
    """(torque unit, velocity unit) of these joints."""
    prismatic = [design.chain.coordinate_types[j] == "prismatic" for j in joints]
    if all(prismatic):
        return "N", "m/s"
    if any(prismatic):
        return "N·m or N", "rad/s or m/s"
    return "N·m", "rad/s"


def _list(values, digits: int = 3) -> str:
    return ", ".join(f"{v:.{digits}g}" for v in values)


def _on(joints) -> str:
    return f"joint{'s' if len(joints) > 1 else ''} {', '.join(str(j + 1) for j in joints)}"


def _swing(c: np.ndarray, lo: float, hi: float, basis) -> float:
    """How much Σ c_i·basis_i(q) varies over [lo, hi]."""
    if not (np.isfinite(lo) and np.isfinite(hi)) or hi <= lo:
        return float("nan")
    q = np.linspace(lo, hi, 201)
    f = np.asarray(basis(q)).T @ c
    return float(f.max() - f.min())


SPRING_BASIS = {
    "spring": lambda q: [q, np.ones_like(q)],
    "gravity_error": lambda q: [np.sin(q), np.cos(q)],
    "spring_v1": lambda q: [q, np.sin(q), np.cos(q)],
}


def _swings(term: Term, c: np.ndarray, motion) -> list[float]:
    basis = SPRING_BASIS[term.effect]
    return [_swing(row, motion.lo[j], motion.hi[j], basis) if motion is not None else float("nan")
            for j, row in zip(term.joints, c, strict=True)]


def explain(term: Term, c: np.ndarray, design: Design, motion=None) -> str:
    """One line for ``term`` with coefficients ``c`` (joints, columns)."""
    T, V = _units(design, term.joints)
    on = _on(term.joints)
    e = term.effect
    if e in ONE_COLUMN:
        values = 1 + c[:, 0] if e == "gain" else 100 * c[:, 0] if e == "load_coulomb" else c[:, 0]
        unit = ("kg" if T == "N" else "kg·m²") if e == "rotor_inertia" else T
        return ONE_COLUMN[e].format(v=_list(values, 4 if e == "gain" else 3), T=unit, V=V, on=on)
    if e == "stribeck":
        assert term.hyper is not None  # an effect with a grid: its term carries the value
        return (f"breakaway friction {_list(c[:, 0])} {T} above the Coulomb level at standstill on {on}, "
                f"gone by |q̇| ≈ {2 * term.hyper:g} {V}")
    if e == "asymmetric_coulomb":
        return (f"dry friction of {_list(c[:, 0])} {T} in the positive direction and {_list(c[:, 1])} {T} in the "
                f"negative direction on {on}")
    if e == "spring":
        rest = [-row[1] / row[0] if row[0] != 0 else float("nan") for row in c]
        return (f"a spring K·(q − q₀), K = {_list(c[:, 0])} {T} per {V.split('/')[0]}, rest angle q₀ = {_list(rest)}, "
                f"varying by {_list(_swings(term, c, motion))} {T} over the fitted motion on {on}: a spring, cable or "
                "gravity compensator (q₀ is only known where the model has no offset of its own)")
    if e == "gravity_error":
        return (f"a torque A·sin q + B·cos q of amplitude {_list(np.hypot(c[:, 0], c[:, 1]))} {T} on {on}, varying by "
                f"{_list(_swings(term, c, motion))} {T} over the fitted motion: a gravity model error (a link mass or "
                "centre of mass the rigid-body model gets wrong)")
    if e == "spring_v1":
        return (f"a torque that depends on position, varying by {_list(_swings(term, c, motion))} {T} over the fitted "
                f"motion on {on} (Kq·q + Ks·sin q + Kc·cos q; a model file of format version 1)")
    if e in ("cogging", "position_error"):
        assert term.hyper is not None  # an effect with a grid: its term carries the value
        amp = np.hypot(c[:, 0], c[:, 1])
        seen = "" if motion is None else \
            f", seen over {min(periods_seen(motion.range[j], term.hyper) for j in term.joints):.2g} periods"
        if e == "position_error":
            return (f"position-dependent model error on {on}: smooth basis sin {term.hyper:g}q, cos {term.hyper:g}q, "
                    f"amplitude {_list(amp)} {T}{seen} (fewer than {MIN_PERIODS:g}: not told apart from gravity, "
                    "cable or any smooth error in q)")
        return (f"a ripple of amplitude {_list(amp)} {T}, {term.hyper:g} periods per turn (every {360 / term.hyper:.3g}°) "
                f"on {on}{seen}: motor cogging or gear meshing")
    return EFFECTS[e].explanation


def unnamed(term: Term, ev: dict) -> str:
    """A term kept for prediction whose evidence does not hold under correlated residuals: what it is."""
    cols = ", ".join(EFFECTS[term.effect].column_names)
    why = (f"kept because it predicts the selection data better (ΔBIC {ev['delta_bic_selection']:.1f} as if the "
           "samples were independent)") if "delta_bic_selection" in ev else \
        f"kept in place of {ev.get('replaces', 'a term')} that was not named"
    return (f"a model error of the form of {term.effect} (columns {cols}) on {_on(term.joints)}, {why}; not named "
            f"{term.effect}: under correlated residuals its evidence is ΔBIC_eff {ev.get('delta_bic_eff', float('nan')):.1f} "
            f"(N_eff {ev.get('n_eff', float('nan')):.0f}), short of -10")


def describe_terms(design: Design, fit, motion=None, evidence=None) -> list[dict]:
    """The final model's added effects: ids, joints, coefficients, a line written from them, and the
    evidence that added each (``evidence``: term -> dict, from ``diagnose.term_evidence``)."""
    out = []
    for t, c in zip(design.terms, term_coefficients(design, full_theta(fit, design.p)), strict=True):
        names = t.names()
        entry: dict = {"effect": t.effect, "joints": [j + 1 for j in t.joints], "hyper": t.hyper,
                       "coefficients": {nm: float(v) for nm, v in zip(names, c.reshape(-1), strict=True)},
                       "explanation": explain(t, c, design, motion)}
        if evidence is not None and t in evidence:
            ev = dict(evidence[t])
            entry["evidence"] = ev
            if not ev.get("named", True):
                entry["explanation"] = unnamed(t, ev)
        out.append(entry)
    return out


STILL_NOTE = 0.10  # share of still samples on a joint worth naming beside a wrong-sign friction term


def describe_rejected(r: Rejected, data_reports: list[dict]) -> dict:
    """A wrong-sign candidate: what it would have removed, its values, and what it most likely is."""
    e = EFFECTS[r.term.effect]
    assert e.bounds is not None  # a candidate is rejected for a coefficient outside its bounds
    lo, hi = e.bounds
    bad = [(j, row) for j, row in zip(r.term.joints, r.coefficients, strict=True) if not in_bounds(r.term.effect, row)]
    shown = ", ".join(f"{e.column_names[0]}{j + 1} = {row[0]:.3g}" for j, row in bad)
    rng = f"≥ {lo:g}" if math.isinf(hi) else f"in [{lo:g}, {hi:g}]"
    share = (data_reports[0].get("still_share") or []) if data_reports else []
    still = [(j, share[j]) for j, _ in bad if j < len(share) and share[j] > STILL_NOTE]
    text = (f"{r.term.label()} would remove {100 * r.gain:.1f} % of the selection residual energy, but {shown} "
            f"(physical range {rng}): most likely {e.misfit}")
    if still:
        least, most = min(s for _, s in still), max(s for _, s in still)
        pct = f"{100 * least:.0f} %" if round(100 * least) == round(100 * most) else f"{100 * least:.0f}-{100 * most:.0f} %"
        text += f" ({_on([j for j, _ in still])} still {pct} of the time)"
    return {"effect": r.term.effect, "joints": [j + 1 for j in r.term.joints], "hyper": r.term.hyper,
            "selection_gain": r.gain, "delta_bic_selection": r.delta_bic,
            "coefficients": {nm: float(v) for nm, v in zip(r.term.names(), np.asarray(r.coefficients).reshape(-1), strict=True)},
            "reading": text}


def _rotor_homes(chain, seed: int) -> dict[str, list[tuple[int, float]]]:
    """Base parameter name -> (joint, coefficient) of the rotor inertias that regroup into it (when not declared)."""
    from minparam_cli.base.qr import derive_qr
    from minparam_cli.params import EXTRA_ORDER

    extras = tuple(tuple(k for k in EXTRA_ORDER if k in ex or k == "rotor_inertia") for ex in chain.layout.extras)
    base = derive_qr(chain.with_extras(extras), seed=seed)
    names = base.standard_names
    homes: dict[str, list[tuple[int, float]]] = {}
    for j in chain.coordinates:
        col = names.index(f"Ia{j + 1}")
        for i, bname in enumerate(base.base_names):
            if bname != f"Ia{j + 1}" and abs(base.K[i, col]) > 0:
                homes.setdefault(bname, []).append((j, float(base.K[i, col])))
    return homes


def nominal_notes(chain, base, fit, seed: int = 0) -> list[str]:
    """Base parameters far from the description's nominal values.

    A payload or a wrong link mass shows here.  So does an undeclared rotor inertia of a joint whose
    Ia regroups into a base parameter (Ia1 into ZZR1 when joint 1's axis is fixed in the base):
    that is said instead of a payload when it can be the cause.  Parameters that hold declared
    rotor or friction extras have no nominal value and are left out."""
    if chain.phi_nominal is None:
        return []
    phi = np.zeros(chain.layout.size)
    phi[: len(chain.phi_nominal)] = chain.phi_nominal
    nominal = base.K @ phi
    notes = []
    scale = np.max(np.abs(nominal)) if np.any(nominal) else 1.0
    where = {c: k for k, c in enumerate(fit.columns)}
    n_inertial = chain.layout.n_inertial
    homes = None
    for i, name in enumerate(base.base_names):
        if i not in where or np.any(np.abs(base.K[i, n_inertial:]) > 0):
            continue
        k = where[i]
        v, nom = fit.theta[k], nominal[i]
        sd = abs(v) * fit.std_percent[k] / 100 if np.isfinite(fit.std_percent[k]) else np.inf
        if abs(v - nom) > max(3 * sd, 0.2 * abs(nom), 0.02 * scale):
            homes = _rotor_homes(chain, seed) if homes is None else homes
            # a rotor inertia Ia > 0 moves the parameter by coefficient·Ia: only that direction is explained
            rotors = [j for j, c in homes.get(name, []) if c * (v - nom) > 0]
            if rotors:
                js = ", ".join(f"Ia{j + 1}" for j in rotors)
                notes.append(f"{name} = {v:.4g} differs from its nominal {nom:.4g} by {v - nom:+.4g}: most likely rotor inertia "
                             f"({js} regroups into {name}; declare --rotor-inertia to name it), else a payload or a wrong link inertia")
            else:
                notes.append(f"{name} = {v:.4g} differs from its nominal {nom:.4g}: a payload, a wrong link mass or inertia, not an effect")
    return notes
