"""`minparam evaluate`: predict torques with a saved model (identify --save-model) and report the errors."""

from __future__ import annotations

import json
from enum import Enum
from pathlib import Path
from typing import List, Optional

import typer

from minparam_cli.cli.common import guarded
from minparam_cli.output import write_output
from minparam_cli.cli.identify import Fmt, TimeUnit, time_unit_option, topic_option

HELP = ("Predict joint torques with a model saved by 'identify --save-model' and report the errors on data files: "
        "RMS per joint, total RMS and ‖r‖/‖τ‖, per file and pooled.")
EPILOG = """\b
Examples:
  minparam identify robots/puma560_mdh.yaml run1.csv --test run2.csv --save-model model.json
  minparam evaluate model.json run3.csv run4.csv
  minparam evaluate model.json run3.csv --predictions pred.csv --format json -o eval.json

\b
The data are read with the model's settings (columns, cut-off, filter, decimation, rate,
standstill trimming); --time-unit and --topic say how to read these files.  The robot
file is the one the model names, or --robot; its SHA-256 must be the model's.
Exit codes: 0 success, 1 failed computation, 2 bad input.
"""


class Which(str, Enum):
    physical = "physical"
    fit = "fit"


def evaluate(
    model: Path = typer.Argument(..., help="Model file written by 'identify --save-model'.", show_default=False),
    data: List[Path] = typer.Argument(..., help="Data files (CSV with a header row, .npz, or ROS bags).", show_default=False),
    which: Optional[Which] = typer.Option(None, "--model", help="Parameters to use: the physical fit (default when the model has one) or the unconstrained fit."),
    predictions: Optional[Path] = typer.Option(None, "--predictions", help="Write t, tau_meas1..n, tau_pred1..n of the (one) DATA file as CSV (atomically)."),
    fmt: Fmt = typer.Option(Fmt.table, "--format", "-f", help="Output format."),
    output: Optional[Path] = typer.Option(None, "--output", "-o", help="Write the report to this file (atomically)."),
    band: bool = typer.Option(False, "--band", help="Report a prediction band per joint (parameter covariance of the model file propagated to τ, plus the fit's residual σ) and the share of samples inside it."),
    band_level: float = typer.Option(0.95, "--band-level", help="Probability of the prediction band (--band)."),
    robot: Optional[Path] = typer.Option(None, "--robot", help="Robot file to use instead of the one the model names (same SHA-256)."),
    time_unit: TimeUnit = time_unit_option(),
    topic: Optional[str] = topic_option(),
):
    _evaluate(model, data, which, predictions, fmt, output, robot, time_unit, topic, band, band_level)


@guarded
def _evaluate(model, data, which, predictions, fmt, output, robot, time_unit, topic, band=False, band_level=0.95):
    from minparam_cli.api.identification import check_data_file, evaluation_report, evaluation_setup
    from minparam_cli.api.model_file import open_model
    from minparam_cli.errors import InputError
    from minparam_cli.model.evaluation import evaluate as run

    if predictions is not None and len(data) > 1:
        raise InputError(f"--predictions writes one file: give one DATA file (got {len(data)})")
    m, robot_path, design = open_model(model, robot)
    for p in data:
        check_data_file(p)
    setup = evaluation_setup(str(model), m, str(robot_path), design, which.value if which is not None else None,
                             TimeUnit(time_unit).value, topic)
    prediction_band = _band(setup.saved, setup.kind, design.chain.dof, str(model), band_level) if band else None
    if predictions is None:
        result = run(setup.design, setup.theta, data, setup.data, setup.kind, band=prediction_band)
    else:
        result = _with_predictions(predictions, setup.design, setup.theta, data, setup, setup.kind, run, prediction_band)
    report = evaluation_report(setup, result)
    if fmt == Fmt.json:
        text = json.dumps(report, indent=2, ensure_ascii=False)
    else:
        from minparam_cli.render.evaluate_text import render_evaluate

        text = render_evaluate(report)
    write_output(text, output)


def _band(m, kind: str, n: int, source: str, level: float):
    """The prediction band of the model file's covariance (one line, exit 2 where it cannot be made)."""
    import numpy as np

    from minparam_cli.model.bands import Band, check_level
    from minparam_cli.model.file import ModelError

    check_level(level)
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


def _with_predictions(path: Path, design, theta, data, m, kind, run, band=None):
    """Evaluate while streaming every block's predictions into a temporary file renamed at the end."""
    import numpy as np

    from minparam_cli.output import atomic_write

    n = design.chain.dof
    header = ",".join(["t"] + [f"tau_meas{j}" for j in range(1, n + 1)] + [f"tau_pred{j}" for j in range(1, n + 1)])
    out = {}

    def write(tmp: str) -> None:
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(header + "\n")

            def sink(t, tau, pred):
                np.savetxt(fh, np.column_stack([t, tau, pred]), delimiter=",", fmt="%.12g")

            out["result"] = run(design, theta, data, m.data, kind, sink=sink, band=band)  # m: the EvaluationSetup

    atomic_write(path, write, suffix=".csv")
    return out["result"]


def register(app: typer.Typer) -> None:
    app.command(name="evaluate", help=HELP, epilog=EPILOG)(evaluate)
