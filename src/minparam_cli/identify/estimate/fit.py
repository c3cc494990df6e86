"""Least squares with memory independent of the number of samples.

Each joint j keeps the triangular factor R_j of its augmented rows [X_j | y_j],
updated block by block (``accumulate.Accumulator``).  From the R_j alone follow
every quantity the report needs:

* OLS:  min Σ_j ‖X_j θ − y_j‖²,  with ‖X_j θ − y_j‖ = ‖R_j [θ; −1]‖;
* Gautier's weighted LS (Gautier 1997, "Dynamic identification of robots with
  power model"; Khalil & Dombre 2002 §12.4): each joint's rows divided by
  σ_j, its residual standard deviation after OLS;
* covariance σ²(XᵀX)⁻¹, relative standard deviations 100·σ_θ/|θ| (%),
  the condition number, per-joint RMS residuals and ‖r‖/‖τ‖.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from minparam_cli.errors import ComputationError
from minparam_cli.identify.estimate.accumulate import Accumulator
from minparam_cli.identify.estimate.errors import Errors

__all__ = ["Accumulator", "Errors", "Fit", "errors", "full_theta", "independent_columns", "solve"]


@dataclass(frozen=True)
class Fit:
    names: tuple[str, ...]
    theta: np.ndarray
    std_percent: np.ndarray
    sigma: np.ndarray  # per-joint residual std used as weights
    cond: float
    method: str  # "ols" | "wls"
    rows: int
    columns: tuple[int, ...] = ()  # columns of the design that were fitted
    dependent: tuple[str, ...] = ()  # names dropped as combinations of earlier columns


DEPENDENCE_TOL = 1e-9  # |R_ii| of unit-norm columns below this: a combination of earlier columns


def independent_columns(acc: Accumulator) -> list[int]:
    """Columns of X that are not combinations of earlier ones, on this data (scan order)."""
    A = acc.stacked(np.ones(acc.n))[:, : acc.p]
    norms = np.linalg.norm(A, axis=0)
    ok = norms > 0
    An = A[:, ok] / norms[ok]
    r = np.abs(np.diagonal(np.linalg.qr(An, mode="r"))) if An.shape[1] else np.array([])
    cols = np.flatnonzero(ok)
    return [int(c) for c, ri in zip(cols, r, strict=True) if ri > DEPENDENCE_TOL]


def solve(acc: Accumulator, names: tuple[str, ...], weighted: bool = True) -> Fit:
    """OLS, then (if ``weighted``) Gautier's per-joint weighted LS, on the independent columns."""
    keep = independent_columns(acc)
    dependent = tuple(names[i] for i in range(acc.p) if i not in set(keep))
    if len(keep) < acc.p:
        acc = acc.restrict(keep)
        names = tuple(names[i] for i in keep)
    p = acc.p
    total = int(acc.rows.sum())
    if total <= p:
        raise ComputationError(f"{total} equations for {p} parameters: not enough data")
    ones = np.ones(acc.n)
    M = acc.stacked(ones)
    theta, *_ = np.linalg.lstsq(M[:, :p], M[:, p], rcond=None)
    rss = acc.rss(theta)
    dof = np.maximum(acc.rows - p / acc.n, 1.0)
    sigma = np.sqrt(rss / dof)
    method = "ols"
    if weighted and np.all(sigma > 0):
        M = acc.stacked(sigma)
        theta, *_ = np.linalg.lstsq(M[:, :p], M[:, p], rcond=None)
        method = "wls"
        scale = 1.0  # weighted residuals have unit variance by construction
    else:
        scale = float(np.sum(rss) / max(total - p, 1))
    A = M[:, :p]
    sv = np.linalg.svd(A, compute_uv=False)
    if sv[-1] <= sv[0] * max(A.shape) * np.finfo(float).eps:
        raise ComputationError("the regressor is rank deficient on this data: the trajectory does not excite every base parameter")
    cov = np.linalg.inv(A.T @ A) * scale
    std = np.sqrt(np.maximum(np.diag(cov), 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        std_percent = np.where(theta != 0, 100.0 * std / np.abs(theta), np.inf)
    return Fit(tuple(names), theta, std_percent, sigma, float(sv[0] / sv[-1]), method, total, tuple(keep), dependent)


def full_theta(fit: Fit, p: int) -> np.ndarray:
    """The fit's parameters in the order of all ``p`` design columns (0 for columns regrouped on this data)."""
    theta = np.zeros(p)
    theta[list(fit.columns)] = fit.theta
    return theta


def errors(acc: Accumulator, theta: np.ndarray, columns: tuple[int, ...] | None = None) -> Errors:
    if columns is not None and len(columns) < acc.p:
        acc = acc.restrict(list(columns))
    rss = acc.rss(theta)
    y2 = acc.y_norm2()
    rows = np.maximum(acc.rows, 1)
    with np.errstate(divide="ignore", invalid="ignore"):
        rel_j = np.where(y2 > 0, np.sqrt(rss / y2), np.nan)
    return Errors(
        rms_total=float(np.sqrt(rss.sum() / rows.sum())),
        rms_per_joint=tuple(float(x) for x in np.sqrt(rss / rows)),
        relative_error=float(np.sqrt(rss.sum() / y2.sum())) if y2.sum() > 0 else float("nan"),
        relative_per_joint=tuple(float(x) for x in rel_j),
    )
