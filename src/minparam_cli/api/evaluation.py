"""A saved model's errors on data (``minparam evaluate``): ``evaluate`` (the library call) and
``run_evaluate`` (the one driver, which the command calls too), on one ``EvaluateOptions`` record."""

from __future__ import annotations

import os
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterable, Mapping, Sequence

from minparam_cli.api.identified import Evaluation, Model
from minparam_cli.api.options.evaluate import EvaluateOptions
from minparam_cli.errors import InputError

if TYPE_CHECKING:
    import numpy as np

    from minparam_cli.identify.passes.design import Design
    from minparam_cli.measured.records import DataOptions
    from minparam_cli.model.file import SavedModel


@dataclass(frozen=True)
class EvaluationSetup:
    """What ``evaluate`` reads the data with: the model, its design and parameters, the data options."""

    model_file: str
    robot: str
    saved: SavedModel
    design: Design
    kind: str
    theta: np.ndarray
    data: DataOptions


def evaluation_setup(model_file: str, saved: SavedModel, robot_file: str, design: Design, which: str | None,
                     time_unit: str = "s", topic: str | None = None,
                     columns: Mapping[str, str] | None = None) -> EvaluationSetup:
    """The parameters to use (the physical fit by default when the model has one) and the model's data
    settings with these files' time unit, a bag's topic, the robot's joint names and, when given,
    these files' column names (``columns``, replacing the model's whole)."""
    from minparam_cli.measured.rosbag import coordinate_names

    kind = which if which is not None else ("physical" if saved.physical is not None else "fit")
    theta = saved.fit_theta(kind)
    data = replace(saved.data, time_unit=time_unit, topic=topic, joint_names=coordinate_names(design.chain))
    if columns is not None:
        data = replace(data, columns=dict(columns))
    return EvaluationSetup(model_file, robot_file, saved, design, kind, theta, data)


def _identify_test(setup: EvaluationSetup):
    """Identify's test figure of the parameters used, as the model file stores it (None without one)."""
    m, kind = setup.saved, setup.kind
    ident = ((m.figures.get("physical") or {}).get("test") if kind == "physical" else None)
    test = m.figures.get("test") or {}
    if kind == "fit" and test.get("final"):
        return test["final"]
    if kind == "physical" and ident and len(ident) == 1:
        return next(iter(ident.values()))
    return None


def check_data_file(p: Path) -> None:
    """A data file must exist and be a regular file (a ROS bag may be a folder); a FIFO, a device or
    another folder is refused in the words of identify's readers (``safety.require_regular_file``)."""
    from minparam_cli.measured.rosbag import is_bag
    from minparam_cli.safety import require_regular_file

    if not p.exists() and not p.is_symlink():
        raise InputError(f"{p}: data file not found")
    if p.is_dir():
        if not is_bag(p):
            raise InputError(f"{p}: is a folder, expected a data file (CSV, .npz, .parquet or a ROS bag)")
        return
    require_regular_file(p, InputError)


def _band(m: SavedModel, kind: str, n: int, source: str, level: float):
    """The prediction band of the model file's covariance (one line, exit 2 where it cannot be made)."""
    import numpy as np

    from minparam_cli.model.bands import Band
    from minparam_cli.model.file import ModelError

    if kind != "fit":
        raise ModelError("--band needs --model fit: the stored covariance is that of the unconstrained fit")
    u = m.uncertainty
    if u is None:
        raise ModelError(f"{source}: the model file has no parameter covariance (saved by an older minparam): "
                         "run identify --save-model again for --band")
    if len(u["residual_sigma_per_joint"]) != n:
        raise ModelError(f"{source}: uncertainty.residual_sigma_per_joint has {len(u['residual_sigma_per_joint'])} "
                         f"values, the robot has {n} joints")
    return Band(np.array(u["columns"]), np.array(u["covariance"]), np.array(u["residual_sigma_per_joint"]), level, u["sigma"])


def _with_predictions(path: Path, setup: EvaluationSetup, data, band):
    """Evaluate while streaming every block's predictions into a temporary file renamed at the end."""
    import numpy as np

    from minparam_cli.model.evaluation import evaluate as run
    from minparam_cli.output import atomic_write

    n = setup.design.chain.dof
    header = ",".join(["t"] + [f"tau_meas{j}" for j in range(1, n + 1)] + [f"tau_pred{j}" for j in range(1, n + 1)])
    out = {}

    def write(tmp: str) -> None:
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(header + "\n")

            def sink(t, tau, pred):
                np.savetxt(fh, np.column_stack([t, tau, pred]), delimiter=",", fmt="%.12g")

            out["result"] = run(setup.design, setup.theta, data, setup.data, setup.kind, sink=sink, band=band)

    atomic_write(path, write, suffix=".csv")
    return out["result"]


def run_evaluate(model: Model | str | Path, data: Sequence[Any], opts: EvaluateOptions) -> Evaluation:
    """The one driver of ``minparam evaluate`` and ``minparam.evaluate``: the model (a :class:`Model` or
    a model file), the data (files, or mappings of arrays and DataFrames registered as <data1>...)."""
    from minparam_cli.api.model_file import open_model
    from minparam_cli.measured.arrays import as_record, is_in_memory, registered
    from minparam_cli.model.evaluation import EvaluateResult
    from minparam_cli.model.evaluation import evaluate as run

    if opts.predictions is not None and len(data) > 1:
        raise InputError(f"--predictions writes one file: give one DATA file (got {len(data)})")
    if isinstance(model, Model):
        saved, robot_file, design, source = model.saved, model.robot, model.design, "<model>"
    else:
        saved, robot_path_, design = open_model(model, opts.robot)
        robot_file, source = str(robot_path_), str(model)
    names: list[str | Path] = []
    records = []
    for k, x in enumerate(data):
        if is_in_memory(x):
            records.append(as_record(x, f"<data{k + 1}>"))
            names.append(f"<data{k + 1}>")
        elif isinstance(x, (str, Path)):
            check_data_file(Path(x))
            names.append(x if isinstance(x, Path) else str(x))
        else:
            raise InputError(f"data{k + 1}: expected a file path, a mapping of arrays or a pandas DataFrame, got {type(x).__name__}")
    setup = evaluation_setup(source, saved, robot_file, design, opts.which, opts.time_unit, opts.topic,
                             opts.columns)  # type: ignore[arg-type]  # a dict once the record is built
    band = _band(setup.saved, setup.kind, design.chain.dof, source, opts.band_level) if opts.band else None
    with registered(records):
        if opts.predictions is None:
            result = run(setup.design, setup.theta, names, setup.data, setup.kind, band=band)
        else:
            result = _with_predictions(opts.predictions, setup, names, band)
    return Evaluation(EvaluateResult(setup.model_file, setup.robot, len(setup.theta), result, _identify_test(setup)))


def evaluate(model: Model | str | Path, data: Any, *, which: str | None = None, robot: str | Path | None = None,
             time_unit: str = "s", topic: str | None = None, columns: str | Mapping[str, str] | None = None) -> Evaluation:
    """Errors of a saved model on data (``minparam evaluate``): per file and pooled.

    ``model``: a :class:`Model` or a model file; ``data``: one data set or a list of them (files,
    mappings of arrays, DataFrames), read with the model's settings.  ``which``: "physical" or "fit"
    (default: physical when the model has one).  ``columns``: the data's column names
    (``"t=time,q=pos"`` or a mapping, as identify's ``columns``) instead of the model's.
    """
    from minparam_cli.measured.arrays import is_in_memory

    opts = EvaluateOptions(which=which, robot=None if robot is None else Path(robot), time_unit=time_unit, topic=topic,
                           columns=columns)
    if isinstance(data, (str, os.PathLike)) or is_in_memory(data):
        items = [Path(data) if isinstance(data, os.PathLike) else data]
    elif isinstance(data, Iterable) and not isinstance(data, (bytes, Mapping)):  # a list, a tuple, a generator (Path.glob)
        items = [Path(d) if isinstance(d, os.PathLike) else d for d in data]
    else:
        raise InputError(f"data: expected a file path, a mapping of arrays, a pandas DataFrame or a list of them, got {type(data).__name__}")
    return run_evaluate(model, items, opts)
