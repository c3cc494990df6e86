"""``minparam excite``'s result: the excitation trajectory."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import numpy as np

    from minparam_cli.experiment.excite.design import ExciteResult

SCHEMA = "minparam.excite/1"


@dataclass(frozen=True)
class Excitation:
    """An excitation trajectory (``minparam excite``): samples t (N,), q, dq, ddq (N, dof) in SI units
    over ``periods`` periods, the Fourier coefficients ``q0`` (dof,), ``a``, ``b`` (dof, harmonics) of
    Swevers' series, the criterion on the design grid and the base regressor's condition number on the
    samples (column-scaled and in SI units).  ``tau``: the nominal rigid-body torques (None without
    inertial values).  ``to_dict()`` is the ``--json`` record, ``to_csv()`` the ``-o`` file."""

    robot: str  # the robot file
    robot_name: str
    t: np.ndarray = field(repr=False)
    q: np.ndarray = field(repr=False)
    dq: np.ndarray = field(repr=False)
    ddq: np.ndarray = field(repr=False)
    tau: np.ndarray | None = field(repr=False)
    q0: np.ndarray = field(repr=False)
    a: np.ndarray = field(repr=False)
    b: np.ndarray = field(repr=False)
    base_frequency: float
    criterion: float
    condition_number: float
    condition_number_si: float
    base_names: tuple[str, ...]
    seed: int
    effects: dict[str, Any] = field(repr=False)  # the regressor's declared friction, rotor inertia and columns
    design: ExciteResult = field(repr=False)  # the design stage's result

    @property
    def harmonics(self) -> int:
        return int(self.a.shape[1])

    def evaluate(self, t: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """q, dq, ddq (len(t), dof) of the series at times ``t`` (s): exact, not interpolated."""
        import numpy as np

        return self.design.trajectory.evaluate(np.asarray(t, dtype=float))

    def arrays(self) -> dict[str, np.ndarray]:
        """{"t", "q", "dq", "ddq"}: the samples, as ``simulate``'s trajectory input reads them."""
        return {"t": self.t, "q": self.q, "dq": self.dq, "ddq": self.ddq}

    def to_dict(self) -> dict[str, Any]:
        """The ``--json`` record: coefficients, criterion, starts, limits used, effects."""
        from minparam_cli.render.excite_text import json_record

        return {"schema": SCHEMA, **json_record(self.design, self.robot, self.robot_name, self.seed, self.effects)}

    def to_csv(self) -> str:
        """The CSV ``minparam excite -o`` writes: t, q1..qn, dq1..dqn, ddq1..ddqn."""
        from minparam_cli.render.excite_text import csv_text

        return csv_text(self.design)

    def summary(self) -> str:
        """The lines ``minparam excite`` prints on stderr (criterion, condition number, limits used)."""
        from minparam_cli.render.excite_text import summary_text

        return summary_text(self.design, self.robot_name, self.seed)
