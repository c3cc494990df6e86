"""`minparam evaluate`: predict torques with a saved model (identify --save-model) and report the errors."""

from __future__ import annotations

import json
from enum import Enum
from pathlib import Path
from typing import List, Optional

import typer

from minparam_cli.cli.common import guarded, option_errors
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
standstill trimming); --time-unit and --topic say how to read these files, and
--columns names their columns when they differ from the model's (as identify's).  The robot
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
    columns: str = typer.Option("", "--columns", help="The data files' columns, as identify's --columns (t=time,q=pos,tau=effort), instead of the model's."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="Nothing on stderr but errors (evaluate draws no progress bar; accepted as by every command)."),
):
    del quiet  # evaluate writes nothing on stderr but errors
    _evaluate(model, data, which, predictions, fmt, output, robot, time_unit, topic, band, band_level, columns or None)


@guarded
def _evaluate(model, data, which, predictions, fmt, output, robot, time_unit, topic, band=False, band_level=0.95, columns=None):
    """Parse, call the API (``api.evaluation``), render, write."""
    from minparam_cli.api.evaluation import run_evaluate
    from minparam_cli.api.options.evaluate import EvaluateOptions

    with option_errors():
        opts = EvaluateOptions(which=which.value if which is not None else None, predictions=predictions, band=band,
                               band_level=band_level, robot=robot, time_unit=TimeUnit(time_unit).value, topic=topic,
                               columns=columns)
    result = run_evaluate(model, list(data), opts)
    if fmt == Fmt.json:
        text = json.dumps(result.to_dict(), indent=2, ensure_ascii=False)
    else:
        from minparam_cli.render.evaluate_text import render_evaluate

        text = render_evaluate(result.result)
    write_output(text, output)


def register(app: typer.Typer) -> None:
    app.command(name="evaluate", help=HELP, epilog=EPILOG)(evaluate)
