"""Several recordings of one robot: each fitted alone and all together, and where they disagree.

Every recording is identified with the declared model (no diagnosis, so each
fits the same parameters) and its own fit/selection/test split.  The joint fit
sums the recordings' weighted per-block statistics (each recording keeps its
own Gautier weights σ_j; blocks of different recordings are never neighbours),
so it reads no file twice.  Per base parameter the report gives every
recording's value and σ (the kind of ``--sigma``), the joint value and σ, and

    χ² = Σ_r (θ_r − θ̄)² / σ_r²,   θ̄ = Σ_r θ_r/σ_r² / Σ_r 1/σ_r²,

with ``spread_over_sigma`` = sqrt(χ² / (R − 1)) (≈ 1 when the recordings differ
by what their σ say) and a flag where χ² exceeds its 99 % quantile with R − 1
degrees of freedom: the recordings disagree beyond their σ, so the parameter
is dominated by model error, not by noise.  The same figure with the textbook
σ shows how far those understate the spread.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, cast

import numpy as np

from minparam_cli.errors import DataError
from minparam_cli.identify.assess.uncertainty import Uncertainty, from_weighted, relative_percent, weighted_blocks
from minparam_cli.identify.result import IdentifyResult

LEVEL = 0.99  # a parameter is flagged when χ² exceeds this quantile
SCHEMA = "minparam.consistency/1"


@dataclass(frozen=True)
class Recording:
    path: str
    names: tuple[str, ...]
    theta: np.ndarray
    std: np.ndarray  # of the chosen kind
    std_textbook: np.ndarray
    Gb: np.ndarray  # weighted block Grams of the fitted columns
    keys: np.ndarray
    rows: int
    block_s: float


@dataclass(frozen=True)
class Value:
    """One recording's value of a parameter, its σ (of the kind asked for) and its textbook σ."""

    value: float
    std: float
    std_textbook: float

    def to_dict(self) -> dict:
        return {"value": self.value, "std": self.std, "std_textbook": self.std_textbook}


@dataclass(frozen=True)
class JointValue:
    """The joint fit's value of a parameter, its σ and relative σ (%)."""

    value: float
    std: float
    std_percent: float

    def to_dict(self) -> dict:
        return {"value": self.value, "std": self.std, "std_percent": self.std_percent}


@dataclass(frozen=True)
class ParameterSpread:
    """One base parameter over the recordings: each one's value, the joint fit's, χ² and spread/σ."""

    parameter: str
    recordings: tuple[Value, ...]
    joint: JointValue
    chi2: float
    spread_over_sigma: float
    chi2_textbook: float
    spread_over_sigma_textbook: float
    disagree: bool

    def to_dict(self) -> dict:
        return {"parameter": self.parameter, "recordings": [r.to_dict() for r in self.recordings],
                "joint": self.joint.to_dict(), "chi2": self.chi2, "spread_over_sigma": self.spread_over_sigma,
                "chi2_textbook": self.chi2_textbook, "spread_over_sigma_textbook": self.spread_over_sigma_textbook,
                "disagree": self.disagree}


@dataclass(frozen=True)
class ConsistencyResult:
    """``identify --consistency``: per parameter the recordings' spread; ``to_dict()`` is the JSON."""

    sigma: str
    recordings: tuple[str, ...]
    level: float
    chi2_limit: float
    parameters: tuple[ParameterSpread, ...]
    disagree: tuple[str, ...]
    median_spread_over_sigma: float
    median_spread_over_sigma_textbook: float
    joint_condition_number: float
    seed: int
    robot: str = ""  # the robot's name, for titles (not in the JSON)

    def to_dict(self) -> dict:
        return {"schema": SCHEMA, "sigma": self.sigma, "recordings": list(self.recordings), "level": self.level,
                "chi2_limit": self.chi2_limit, "parameters": [p.to_dict() for p in self.parameters],
                "disagree": list(self.disagree), "median_spread_over_sigma": self.median_spread_over_sigma,
                "median_spread_over_sigma_textbook": self.median_spread_over_sigma_textbook,
                "joint_condition_number": self.joint_condition_number, "seed": self.seed}


def check_joint_counts(chain, paths: list[Path], data_opts) -> None:
    """Read the head of every recording before fitting any: a recording whose joints do not match the robot's
    (hence the others') is refused in one line."""
    from minparam_cli.measured.reading import raw_chunks

    head = replace(data_opts, chunk_rows=8)
    for p in paths:
        try:
            next(iter(raw_chunks(Path(p), chain.dof, head)), None)
        except DataError as e:
            raise DataError(f"--consistency: the recordings must have the robot's {chain.dof} joints: {e}") from None


def fit_recording(chain, path: Path, opts, progress=None) -> tuple[Recording, IdentifyResult]:
    """identify with the declared model on one recording; its fit and its block statistics."""
    from minparam_cli.identify.stage import identify

    rep, art = identify(chain, path, replace(opts, diagnose=False, essential=None), progress)
    u = cast(Uncertainty, art.uncertainty)
    grams, maps = cast(tuple, art.grams)
    fit_sigma = np.array(rep.sigma_per_joint) if rep.method == "wls" else None
    cols = list(u.columns)  # the design columns of the fit (those not regrouped on this recording)
    rows = int(rep.samples_fit) * chain.dof  # equations of the fit: samples x joints
    Gb, keys = weighted_blocks(grams, maps, cols, fit_sigma, rows)
    return Recording(str(path), tuple(e.name for e in rep.parameters), np.array([e.value for e in rep.parameters]),
                     u.std(), u.std("textbook"), Gb, keys, rows, u.block_s), rep


def combine(recs: list[Recording], opts) -> ConsistencyResult:
    """The consistency report: per parameter, every recording's value and σ, the joint fit, χ² and the flag."""
    from scipy.stats import chi2

    names = recs[0].names
    for r in recs[1:]:
        if r.names != names:
            missing = sorted(set(names) ^ set(r.names))
            raise DataError(f"--consistency: {r.path} identifies other parameters than {recs[0].path} "
                            f"({', '.join(missing[:6])} regrouped on one of them): the recordings cannot be compared")
    shift = 0
    Gs, ks = [], []
    for r in recs:
        Gs.append(r.Gb)
        ks.append(r.keys - r.keys.min() + shift)
        shift = int(ks[-1].max()) + 2  # a gap: blocks of different recordings are not neighbours
    joint = from_weighted(np.concatenate(Gs), np.concatenate(ks), sum(r.rows for r in recs), opts.uncertainty, recs[0].block_s)
    T = np.array([r.theta for r in recs])
    S = np.array([r.std for r in recs])
    S0 = np.array([r.std_textbook for r in recs])
    R = len(recs)
    limit = float(chi2.ppf(LEVEL, R - 1))
    out = []
    for k, name in enumerate(names):
        js = float(joint.std()[k])
        stats: dict[str, Any] = {}
        for key, sig in (("", S[:, k]), ("_textbook", S0[:, k])):
            w = 1.0 / np.maximum(sig, 1e-300) ** 2
            mean = float(np.sum(w * T[:, k]) / np.sum(w))
            c2 = float(np.sum(w * (T[:, k] - mean) ** 2))
            stats["chi2" + key] = c2
            stats["spread_over_sigma" + key] = float(np.sqrt(c2 / (R - 1)))
        out.append(ParameterSpread(
            name, tuple(Value(float(T[i, k]), float(S[i, k]), float(S0[i, k])) for i in range(R)),
            JointValue(float(joint.theta[k]), js, float(relative_percent(joint.theta[k:k + 1], joint.std()[k:k + 1])[0])),
            stats["chi2"], stats["spread_over_sigma"], stats["chi2_textbook"], stats["spread_over_sigma_textbook"],
            stats["chi2"] > limit))
    return ConsistencyResult(
        sigma=opts.uncertainty.kind, recordings=tuple(r.path for r in recs), level=LEVEL, chi2_limit=limit,
        parameters=tuple(out), disagree=tuple(r.parameter for r in out if r.disagree),
        median_spread_over_sigma=float(np.median(np.array([r.spread_over_sigma for r in out]))),
        median_spread_over_sigma_textbook=float(np.median(np.array([r.spread_over_sigma_textbook for r in out]))),
        joint_condition_number=float(np.sqrt(np.linalg.cond(np.concatenate(Gs).sum(axis=0)[:-1, :-1]))),
        seed=opts.seed)


def consistency(chain, paths: list[Path], opts, progress=None) -> tuple[ConsistencyResult, list[IdentifyResult]]:
    """Fit every recording alone and all together (see the module docstring); the per-recording reports too."""
    if len(paths) < 2:
        raise DataError("--consistency needs at least two recordings")
    check_joint_counts(chain, paths, opts.data)
    recs, reports = [], []
    for k, p in enumerate(paths):
        rec, rep = fit_recording(chain, Path(p), opts)
        recs.append(rec)
        reports.append(rep)
        if progress is not None:
            progress(k + 1, len(paths))
    return combine(recs, opts), reports
