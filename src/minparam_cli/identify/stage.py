"""`identify` as one pure stage: robot chain + data file(s) -> report dict.

The data are streamed once: per-joint QR accumulators of the declared model
plus the slot columns of the effect library (training and held-out parts, see
``slots``), and a bounded, evenly thinned sample of at most ``diagnosis_cap``
samples kept in memory for the diagnosis.  The final design's factors follow
from the accumulated ones by a linear map of the columns; only a design with
an effect that has no slot (cogging, load-dependent Coulomb) streams the data
a second time.  Memory is bounded by the chunk size and the cap, not by the
file.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from minparam_cli.chain import Chain
from minparam_cli.errors import DataError
from minparam_cli.identify.data import Block, DataOptions, DataReport, iter_blocks, time_span
from minparam_cli.identify.design import Design
from minparam_cli.identify.diagnose import DiagnosisOptions, diagnose
from minparam_cli.identify.effects import EFFECTS, source_columns
from minparam_cli.identify.fit import Accumulator, errors, solve
from minparam_cli.identify.slots import block_rows, final_maps, slot_sources

DEFAULT_HOLDOUT = 0.3
DIAGNOSIS_CAP = 12_000  # samples kept for the diagnosis (training part; half as many held out)
REGRESSOR_ROWS = 4096


@dataclass(frozen=True)
class IdentifyOptions:
    data: DataOptions = field(default_factory=DataOptions)
    holdout: float = DEFAULT_HOLDOUT
    validate: str | None = None
    weighted: bool = True
    diagnose: bool = True
    diagnosis: DiagnosisOptions = field(default_factory=DiagnosisOptions)
    diagnosis_cap: int = DIAGNOSIS_CAP
    seed: int = 0


class _Thinned:
    """Keeps every stride-th sample, doubling the stride whenever more than ``cap`` are held."""

    def __init__(self, cap: int):
        self.cap, self.stride, self.seen, self.blocks = cap, 1, 0, []

    def add(self, b: Block) -> None:
        idx = np.flatnonzero((self.seen + np.arange(len(b))) % self.stride == 0)
        self.seen += len(b)
        if len(idx):
            self.blocks.append(b.take(idx))
        while sum(len(x) for x in self.blocks) > self.cap:
            merged = Block.concat(self.blocks)
            self.blocks = [merged.take(slice(0, None, 2))]
            self.stride *= 2

    def block(self) -> Block | None:
        return Block.concat(self.blocks) if self.blocks else None


def _split_time(path: Path, opts: IdentifyOptions) -> float:
    """Time at which the held-out part starts: the last ``holdout`` of the record's time span."""
    t0, t1 = time_span(path, opts.data)
    if not t1 > t0:
        raise DataError(f"{path}: the last time stamp ({t1}) is not after the first ({t0})")
    return float(t0 + (1.0 - opts.holdout) * (t1 - t0))


def _stream(design: Design, sources, n: int, opts: IdentifyOptions, keep: bool, slots=()):
    """One pass over the data: per-joint factors of [design columns | slot columns | τ] (training and
    held out), the thinned diagnosis sample, the data reports, and the design with its drift origin set."""
    width = source_columns(slots, design.p)[1]
    acc = {"train": Accumulator(n, width), "hold": Accumulator(n, width)}
    thin = {"train": _Thinned(opts.diagnosis_cap), "hold": _Thinned(opts.diagnosis_cap // 2)}
    reports = []
    for path, part, t_cut in sources:
        rep = DataReport(str(path))
        for b in iter_blocks(path, n, opts.data, rep):
            if not len(b):
                continue
            if design.t0 is None:  # drift is measured from the first sample, in every block and both parts
                design = replace(design, t0=float(b.t[0]))
            if t_cut is None:
                pieces = [(part, b)]
            else:
                k = int(np.searchsorted(b.t, t_cut))  # times increase: the training part is a prefix
                pieces = [("train", b.take(slice(0, k))), ("hold", b.take(slice(k, None)))]
            for name, piece in pieces:
                if len(piece):
                    # the full regressor is n·10n numbers a sample: build it a few thousand samples at a time
                    for s in range(0, len(piece), REGRESSOR_ROWS):
                        sub = piece.take(slice(s, s + REGRESSOR_ROWS))
                        acc[name].add_rows(_finite_rows(design, slots, sub, path))
                    if keep:
                        thin[name].add(piece)
            b = pieces = piece = sub = None  # not alive while the next block is read
        reports.append(rep)
    return acc, thin, reports, design


def _finite_rows(design: Design, slots, b: Block, path: Path) -> np.ndarray:
    """block_rows, refused with the time of the first sample whose row overflowed: a finite but huge
    value (a corrupt dq of 1e200, say) would otherwise turn the whole fit into NaN."""
    with np.errstate(over="ignore", invalid="ignore"):
        rows = block_rows(design, slots, b)
    ok = np.isfinite(rows).all(axis=(1, 2))
    if not ok.all():
        i = int(np.argmin(ok))
        raise DataError(
            f"{path}: the sample at t = {b.t[i]:.6g} s gives a non-finite regressor row "
            "(a value of q, dq, ddq or tau there is too large to use)"
        )
    return rows


@dataclass
class Artifacts:
    """What plots need beside the report: held-out samples and each step's model."""

    hold: Block | None = None
    models: list = field(default_factory=list)  # (label, design, theta)


def identify(chain: Chain, data_path: str | Path, opts: IdentifyOptions, progress=None) -> tuple[dict, Artifacts]:
    from minparam_cli.base.qr import derive_qr

    t_start = time.perf_counter()
    data_path = Path(data_path)
    n = chain.n
    base = derive_qr(chain, seed=opts.seed)
    design = Design(chain, base.kept, base.base_names)
    if opts.validate:
        sources = [(data_path, "train", None), (Path(opts.validate), "hold", None)]
    else:
        if not 0 < opts.holdout < 1:
            raise DataError(f"--holdout must be between 0 and 1, got {opts.holdout}")
        sources = [(data_path, None, _split_time(data_path, opts))]

    slots = slot_sources(opts.diagnosis.effects) if opts.diagnose else ()
    acc_all, thin, reports, design = _stream(design, sources, n, opts, keep=opts.diagnose, slots=slots)
    for part in ("train", "hold"):
        if acc_all[part].rows.sum() <= (design.p if part == "train" else 0):
            raise DataError(f"{data_path}: the {part} part has too few samples ({int(acc_all[part].rows[0])}) for {design.p} parameters")
    acc = {k: (a.restrict(list(range(design.p))) if slots else a) for k, a in acc_all.items()}
    fit0 = solve(acc["train"], design.names, opts.weighted)
    before = errors(acc["hold"], fit0.theta, fit0.columns)
    theta_model = np.zeros(design.p)
    theta_model[list(fit0.columns)] = fit0.theta
    design = replace(design, theta_model=theta_model)

    steps_out = [{"effect": None, "joints": [], "statistic": None, **_errs(before)}]
    stop_reason = "diagnosis off (--no-diagnose)"
    final_fit, after, final_design = fit0, before, design
    diag_info = {}
    artifacts = Artifacts()
    if opts.diagnose:
        train, hold = thin["train"].block(), thin["hold"].block()
        d = diagnose(design, train, hold, opts.diagnosis, progress)
        stop_reason = d.stop_reason
        artifacts.hold = hold
        artifacts.models = [("rigid body" if s.term is None else f"+ {s.term.label()}", s.design, s.theta) for s in d.steps]
        diag_info = {"samples_train": len(train), "samples_holdout": len(hold), "candidates_per_step": d.candidates_per_step,
                     "bic_threshold": opts.diagnosis.bic_threshold, "min_gain": opts.diagnosis.min_gain}
        if d.design.terms:
            final_design = d.design
            maps = final_maps(final_design, slots)
            if maps is not None:  # every added effect has slots: no second pass over the file
                acc2 = {k: a.transform(maps) for k, a in acc_all.items()}
            else:
                acc2, _, _, _ = _stream(final_design, sources, n, opts, keep=False)
            final_fit = solve(acc2["train"], final_design.names, opts.weighted)
            after = errors(acc2["hold"], final_fit.theta, final_fit.columns)
        for s in d.steps[1:]:
            steps_out.append({"effect": s.term.effect, "joints": [j + 1 for j in s.term.joints], "hyper": s.term.hyper,
                              "label": s.term.label(), "statistic": s.statistic, **s.errors})
        if len(steps_out) > 1:
            # the last step's errors are the full-data refit, measured on all held-out samples
            steps_out[-1].update(_errs(after))

    rep0 = reports[0]
    report = {
        "robot": chain.name,
        "data": str(data_path),
        "validate": opts.validate,
        "samples_used": int(acc["train"].rows[0] + acc["hold"].rows[0]),
        "samples_train": int(acc["train"].rows[0]),
        "samples_holdout": int(acc["hold"].rows[0]),
        "dropped": rep0.as_dict()["dropped"],
        "preprocessing": rep0.as_dict(),
        "coulomb_model": "sign(dq)" if chain.coulomb_smoothing == 0 else f"tanh(dq / {chain.coulomb_smoothing:g})",
        "method": final_fit.method,
        "condition_number": final_fit.cond,
        "sigma_per_joint": [float(x) for x in final_fit.sigma],
        "steps": steps_out,
        "stop_reason": stop_reason,
        "before": _errs(before),
        "after": _errs(after),
        "effects": [{"effect": t.effect, "joints": [j + 1 for j in t.joints], "hyper": t.hyper, "explanation": _explain(t.effect)} for t in final_design.terms],
        "parameters": {nm: {"value": float(v), "std_percent": _finite(s)} for nm, v, s in zip(final_fit.names, final_fit.theta, final_fit.std_percent)},
        "regrouped_on_this_data": list(final_fit.dependent),
        "nominal_notes": _nominal_notes(chain, base, final_fit),
        "diagnosis": diag_info,
        "seed": opts.seed,
        "elapsed_s": round(time.perf_counter() - t_start, 4),
    }
    return report, artifacts


def _errs(e) -> dict:
    d = e.as_dict()
    return {"rms_total": d["rms_total"], "rms_per_joint": d["rms_per_joint"], "relative_error": d["relative_error"]}


def _finite(x: float):
    return float(x) if np.isfinite(x) else None


def _explain(effect: str) -> str:
    return EFFECTS[effect].explanation


def _nominal_notes(chain: Chain, base, fit) -> list[str]:
    """Base parameters far from the description's nominal values: a payload or wrong mass shows here."""
    if chain.phi_nominal is None:
        return []
    phi = np.zeros(chain.layout.size)
    phi[: len(chain.phi_nominal)] = chain.phi_nominal
    nominal = base.K @ phi
    notes = []
    scale = np.max(np.abs(nominal)) if np.any(nominal) else 1.0
    where = {c: k for k, c in enumerate(fit.columns)}
    for i, name in enumerate(base.base_names):
        if i not in where:
            continue
        k = where[i]
        v, nom = fit.theta[k], nominal[i]
        sd = abs(v) * fit.std_percent[k] / 100 if np.isfinite(fit.std_percent[k]) else np.inf
        if abs(v - nom) > max(3 * sd, 0.2 * abs(nom), 0.02 * scale):
            notes.append(f"{name} = {v:.4g} differs from its nominal {nom:.4g}: a payload, a wrong link mass or inertia, not an effect")
    return notes
