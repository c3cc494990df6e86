"""Results of identify and evaluate in the Python API: ``Identification``, ``Model``, ``Evaluation``.

Each wraps the stage's own typed result (``identify.result.IdentifyResult``,
``model.evaluation.EvaluateResult``, ``model.file.SavedModel``) and adds what a Python caller wants
beside it (predictions, the model object); ``to_dict()`` is the stage result's, the JSON that
``minparam identify/evaluate --format json`` prints for the same call.  ``Errors`` is the stage's
errors record (``identify.estimate.errors.Errors``), re-exported.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from minparam_cli.identify.estimate.errors import Errors

__all__ = ["Errors", "Evaluation", "Identification", "Model"]

if TYPE_CHECKING:
    import numpy as np

    from minparam_cli.identify.passes.design import Design
    from minparam_cli.identify.result import IdentifyResult
    from minparam_cli.model.evaluation import EvaluateResult
    from minparam_cli.model.file import SavedModel


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
        for name, x in zip(("q", "dq", "ddq"), arrays, strict=True):
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
class Identification:
    """An identification (``minparam identify``): ``result``, the stage's typed report (fitted
    parameters, the effects the diagnosis added, errors before (rigid body) and after on the selection
    data and on the test data that chose nothing), and ``model``, the identified model.  ``test``: the
    final model's errors on the test data, ``test_rigid``: the rigid-body model's (None without test
    data)."""

    result: IdentifyResult = field(repr=False)
    model: Model = field(repr=False)
    artifacts: Any = field(default=None, repr=False, compare=False)  # identify.stage.Artifacts (plots)

    @property
    def robot(self) -> str:
        return self.result.robot

    @property
    def names(self) -> tuple[str, ...]:
        """Every column of the final design (the model's parameters)."""
        return self.model.names

    @property
    def theta(self) -> np.ndarray:
        """The parameters of every column (0 where regrouped on this data), a copy."""
        return self.model.saved.theta.copy()

    @property
    def std_percent(self) -> tuple[float | None, ...]:
        return self.model.saved.std_percent

    @property
    def before(self) -> Errors:
        return self.result.before

    @property
    def after(self) -> Errors:
        return self.result.after

    @property
    def test(self) -> Errors | None:
        return self.result.test.final

    @property
    def test_rigid(self) -> Errors | None:
        return self.result.test.rigid

    @property
    def effects(self) -> tuple[dict[str, Any], ...]:
        return tuple(dict(e) for e in self.result.effects)

    @property
    def flags(self) -> tuple[str, ...]:
        return self.result.flags

    @property
    def parameters(self) -> dict[str, float]:
        """{parameter name: value} of the final fit."""
        return {n: float(v) for n, v in zip(self.names, self.model.saved.theta, strict=True)}

    def to_dict(self) -> dict[str, Any]:
        """The JSON of ``minparam identify --format json`` for the same call."""
        return self.result.to_dict()

    def predict(self, q: Any, dq: Any, ddq: Any, t: Any = None) -> np.ndarray:
        """Torques (N, dof) the identified model predicts at joint states q, dq, ddq (N, dof)."""
        return self.model.predict(q, dq, ddq, t)

    def summary(self) -> str:
        """The report as ``minparam identify`` prints it."""
        from minparam_cli.render.identify_text import render_identify

        return render_identify(self.result)


@dataclass(frozen=True)
class Evaluation:
    """``minparam evaluate``: errors of a saved model on data, per file and pooled (``result``: the
    stage's typed report)."""

    result: EvaluateResult = field(repr=False)

    @property
    def which(self) -> str:
        return self.result.which

    @property
    def pooled(self) -> Errors:
        return self.result.evaluation.pooled.errors()

    @property
    def files(self) -> tuple[str, ...]:
        return tuple(path for path, _, _ in self.result.evaluation.files)

    def to_dict(self) -> dict[str, Any]:
        """The JSON of ``minparam evaluate --format json`` for the same call."""
        return self.result.to_dict()

    def summary(self) -> str:
        """The report as ``minparam evaluate`` prints it."""
        from minparam_cli.render.evaluate_text import render_evaluate

        return render_evaluate(self.result)
