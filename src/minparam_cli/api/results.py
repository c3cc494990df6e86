"""Typed, frozen result objects of the Python API.

Every result keeps the JSON report of the CLI command it corresponds to; ``to_dict()`` returns a
deep copy of it (so the two cannot drift: tests/test_api_cli_json.py), and the typed fields are read
from the same computation.  Arrays are numpy arrays, names are tuples of str.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from minparam_cli.api.check_result import CheckResult as CheckResult  # re-exported
from minparam_cli.api.excitation_result import Excitation as Excitation  # re-exported
from minparam_cli.api.generated import GeneratedCode as GeneratedCode  # re-exported
from minparam_cli.api.platform_result import PlatformResult as PlatformResult  # re-exported
from minparam_cli.api.simulation_result import Simulation as Simulation  # re-exported
from minparam_cli.api.singularity import Singularity as Singularity  # re-exported
from minparam_cli.base.result import BaseSet as BaseSet  # re-exported: the one base set

if TYPE_CHECKING:
    import numpy as np

    from minparam_cli.chain import Chain
    from minparam_cli.describe.records import RobotDescription
    from minparam_cli.identify.passes.design import Design
    from minparam_cli.model.file import SavedModel


class _Report:
    """Mixin: the CLI's JSON report, kept as ``_report``."""

    _report: dict[str, Any]

    def to_dict(self) -> dict[str, Any]:
        """The CLI's JSON report of the same call (a deep copy: changing it changes nothing here)."""
        return copy.deepcopy(self._report)


@dataclass(frozen=True)
class LoadOptions:
    """How a robot file becomes a chain (the options every command that loads a robot takes)."""

    friction: tuple[str, ...] = ()  # any of "coulomb", "viscous", "offset", added to every joint
    rotor_inertia: bool = False  # a rotor inertia column Ia per joint
    gravity: tuple[float, float, float] | None = None  # m/s², overrides the file
    mimic: str = "coupled"  # URDF mimic joints: "coupled" or "fixed"
    floating_base: bool = False  # the URDF's root link is free
    coulomb_smoothing: float = 0.0  # tanh(dq / V) for sign(dq) in Coulomb columns; 0: sign


@dataclass(frozen=True)
class Robot:
    """A robot loaded from a file (YAML DH/MDH or URDF): its chain, ready for every computation.

    ``standard_names``: the standard parameters in column order (XXj XYj XZj YYj YZj ZZj MXj MYj MZj Mj
    per link, then the per-joint extras of ``options``).
    """

    path: Path
    name: str
    dof: int
    joint_names: tuple[str, ...]
    joint_types: tuple[str, ...]
    standard_names: tuple[str, ...]
    options: LoadOptions
    chain: Chain = field(repr=False)
    description: RobotDescription = field(repr=False)


@dataclass(frozen=True)
class Errors:
    """Torque errors of a model on some data: RMS over all joints, RMS per joint (N·m or N) and
    ‖r‖/‖τ‖."""

    rms_total: float
    rms_per_joint: tuple[float, ...]
    relative_error: float

    @staticmethod
    def from_dict(d: dict[str, Any] | None) -> Errors | None:
        if d is None:
            return None
        return Errors(float(d["rms_total"]), tuple(float(x) for x in d["rms_per_joint"]), float(d["relative_error"]))


@dataclass(frozen=True)
class Identification(_Report):
    """An identification (``minparam identify``): the fitted parameters, the effects the diagnosis
    added, and the errors before (rigid body) and after on the selection data, and on the test data
    that chose nothing (``test``: the final model, ``test_rigid``: the rigid-body model; None when the
    run has no test data)."""

    robot: str
    names: tuple[str, ...]
    theta: np.ndarray = field(repr=False)
    std_percent: tuple[float | None, ...] = field(repr=False)
    before: Errors | None = None
    after: Errors | None = None
    test: Errors | None = None
    test_rigid: Errors | None = None
    effects: tuple[dict[str, Any], ...] = ()
    flags: tuple[Any, ...] = ()
    model: Model | None = field(default=None, repr=False)
    _report: dict[str, Any] = field(default_factory=dict, repr=False)

    @property
    def parameters(self) -> dict[str, float]:
        """{parameter name: value} of the final fit."""
        return {n: float(v) for n, v in zip(self.names, self.theta)}

    def predict(self, q: Any, dq: Any, ddq: Any, t: Any = None) -> np.ndarray:
        """Torques (N, dof) the identified model predicts at joint states q, dq, ddq (N, dof)."""
        assert self.model is not None
        return self.model.predict(q, dq, ddq, t)

    def summary(self) -> str:
        """The report as ``minparam identify`` prints it."""
        from minparam_cli.render.identify_text import render_identify

        return render_identify(self._report)


@dataclass(frozen=True)
class Model:
    """An identified model: the file ``identify --save-model`` writes and ``evaluate`` reads.

    ``Model.load(path)`` reads one (checking its robot file's SHA-256), ``save(path)`` writes it,
    ``predict(q, dq, ddq)`` gives torques with the unconstrained fit, or the physical one
    (``which="physical"``)."""

    saved: SavedModel = field(repr=False)
    design: Design = field(repr=False)
    robot: str = ""
    names: tuple[str, ...] = ()

    @staticmethod
    def load(path: str | Path, robot: str | Path | None = None) -> Model:
        from minparam_cli.api.model_file import open_model

        m, robot_file, design = open_model(path, robot)
        return Model(saved=m, design=design, robot=str(robot_file), names=tuple(m.names))

    def save(self, path: str | Path) -> None:
        """Write the model file (JSON) atomically."""
        from minparam_cli.model.file import dumps
        from minparam_cli.output import write_output

        write_output(dumps(self.saved), Path(path))

    def to_dict(self) -> dict[str, Any]:
        """The model file's JSON."""
        return self.saved.to_dict()

    def theta(self, which: str = "fit") -> np.ndarray:
        return self.saved.fit_theta(which)

    def predict(self, q: Any, dq: Any, ddq: Any, t: Any = None, which: str = "fit") -> np.ndarray:
        """Torques (N, dof) at joint states q, dq, ddq (N, dof); ``t`` (N,) in s matters only to a
        drift term (default: zeros)."""
        import numpy as np

        from minparam_cli.errors import InputError
        from minparam_cli.measured.records import Block
        from minparam_cli.model.evaluation import predict as run

        n = self.design.chain.dof
        arrays = [np.atleast_2d(np.asarray(x, dtype=float)) for x in (q, dq, ddq)]
        for name, x in zip(("q", "dq", "ddq"), arrays):
            if x.ndim != 2 or x.shape != arrays[0].shape or x.shape[1] != n:
                raise InputError(f"{name}: expected shape (N, {n}) like q, got {x.shape}")
        N = arrays[0].shape[0]
        tt = np.zeros(N) if t is None else np.asarray(t, dtype=float).reshape(-1)
        if len(tt) != N:
            raise InputError(f"t: expected {N} time stamps, got {len(tt)}")
        which = str(getattr(which, "value", which))
        if which not in ("fit", "physical"):
            raise InputError(f"which: {which!r} is not one of 'fit', 'physical'")
        theta = self.saved.fit_theta(which)
        return run(self.design, theta, Block(tt, arrays[0], arrays[1], arrays[2], np.zeros((N, n))))


@dataclass(frozen=True)
class Evaluation(_Report):
    """``minparam evaluate``: errors of a saved model on data, per file and pooled."""

    which: str
    pooled: Errors | None
    files: tuple[str, ...]
    _report: dict[str, Any] = field(default_factory=dict, repr=False)
