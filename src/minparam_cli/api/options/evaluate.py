"""The options of ``minparam evaluate`` as one frozen record that checks itself (see ``identify.py``):
built by the typer command and by ``minparam.evaluate()``, run by ``api.evaluation.run_evaluate``."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

from minparam_cli.api.options.identify import TIME_UNITS, _columns, choice_option

WHICH = ("physical", "fit")


@dataclass(frozen=True)
class EvaluateOptions:
    """``which``: the parameters to use ("physical", "fit"; None: physical when the model has a physical
    fit); ``robot``: the robot file instead of the one the model names; ``predictions``: a CSV file for
    the (one) data file's measured and predicted torques; ``band``: count the samples inside the
    prediction band of probability ``band_level``; ``columns``: the data files' column names
    (``--columns``, as identify's), instead of the model's; None: the model's."""

    which: str | None = None
    predictions: Path | None = None
    band: bool = False
    band_level: float = 0.95
    robot: Path | None = None
    time_unit: str = "s"
    topic: str | None = None
    columns: str | Mapping[str, str] | None = None

    def __post_init__(self) -> None:
        if self.columns is not None:
            self._put("columns", _columns(self.columns))
        if self.which is not None:
            self._put("which", choice_option(self.which, WHICH, "--model"))
        self._put("time_unit", choice_option(self.time_unit, TIME_UNITS, "--time-unit"))
        if self.band:
            from minparam_cli.model.bands import check_level

            check_level(self.band_level)

    def _put(self, name: str, value: Any) -> None:
        object.__setattr__(self, name, value)  # normalising a frozen record while it is being built
