"""The model file: what `identify --save-model` writes and `minparam evaluate` reads.

One JSON document holds everything needed to predict torques again:

* the robot file (path as given, and the SHA-256 of its bytes) and the options it was loaded
  with (declared friction, rotor inertia, gravity override, Coulomb smoothing, mimic and
  floating-base handling);
* the base set: the seed of the QR route and the kept columns with their names.  On loading,
  the same route with the same seed on the same robot must keep the same columns, or the
  parameters would be paired with other columns: the model is refused then;
* the final design's terms (effect id, joints, grid value), ``theta_model`` (the rigid-body
  parameters the gain and load-Coulomb columns read) and ``t0`` (the drift origin);
* the final parameters θ (every design column, 0 where regrouped on the identify data) with
  their names and relative σ; with ``--physical`` the full standard parameters φ and the physical
  fit's θ;
* the data settings (``DataOptions``) and the identify report's headline figures.

``identify.evaluation`` predicts with such a model on other data files; ``identify.model_parse``
reads one back (``read_model``, ``parse_model``).  No function here reads or writes a file.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from minparam_cli.errors import InputError
from minparam_cli.measured.records import DataOptions
from minparam_cli.identify.estimate.records import selection_dict
from minparam_cli.identify.passes.design import Design, Term

if TYPE_CHECKING:
    from minparam_cli.identify.result import IdentifyResult

FORMAT = "minparam-model"
# version 2 (issue 32): the spring is K·(q − q₀) (columns q, 1), each term carries its evidence; version 1
# files are read with their spring as it was (columns q, sin q, cos q: effects.LEGACY_SPRING) and no evidence
VERSION = 2
READS = (1, 2)
# DataOptions fields a version-1 model stores (all of them)
DATA_KEYS = ("columns", "cutoff_hz", "force_filter", "chunk_rows", "decimate", "step_s", "still_speed", "trim_still_s")


class ModelError(InputError):
    """A model file that cannot be used (exit code 2)."""


@dataclass(frozen=True)
class LoadSettings:
    """How the robot file was turned into the chain (``robot.DeriveOptions`` plus Coulomb smoothing)."""

    friction: tuple[str, ...] = ()
    rotor_inertia: bool = False
    gravity: tuple[float, float, float] | None = None
    coulomb_smoothing: float = 0.0
    mimic: str = "coupled"
    floating_base: bool = False

    def derive_options(self, seed: int):
        from minparam_cli.robot import DeriveOptions

        return DeriveOptions(friction=self.friction, rotor_inertia=self.rotor_inertia, gravity=self.gravity,
                             seed=seed, mimic=self.mimic, floating_base=self.floating_base)

    def to_dict(self) -> dict:
        return {"friction": list(self.friction), "rotor_inertia": self.rotor_inertia,
                "gravity": None if self.gravity is None else list(self.gravity),
                "coulomb_smoothing": self.coulomb_smoothing, "mimic": self.mimic, "floating_base": self.floating_base}


@dataclass(frozen=True)
class PhysicalParameters:
    phi_names: tuple[str, ...]
    phi: np.ndarray  # full standard parameters, chain.layout order
    theta: np.ndarray  # the design's parameters of the physical fit: [K·φ; effect coefficients]


@dataclass(frozen=True)
class SavedModel:
    """A parsed model file (fields as in the module docstring; ``to_dict`` is the JSON contract)."""

    robot: str
    robot_sha256: str
    load: LoadSettings
    seed: int
    kept: tuple[int, ...]
    base_names: tuple[str, ...]
    terms: tuple[Term, ...]
    theta_model: np.ndarray | None
    t0: float | None
    names: tuple[str, ...]
    theta: np.ndarray
    std_percent: tuple[float | None, ...]
    data: DataOptions
    physical: PhysicalParameters | None = None
    figures: dict = field(default_factory=dict)
    uncertainty: dict | None = None  # {"sigma", "columns", "covariance", "residual_sigma_per_joint"}: prediction bands
    evidence: tuple[dict | None, ...] = ()  # per term: what added it (ΔBIC_eff, N_eff, periods seen); () or None: unknown

    def to_dict(self) -> dict:
        out: dict[str, Any] = {
            "format": FORMAT,
            "version": VERSION,
            "robot": {"path": self.robot, "sha256": self.robot_sha256},
            "load": self.load.to_dict(),
            "base": {"method": "qr", "seed": self.seed, "kept": list(self.kept), "names": list(self.base_names)},
            "design": {
                "terms": [{"effect": t.effect, "joints": [j + 1 for j in t.joints], "hyper": t.hyper,
                           "evidence": self.term_evidence(i)} for i, t in enumerate(self.terms)],
                "theta_model": None if self.theta_model is None else [float(x) for x in self.theta_model],
                "t0": self.t0,
            },
            "parameters": {"names": list(self.names), "theta": [float(x) for x in self.theta],
                           "std_percent": list(self.std_percent)},
            "physical": None,
            "data": {k: (dict(v) if k == "columns" else v) for k, v in ((k, getattr(self.data, k)) for k in DATA_KEYS)},
            "figures": self.figures,
        }
        if self.uncertainty is not None:
            out["uncertainty"] = self.uncertainty
        # derived velocities below still_speed read as rest (identify's default since issue 16); a model
        # without the key was saved before and is evaluated as it was fitted, with the plain sign(q̇)
        out["data"]["rest_below_still"] = bool(self.data.rest_below_still)
        if self.data.motor_side is not None:  # identify --side motor: the conversion the data were read with
            rows, zero, gains = self.data.motor_side
            out["data"]["motor_side"] = {"matrix": [list(r) for r in rows], "zero": list(zero),
                                         "gains": None if gains is None else list(gains)}
        if self.physical is not None:
            out["physical"] = {"phi_names": list(self.physical.phi_names), "phi": [float(x) for x in self.physical.phi],
                               "theta": [float(x) for x in self.physical.theta]}
        return out

    def term_evidence(self, i: int) -> dict | None:
        """The evidence saved with term i (None: a model saved before evidence was kept)."""
        return self.evidence[i] if i < len(self.evidence) else None

    def fit_theta(self, which: str) -> np.ndarray:
        """θ of the unconstrained fit ("fit") or of the physical fit ("physical")."""
        if which == "physical":
            if self.physical is None:
                raise ModelError("the model has no physical fit (identify was run without --physical); use --model fit")
            return self.physical.theta
        return self.theta


def sha256_hex(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def saved_model(robot: str, robot_bytes: bytes, load: LoadSettings, data: DataOptions, seed: int, artifacts,
                result: IdentifyResult) -> SavedModel:
    """The model of one identify run: its ``Artifacts`` (final design, θ, σ, physical fit) and result."""
    d = artifacts.design
    physical = None
    if artifacts.physical is not None:
        pf = artifacts.physical
        physical = PhysicalParameters(tuple(pf.names), np.asarray(pf.phi, dtype=float), np.asarray(pf.theta, dtype=float))
    figures = {"selection": {"before": selection_dict(result.before), "after": selection_dict(result.after)},
               "test": result.test.to_dict()}
    if result.physical is not None:
        figures["physical"] = {"selection": result.physical.selection.to_dict(),
                               "test": {k: e.to_dict() for k, e in result.physical.test.items()}}
    return SavedModel(
        robot=str(robot), robot_sha256=sha256_hex(robot_bytes), load=load, seed=int(seed),
        kept=tuple(int(k) for k in d.kept), base_names=tuple(d.base_names), terms=tuple(d.terms),
        theta_model=None if d.theta_model is None else np.asarray(d.theta_model, dtype=float),
        t0=None if d.t0 is None else float(d.t0), names=tuple(d.names), theta=np.asarray(artifacts.theta, dtype=float),
        std_percent=tuple(float(s) if math.isfinite(s) else None for s in artifacts.std_percent),
        data=data, physical=physical, figures=figures, uncertainty=_uncertainty(artifacts, result),
        evidence=_evidence(d.terms, result),
    )


def _evidence(terms, result: IdentifyResult) -> tuple[dict | None, ...]:
    """Each term's evidence from the report's effects (the same terms, in the same order)."""
    out: list[dict | None] = [None] * len(terms)
    for i, (t, e) in enumerate(zip(terms, result.effects, strict=False)):
        if e.get("effect") == t.effect and "evidence" in e:
            out[i] = dict(e["evidence"])
    return tuple(out)


def _uncertainty(artifacts, result: IdentifyResult) -> dict | None:
    """The covariance of the fitted parameters (the kind the report shows) and the residual σ per joint."""
    u = getattr(artifacts, "uncertainty", None)
    if u is None:
        return None
    return {"sigma": u.kind, "columns": [int(c) for c in u.columns],
            "covariance": [[float(x) for x in row] for row in u.cov],
            "residual_sigma_per_joint": [float(x) for x in result.sigma_per_joint]}


def dumps(model: SavedModel) -> str:
    """The model as JSON: objects one key a line, lists on one line (a parameter vector stays a line)."""

    def fmt(v, depth: int) -> str:
        if isinstance(v, dict) and v and depth < 3:
            pad = " " * (depth + 1)
            items = ",\n".join(f"{pad}{json.dumps(k)}: {fmt(x, depth + 1)}" for k, x in v.items())
            return "{\n" + items + "\n" + " " * depth + "}"
        return json.dumps(v, ensure_ascii=False, allow_nan=False)

    return fmt(model.to_dict(), 0) + "\n"


# --- the robot and the design ---------------------------------------------------------------------


def check_robot(model: SavedModel, model_source: str, robot: str, robot_bytes: bytes) -> None:
    """Refuse a robot file whose bytes are not the ones the model was made for."""
    sha = sha256_hex(robot_bytes)
    if sha == model.robot_sha256:
        return
    made = f"{model_source} was made for {model.robot} (sha256 {model.robot_sha256[:12]}…)"
    if Path(robot) == Path(model.robot):
        raise ModelError(f"{made}; {robot} has changed since (sha256 {sha[:12]}…)")
    raise ModelError(f"{made}, not for {robot} (sha256 {sha[:12]}…)")


def model_design(model: SavedModel, chain, model_source: str) -> Design:
    """The model's design on ``chain``: its base columns checked against the QR route with the model's
    seed (the parameters θ are only meaningful on the columns they were fitted to)."""
    from minparam_cli.base.qr import derive_qr

    if model.physical is not None and tuple(chain.layout.names) != model.physical.phi_names:
        raise ModelError(f"{model_source}: the robot's standard parameters ({len(chain.layout.names)}) are not the "
                         f"model's physical.phi_names ({len(model.physical.phi_names)})")
    for i, t in enumerate(model.terms):
        if max(t.joints) >= chain.dof:
            raise ModelError(f"{model_source}: design.terms[{i}] names joint {max(t.joints) + 1}; the robot has {chain.dof}")
    base = derive_qr(chain, seed=model.seed)
    if tuple(base.kept) != model.kept or tuple(base.base_names) != model.base_names:
        raise ModelError(f"{model_source}: the QR route with seed {model.seed} keeps other base columns on this robot "
                         f"({len(base.kept)} base parameters, the model has {len(model.kept)}): the parameters would "
                         "not match their columns")
    design = Design(chain, model.kept, model.base_names, model.terms, model.theta_model, model.t0)
    if design.names != model.names:
        raise ModelError(f"{model_source}: parameters.names are not the names of the design's columns")
    return design
