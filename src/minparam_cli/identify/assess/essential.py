"""Essential parameters (Pham & Gautier 1991): the base parameters the data really determine.

Backward elimination on the final fit: while the largest relative standard
deviation 100·σ_k/|θ_k| exceeds ``bound`` (%), drop that parameter (its column
leaves the design, its value is taken as 0) and refit the rest.  The σ are
those the report shows (``--sigma``: hac, bootstrap or textbook), recomputed
after every drop from the same per-block statistics (``uncertainty``), with
Gautier's joint weights of the full fit held fixed, so every step costs
O(blocks·q²) and reads no data.  The result names every dropped parameter,
its relative σ when dropped, the condition number of the essential set and
the test error (data that chose nothing) before and after the reduction.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from minparam_cli.identify.estimate.fit import errors
from minparam_cli.identify.assess.uncertainty import UncertaintyOptions, estimate, relative_percent

DEFAULT_BOUND = 10.0  # %: an essential parameter is known to better than a tenth of its value (1 σ)


@dataclass(frozen=True)
class Essential:
    bound: float
    names: tuple[str, ...]  # the essential set
    theta: np.ndarray
    std_percent: np.ndarray
    dropped: list  # {"parameter", "std_percent", "why"} in the order dropped
    cond: float  # condition number of the weighted essential regressor
    cond_full: float
    columns: tuple[int, ...]  # positions of the essential set in the full fit's columns


def _cond(H: np.ndarray) -> float:
    w = np.linalg.eigvalsh(H)
    return float(np.sqrt(w[-1] / w[0])) if w[0] > 0 else float("inf")


def reduce(grams, maps, fit, opts: UncertaintyOptions, bound: float = DEFAULT_BOUND) -> Essential:
    """Pham & Gautier's elimination on ``fit`` (fit.Fit with honest σ) from the block statistics ``grams``."""
    sigma = fit.sigma if fit.method == "wls" else None
    keep = list(range(len(fit.columns)))  # positions in fit.columns
    dropped = []
    blocks, _ = grams.stack(maps, list(fit.columns))
    w = 1.0 / (fit.sigma if sigma is not None else np.ones(blocks.shape[1])) ** 2
    Hfull = np.einsum("bjkl,j->kl", blocks, w)[:-1, :-1]
    u = None
    while keep:
        cols = [fit.columns[k] for k in keep]
        u = estimate(grams, maps, cols, sigma, int(fit.rows), opts)
        rel = relative_percent(u.theta, u.std())
        worst = int(np.argmax(rel))
        if rel[worst] <= bound or len(keep) == 1:
            break
        dropped.append({"parameter": fit.names[keep[worst]], "std_percent": float(rel[worst]) if np.isfinite(rel[worst]) else None,
                        "value": float(u.theta[worst]),
                        "why": f"largest relative σ ({rel[worst]:.3g} % > {bound:g} %) among the {len(keep)} parameters left"})
        del keep[worst]
    assert u is not None  # the loop runs at least once: a fit has at least one column
    return Essential(bound, tuple(fit.names[k] for k in keep), u.theta, relative_percent(u.theta, u.std()), dropped,
                     _cond(Hfull[np.ix_(keep, keep)]), _cond(Hfull), tuple(keep))


def compare_errors(acc: dict, fit, ess: Essential, parts: list[str]) -> tuple[dict, dict, str]:
    """rms and ‖r‖/‖τ‖ of the full and the essential fit on ``parts`` (the test parts; else selection)."""
    from minparam_cli.identify.estimate.fit import Accumulator

    full = np.asarray(fit.theta, dtype=float)
    red = np.zeros_like(full)
    red[list(ess.columns)] = ess.theta
    out = []
    for theta in (full, red):
        rss = y2 = rows = 0.0
        per = []
        for k in parts:
            a: Accumulator = acc[k]
            e = errors(a, theta, fit.columns)
            rss += float(np.sum(np.asarray(e.rms_per_joint) ** 2 * np.maximum(a.rows, 1)))
            y2 += float(a.y_norm2().sum())
            rows += float(a.rows.sum())
            per.append(e.rms_per_joint)
        out.append({"rms_total": float(np.sqrt(rss / rows)), "relative_error": float(np.sqrt(rss / y2)) if y2 > 0 else None})
    return out[0], out[1], ", ".join(parts)


@dataclass(frozen=True)
class EssentialReport:
    """The report's "essential" entry: the reduction, and the error of the full and the essential fit
    (rms_total, relative_error) on ``error_data`` (the test parts; the selection data without them)."""

    essential: Essential
    error_before: dict
    error_after: dict
    error_data: str

    def to_dict(self) -> dict:
        e = self.essential
        return {
            "bound_percent": e.bound,
            "parameters": {n: {"value": float(v), "std_percent": float(s)} for n, v, s in zip(e.names, e.theta, e.std_percent, strict=True)},
            "dropped": [dict(d) for d in e.dropped],
            "condition_number": e.cond,
            "condition_number_full": e.cond_full,
            "error_data": self.error_data,
            "error_before": dict(self.error_before),
            "error_after": dict(self.error_after),
        }


def essential_report(grams, maps, fit, opts: UncertaintyOptions, bound: float, acc: dict, test_parts: list[str]) -> EssentialReport:
    """The reduction, and its error on the test parts (selection data if none)."""
    ess = reduce(grams, maps, fit, opts, bound)
    before, after, data = compare_errors(acc, fit, ess, test_parts or ["selection"])
    return EssentialReport(ess, before, after, data)
