"""`minparam evaluate`: a saved model's torque predictions and errors on other recordings.

Data files are streamed block by block (``iter_blocks`` with the model's data settings): the
model predicts τ = X(block)·θ and the squares of the residual are summed per joint, so memory does
not grow with the file.  The figures are the identify report's (``fit.errors``): RMS per joint and
in total, and ‖r‖/‖τ‖.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Callable, Mapping

import numpy as np

from minparam_cli.errors import DataError
from minparam_cli.measured.blocks import iter_blocks
from minparam_cli.measured.records import DataOptions, DataReport
from minparam_cli.identify.estimate.errors import Errors
from minparam_cli.identify.passes.design import Design

if TYPE_CHECKING:
    from minparam_cli.model.bands import Band, BandCounts

REGRESSOR_ROWS = 4096  # samples per regressor evaluation: the full regressor is n·10n numbers a sample

@dataclass
class Sums:
    """Per joint: samples, Σ r², Σ τ² of the residual r = τ − τ_pred."""

    rows: np.ndarray
    rss: np.ndarray
    y2: np.ndarray

    @staticmethod
    def zeros(n: int) -> "Sums":
        return Sums(np.zeros(n, dtype=np.int64), np.zeros(n), np.zeros(n))

    def add(self, tau: np.ndarray, pred: np.ndarray) -> None:
        r = tau - pred
        self.rows += len(tau)
        self.rss += np.einsum("ij,ij->j", r, r)
        self.y2 += np.einsum("ij,ij->j", tau, tau)

    def __add__(self, other: "Sums") -> "Sums":
        return Sums(self.rows + other.rows, self.rss + other.rss, self.y2 + other.y2)

    @property
    def samples(self) -> int:
        return int(self.rows[0]) if len(self.rows) else 0

    def errors(self) -> Errors:
        """The identify report's figures (``fit.errors``): RMS per joint and in total, ‖r‖/‖τ‖."""
        rows = np.maximum(self.rows, 1)
        y2 = float(self.y2.sum())
        return Errors(rms_total=float(np.sqrt(self.rss.sum() / rows.sum())),
                      rms_per_joint=tuple(float(x) for x in np.sqrt(self.rss / rows)),
                      relative_error=float(np.sqrt(self.rss.sum() / y2)) if y2 > 0 else float("nan"))

    def as_dict(self) -> dict:
        return {"samples": self.samples, **self.errors().to_dict()}


@dataclass(frozen=True)
class Evaluation:
    which: str  # "fit" | "physical"
    files: tuple[tuple[str, Sums, DataReport], ...]
    pooled: Sums
    bands: tuple[BandCounts, ...] | None = None  # per file (with a band)
    band: Band | None = None  # set with ``bands``

    def pooled_band(self) -> BandCounts | None:
        """The band counts of all files together (None without a band)."""
        if self.bands is None:
            return None
        pooled = self.bands[0]
        for c in self.bands[1:]:
            pooled = pooled + c
        return pooled

    def to_dict(self) -> dict:
        out: dict[str, Any] = {
            "model": self.which,
            "files": [{"path": p, **s.as_dict(), "preprocessing": rep.as_dict()} for p, s, rep in self.files],
            "pooled": self.pooled.as_dict(),
        }
        if self.bands is not None:
            pooled = self.pooled_band()
            assert pooled is not None and self.band is not None  # ``evaluate`` sets bands and band together
            for f, c in zip(out["files"], self.bands, strict=True):
                f["band"] = c.as_dict()
            out["pooled"]["band"] = pooled.as_dict()
            out["band"] = {"level": self.band.level, "z": self.band.z, "sigma": self.band.kind,
                           "residual_sigma_per_joint": [float(x) for x in self.band.sigma]}
        return out


SCHEMA = "minparam.evaluate/1"


@dataclass(frozen=True)
class EvaluateResult:
    """``minparam evaluate``: a saved model's errors on data files (``evaluation``), the model file and
    robot it came from, its number of parameters, and identify's test figure for the same parameters
    (as the model file stores it; None when it has none).  ``to_dict()`` is the JSON."""

    model_file: str
    robot: str
    parameters: int
    evaluation: Evaluation
    identify_test: Mapping[str, Any] | None = None

    @property
    def which(self) -> str:
        return self.evaluation.which

    def to_dict(self) -> dict:
        out = {"schema": SCHEMA, "model_file": self.model_file, "robot": self.robot, "parameters": self.parameters,
               **self.evaluation.to_dict()}
        if self.identify_test is not None:
            out["identify_test"] = copy.deepcopy(dict(self.identify_test))
        return out


def predict(design: Design, theta: np.ndarray, block) -> np.ndarray:
    """τ_pred (N, n) = X(block)·θ, the regressor built a few thousand samples at a time."""
    out = np.empty_like(block.tau)
    for s0 in range(0, len(block), REGRESSOR_ROWS):
        sub = block.take(slice(s0, s0 + REGRESSOR_ROWS))
        with np.errstate(over="ignore", invalid="ignore"):
            out[s0 : s0 + len(sub)] = design.columns(sub) @ theta
    return out


Sink = Callable[[np.ndarray, np.ndarray, np.ndarray], None]  # (t, tau measured, tau predicted) per block


def evaluate(design: Design, theta: np.ndarray, paths, data: DataOptions, which: str = "fit", sink: Sink | None = None,
             band=None) -> Evaluation:
    """Errors of the model τ = X·θ on every data file, per file and pooled (sums streamed block by block).
    ``sink`` receives each block's time, measured and predicted torques (the CLI writes them); with a
    ``band`` (bands.Band) the share of samples inside the prediction band is counted too."""
    from minparam_cli.model.bands import BandCounts, band_block

    n = design.chain.dof
    files, counts = [], []
    for path in paths:
        rep = DataReport(str(path))
        sums = Sums.zeros(n)
        cnt = BandCounts.zeros(n)
        for b in iter_blocks(path, n, data, rep):
            if not len(b):
                continue
            pred = predict(design, theta, b)
            bad = ~np.isfinite(pred).all(axis=1)
            if bad.any():
                i = int(np.argmax(bad))
                raise DataError(f"{path}: the sample at t = {b.t[i]:.6g} s gives a non-finite predicted torque "
                                "(a value of q, dq, ddq there is too large to use)")
            with np.errstate(over="ignore", invalid="ignore"):  # a torque of 1e200: its square overflows the sums
                bad = ~np.isfinite((b.tau - pred) ** 2 + b.tau**2).all(axis=1)
            if bad.any():
                i = int(np.argmax(bad))
                raise DataError(f"{path}: the sample at t = {b.t[i]:.6g} s has a measured torque too large to use "
                                f"({float(np.abs(b.tau[i]).max()):.3g})")
            sums.add(b.tau, pred)
            if band is not None:
                cnt.add(b.tau, pred, *band_block(design, band, b))
            if sink is not None:
                sink(b.t, b.tau, pred)
        files.append((str(path), sums, rep))
        counts.append(cnt)
    pooled = Sums.zeros(n)
    for _, s, _ in files:
        pooled = pooled + s
    return Evaluation(which, tuple(files), pooled, tuple(counts) if band is not None else None, band)
