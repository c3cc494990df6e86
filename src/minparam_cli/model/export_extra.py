"""What an exported robot carries besides its bodies, and the side file for what its format cannot say.

``joint_terms`` gathers, per joint, the identified terms a simulator's joint can hold, from the
physical fit: the declared extras of φ (``Ia``, ``Fc``, ``Fv``; ``OFF``) and the diagnosed effects
of the design (their coefficients are the tail of the physical fit's θ, term by term):

* rotor inertia: ``Ia_j`` + a diagnosed ``rotor_inertia`` + the rotor inertia ``r²·Iam_k`` of an
  uncoupled motor k on joint j (row k of N has the one entry r): MJCF ``armature``;
* viscous friction ``Fv_j`` (+ ``viscous``, + ``r²·Fvm_k``): URDF ``damping``, MJCF ``damping``;
* Coulomb friction ``Fc_j`` (+ ``coulomb``, + ``|r|·Fcm_k``): URDF ``friction``, MJCF ``frictionloss``;
* drive gains: the gear from control to joint torque, ``N_kk·g_k`` with drive gains g (uncoupled
  motors; the transmission's declared ``drive_gains``, or those ``--payload-data`` identified), ``1/(1 + G_j)`` with a diagnosed ``gain`` (the measured torque
  is (1 + G)·τ, so a control in measured-torque units gives τ = ctrl/(1 + G)), else 1: MJCF
  ``<motor gear>``.

Everything else — offsets, springs, cogging, Stribeck and asymmetric friction, load-dependent
friction, drift, motor-side terms of coupled motors, a smooth Coulomb law, and, per format, what it
lacks (a URDF has no gravity, rotor inertia or drive gains) — goes into the side file
``FILE.extra.yaml`` (format in docs/simulation.md), written with the export.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

SIDE_SUFFIX = ".extra.yaml"
SIDE_FORMAT = "minparam-export-extra"


@dataclass
class JointTerms:
    """Per joint (chain order): the terms a joint element can hold, and the rest by name."""

    names: tuple[str, ...]
    armature: np.ndarray
    damping: np.ndarray
    friction: np.ndarray
    gear: np.ndarray
    gear_source: str = "none"  # none (gear 1: control in N·m), declared drive gains, or identified gain effect
    offsets: dict[str, float] = field(default_factory=dict)  # joint name -> constant torque (OFF + offset effect)
    effects: list[dict] = field(default_factory=list)  # other diagnosed effects: {effect, joint, hyper, coefficients}
    motors: list[dict] = field(default_factory=list)  # motor-side terms of coupled motors
    smoothing: float = 0.0  # Coulomb friction is tanh(q̇/v_c) when > 0
    has_friction: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))  # a viscous or Coulomb term
    # diagnosed terms written into the format's own fields (damping, frictionloss, armature, gear, offsets)
    # whose evidence did not earn them their physical name (docs/methods/selection.md): "effect (joints)"
    unnamed: list[str] = field(default_factory=list)


def joint_terms(chain, phi: np.ndarray, terms=(), coefficients=(), drive_gains=None,
                gains_source: str = "declared drive gains", evidence=()) -> JointTerms:
    """The per-joint terms of the full parameters ``phi`` (chain.layout order) and of the diagnosed
    ``terms`` (``identify.passes.design.Term``) with their ``coefficients`` (θ's tail, in term order).
    ``drive_gains``: the drive gains per motor (declared, or identified with a payload; ``gains_source``
    says which), or None; ``evidence``: per term, the evidence saved with it (``named``: whether it earned
    its physical name), or None."""
    from minparam_cli.dynamics.effects import EFFECTS

    n, layout = chain.n, chain.layout
    out = JointTerms(tuple(chain.joint_names), np.zeros(n), np.zeros(n), np.zeros(n), np.ones(n),
                     smoothing=float(chain.coulomb_smoothing), has_friction=np.zeros(n, dtype=bool))
    N = np.eye(n) if chain.transmission is None else np.asarray(chain.transmission.matrix, dtype=float)
    field_of = {"rotor_inertia": out.armature, "viscous": out.damping, "coulomb": out.friction}
    motor_of = {"motor_inertia": (out.armature, 2), "motor_viscous": (out.damping, 2), "motor_coulomb": (out.friction, 1)}
    for c, (j, kind) in enumerate(layout.extra_columns):
        value = float(phi[layout.n_inertial + c])
        if kind in field_of:
            field_of[kind][j] += value
            out.has_friction[j] |= kind != "rotor_inertia"
        elif kind == "offset":
            out.offsets[chain.joint_names[j]] = out.offsets.get(chain.joint_names[j], 0.0) + value
        elif kind in motor_of:
            row = np.flatnonzero(N[j])
            if len(row) == 1:  # an uncoupled motor: a joint term (dynamics/transmission.py)
                target, power = motor_of[kind]
                target[row[0]] += abs(N[j, row[0]]) ** power * value
                out.has_friction[row[0]] |= kind != "motor_inertia"
            else:
                out.motors.append({"motor": j + 1, "term": kind, "value": value,
                                   "row": [float(x) for x in N[j]]})
    at = 0
    for ti, t in enumerate(terms):
        width = t.width()
        values = [float(x) for x in coefficients[at : at + width]]
        at += width
        per = len(EFFECTS[t.effect].column_names)
        ev = evidence[ti] if ti < len(evidence) else None
        if ev is not None and ev.get("named") is False and t.effect in FOLDED_EFFECTS:
            out.unnamed.append(f"{t.effect} ({', '.join(chain.joint_names[j] for j in t.joints)})")
        for i, j in enumerate(t.joints):
            mine = values[i * per : (i + 1) * per]
            if t.effect in field_of:
                field_of[t.effect][j] += mine[0]
                out.has_friction[j] |= t.effect != "rotor_inertia"
            elif t.effect == "offset":
                out.offsets[chain.joint_names[j]] = out.offsets.get(chain.joint_names[j], 0.0) + mine[0]
            elif t.effect == "gain":
                out.gear[j] = 1.0 / (1.0 + mine[0])
                out.gear_source = "identified gain effect"
            else:
                names = EFFECTS[t.effect].names(j, t.hyper)
                entry = {"effect": t.effect, "joint": chain.joint_names[j], "hyper": t.hyper,
                         "coefficients": dict(zip(names, mine, strict=True)),
                         "meaning": EFFECTS[t.effect].explanation}
                if ev is not None:
                    entry["named"] = bool(ev.get("named", True))
                    entry["evidence"] = {k: v for k, v in ev.items() if k != "named"}
                out.effects.append(entry)
    if drive_gains is not None and out.gear_source == "none":
        for k, g in enumerate(drive_gains):
            row = np.flatnonzero(N[k])
            if len(row) == 1:
                out.gear[row[0]] = float(N[k, row[0]]) * float(g)
            else:  # a coupled motor's control moves several joints: no joint actuator holds it
                out.motors.append({"motor": k + 1, "term": "drive_gain", "value": float(g), "row": [float(x) for x in N[k]]})
        out.gear_source = gains_source
    return out


# diagnosed effects folded into the formats' own fields (armature, damping, frictionloss, offsets, gear); the others
# are listed term by term in the side file, with their evidence
FOLDED_EFFECTS = ("rotor_inertia", "viscous", "coulomb", "offset", "gain")


def side_path(path) -> str:
    """The side file of an export: ``FILE.extra.yaml`` beside it."""
    return f"{path}{SIDE_SUFFIX}"


def side_document(fmt: str, export_name: str, robot: str, terms: JointTerms, gravity=None,
                  joint_fields: tuple[str, ...] = ()) -> dict:
    """The side file's content: what ``fmt`` (urdf or mjcf) cannot express.  ``gravity``: written when
    the format has none; ``joint_fields``: the JointTerms fields (armature, gear) it lacks."""
    doc: dict = {"format": SIDE_FORMAT, "version": 1, "export": export_name, "export_format": fmt, "robot": robot}
    if gravity is not None:
        doc["gravity"] = [float(x) for x in gravity]
    joints: dict[str, dict] = {}
    for j, name in enumerate(terms.names):
        entry: dict = {}
        if name in terms.offsets:
            entry["offset"] = terms.offsets[name]
        if "armature" in joint_fields and terms.armature[j] != 0:
            entry["rotor_inertia"] = float(terms.armature[j])
        if "gear" in joint_fields and terms.gear_source != "none":
            entry["gear"] = float(terms.gear[j])
        if entry:
            joints[name] = entry
    if joints:
        doc["joints"] = joints
    if "gear" in joint_fields and terms.gear_source != "none":
        doc["gear_source"] = terms.gear_source
    if terms.smoothing > 0 and np.any(terms.friction != 0):
        doc["coulomb_smoothing"] = terms.smoothing
    if terms.effects:
        doc["effects"] = terms.effects
    if terms.motors:
        doc["coupled_motors"] = terms.motors
    if terms.unnamed:
        doc["unnamed_in_export"] = {
            "terms": list(terms.unnamed),
            "why": "written into the export's own fields (damping, friction, armature, offsets, gear) so that it "
                   "reproduces the identified torques, but their evidence under correlated residuals did not earn "
                   "them the physical name (docs/methods/selection.md): read them as model error of that form"}
    return doc


def side_summary(doc: dict) -> str:
    """The one line naming what went into a side file (empty: nothing but the header)."""
    parts = []
    if "gravity" in doc:
        parts.append("gravity")
    joints = doc.get("joints", {})
    for key, label in (("offset", "offsets"), ("rotor_inertia", "rotor inertia"), ("gear", "drive gains")):
        which = [name for name, e in joints.items() if key in e]
        if which:
            parts.append(f"{label} ({', '.join(which)})")
    if "coulomb_smoothing" in doc:
        parts.append("the smooth Coulomb law")
    if doc.get("effects"):
        parts.append("effects " + ", ".join(sorted({f"{e['effect']} ({e['joint']})" for e in doc["effects"]})))
    if doc.get("coupled_motors"):
        parts.append("coupled-motor terms")
    if doc.get("unnamed_in_export"):
        parts.append("which folded terms lack the evidence for their name (" + ", ".join(doc["unnamed_in_export"]["terms"]) + ")")
    return "; ".join(parts)


def dumps_side(doc: dict) -> str:
    import yaml

    head = ("# what the export beside this file cannot express (minparam identify; format: docs/simulation.md)\n")
    return head + yaml.safe_dump(doc, sort_keys=False, allow_unicode=True, default_flow_style=None, width=120)
