"""Typed, frozen result objects of the Python API.

Every result keeps the JSON report of the CLI command it corresponds to; ``to_dict()`` returns a
deep copy of it (so the two cannot drift: tests/test_api_cli_json.py), and the typed fields are read
from the same computation.  Arrays are numpy arrays, names are tuples of str.  The results of
identify and evaluate (``Identification``, ``Model``, ``Evaluation``, ``Errors``) are in
``api/identified.py``.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import numpy as np

    from minparam_cli.chain import Chain
    from minparam_cli.describe.records import RobotDescription
    from minparam_cli.experiment.excite.design import ExciteResult


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
class CheckResult(_Report):
    """What ``minparam check --json`` reports for one valid robot file."""

    robot: str
    dof: int
    convention: str
    joint_types: str
    exact: bool
    inertial: bool
    _report: dict[str, Any] = field(repr=False)


@dataclass(frozen=True)
class BaseSet(_Report):
    """Base (minimal) inertial parameters: ``beta_base = K @ phi`` for standard parameters ``phi``.

    ``names[i]`` is a base parameter, ``expressions[i]`` its regrouping as text (``"ZZ1 - M1 - M2"``,
    in geometry symbols with ``symbolic=True``), ``terms[i]`` its coefficients by standard name;
    ``beta`` the regrouping coefficients (rows: base parameters, columns: ``dependent`` standard
    parameters), ``K`` the whole (n_base, n_standard) map.
    """

    robot: str
    method: str
    names: tuple[str, ...]
    expressions: tuple[str, ...]
    terms: tuple[dict[str, float], ...]
    standard_names: tuple[str, ...]
    kept: tuple[str, ...]
    dependent: tuple[str, ...]
    unidentifiable: tuple[str, ...]
    K: np.ndarray = field(repr=False)
    beta: np.ndarray = field(repr=False)
    exact: bool = False
    seed: int | None = None
    warnings: tuple[str, ...] = ()
    _report: dict[str, Any] = field(default_factory=dict, repr=False)

    @property
    def n_base(self) -> int:
        return len(self.names)

    @property
    def n_standard(self) -> int:
        return len(self.standard_names)

    def latex(self) -> str:
        """The base parameters as a LaTeX ``align*`` block (``minparam derive --format latex``)."""
        from minparam_cli.render.text import render_latex

        return render_latex(self._report)

    def markdown(self) -> str:
        """``minparam derive --format markdown``."""
        from minparam_cli.render.text import render_markdown

        return render_markdown(self._report)

    def table(self) -> str:
        """``minparam derive`` (the terminal table)."""
        from minparam_cli.render.text import render_table

        return render_table(self._report)


@dataclass(frozen=True)
class Simulation(_Report):
    """Synthetic measured data (``minparam simulate``): arrays t (N,), q, dq, ddq, tau (N, dof) in SI
    units, and the truth record (``to_dict()``, the JSON of ``--truth``)."""

    t: np.ndarray = field(repr=False)
    q: np.ndarray = field(repr=False)
    dq: np.ndarray = field(repr=False)
    ddq: np.ndarray = field(repr=False)
    tau: np.ndarray = field(repr=False)
    seed: int = 0
    _report: dict[str, Any] = field(default_factory=dict, repr=False)

    def arrays(self, ddq: bool = True) -> dict[str, np.ndarray]:
        """The data as ``identify`` reads them: {"t", "q", "dq", ["ddq",] "tau"} (the .npz members)."""
        out = {"t": self.t, "q": self.q, "dq": self.dq}
        if ddq:
            out["ddq"] = self.ddq
        out["tau"] = self.tau
        return out


@dataclass(frozen=True)
class Singularity(_Report):
    """``minparam singular``: the screw-theory test at q (``singular``: whether it is singular,
    ``sigma_ratio``: σ_min/σ_max of the normalised screw matrix, ``dependent``: the dependent joint
    groups, numbered from 1), with ``scan`` and ``symbolic`` sections when asked."""

    robot: str
    singular: bool | None = None
    sigma_ratio: float | None = None
    dependent: tuple[tuple[int, ...], ...] = ()
    _report: dict[str, Any] = field(default_factory=dict, repr=False)


@dataclass(frozen=True)
class PlatformResult(_Report):
    """``minparam platform ik|fk|workspace``: the report (``to_dict()``) and its main numbers:
    ``lengths`` (ik: leg lengths), ``poses`` (fk: one x,y,z,roll,pitch,yaw per assembly mode, file
    units), ``reachable`` (workspace: the share of sampled poses inside the leg limits)."""

    kind: str
    lengths: tuple[float, ...] = ()
    poses: tuple[tuple[float, ...], ...] = ()
    reachable: float | None = None
    _report: dict[str, Any] = field(default_factory=dict, repr=False)


@dataclass(frozen=True)
class Excitation(_Report):
    """An excitation trajectory (``minparam excite``): samples t (N,), q, dq, ddq (N, dof) in SI units
    over ``periods`` periods, the Fourier coefficients ``q0`` (dof,), ``a``, ``b`` (dof, harmonics) of
    Swevers' series, the criterion on the design grid and the base regressor's condition number on the
    samples (column-scaled and in SI units).  ``tau``: the nominal rigid-body torques (None without
    inertial values).  ``to_dict()`` is the ``--json`` record, ``to_csv()`` the ``-o`` file."""

    robot: str
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
    _design: ExciteResult = field(repr=False)
    _report: dict[str, Any] = field(default_factory=dict, repr=False)

    @property
    def harmonics(self) -> int:
        return int(self.a.shape[1])

    def evaluate(self, t: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """q, dq, ddq (len(t), dof) of the series at times ``t`` (s): exact, not interpolated."""
        import numpy as np

        return self._design.trajectory.evaluate(np.asarray(t, dtype=float))

    def arrays(self) -> dict[str, np.ndarray]:
        """{"t", "q", "dq", "ddq"}: the samples, as ``simulate``'s trajectory input reads them."""
        return {"t": self.t, "q": self.q, "dq": self.dq, "ddq": self.ddq}

    def to_csv(self) -> str:
        """The CSV ``minparam excite -o`` writes: t, q1..qn, dq1..dqn, ddq1..ddqn."""
        from minparam_cli.render.excite_text import csv_text

        return csv_text(self._design)

    def summary(self) -> str:
        """The lines ``minparam excite`` prints on stderr (criterion, condition number, limits used)."""
        from minparam_cli.render.excite_text import summary_text

        return summary_text(self._design, self._report["robot_name"], self.seed)


@dataclass(frozen=True)
class GeneratedCode:
    """Generated code (``minparam codegen``): ``files`` maps a suffix (".c", ".h"; ".py") to the text
    the command writes, ``counts`` the operations of each generated function ({"mul", "add", "sin",
    ...}), ``base_names`` the columns of the base regressor (derive's base set).  ``write(path)``
    writes the file(s) as ``-o path`` does (C: path.c and path.h)."""

    lang: str
    files: dict[str, str] = field(repr=False)
    counts: dict[str, dict[str, int]] = field(repr=False)
    base_names: tuple[str, ...]
    output: Path | None = None
    notes: tuple[str, ...] = ()
    _generated_stem: str = field(default="", repr=False)  # the C source includes <stem>.h

    @property
    def source(self) -> str:
        """The main file: the .c source for C, the module for python and casadi."""
        return self.files[".c"] if self.lang == "c" else self.files[".py"]

    @property
    def header(self) -> str | None:
        """The C header (None for python and casadi)."""
        return self.files.get(".h")

    def write(self, path: str | Path | None = None) -> list[Path]:
        """Write the file(s) atomically to ``path`` (default: the ``output`` the code was generated for);
        for C, ``path`` names the .c file and the .h goes beside it.  Returns the paths written."""
        from minparam_cli.errors import InputError
        from minparam_cli.output import is_stdout, write_code_files

        target = Path(path) if path is not None else self.output
        if target is None:
            raise InputError("write: give a path (the code was generated without an output)")
        if self.lang == "c":
            stem = self._generated_stem
            if is_stdout(target):
                raise InputError("C output is two files (.c and .h): give a path FILE.c")
            if target.stem != stem:
                raise InputError(f"write: the C source includes {stem}.h; write it as {stem}.c (or generate with output={str(target)!r})")
        return write_code_files(self.files, self.lang, target)
