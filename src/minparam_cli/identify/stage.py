"""`identify` as one pure stage: robot chain + data file(s) -> ``IdentifyResult`` (identify/result.py).

The data are streamed once: per-joint QR accumulators of the declared model
plus the slot columns of the effect library (training and held-out parts, see
``slots``), and a bounded, evenly thinned sample of at most ``diagnosis_cap``
samples kept in memory for the diagnosis.  The final design's factors follow
from the accumulated ones by a linear map of the columns; only a design with
an effect that has no slot (``slots.SLOTTED``) streams the data a second time.
The diagnosis runs while the test data are still being read (``stream.Pass``).
Memory is bounded by the chunk size and the cap, not by the file.  The pass
itself is ``identify.stream``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from minparam_cli.chain import Chain
from minparam_cli.errors import DataError
from minparam_cli.measured.blocks import time_span
from minparam_cli.measured.records import Block, DataOptions
from minparam_cli.identify.passes.design import Design
from minparam_cli.identify.diagnosis.diagnose import DiagnosisOptions, diagnose
from minparam_cli.identify.diagnosis.evidence import term_evidence
from minparam_cli.identify.estimate.fit import Errors, errors, full_theta, solve
from minparam_cli.identify.estimate.records import Estimate, Step, TestFigures, TestFile
from minparam_cli.identify.diagnosis.explain import describe_rejected, describe_terms, nominal_notes
from minparam_cli.identify.physical.convex import PhysicalFit, PhysicalOptions
from minparam_cli.identify.physical.report import PhysicalReport
from minparam_cli.identify.assess.quality import COND_LIMIT, check_excitation, flags, keep_physical
from minparam_cli.identify.passes.roles import DEFAULT_SPLIT, FIT, SELECTION, TEST, describe, plan
from minparam_cli.identify.passes.slots import final_maps, slot_sources
from minparam_cli.identify.passes.stream import Pass, stream
from minparam_cli.identify.assess.uncertainty import BlockGrams, Uncertainty, UncertaintyOptions, block_length, estimate, relative_percent
from minparam_cli.identify.result import IdentifyResult

DIAGNOSIS_CAP = 12_000  # samples kept for the diagnosis (fit part; half as many of the selection part)


@dataclass(frozen=True)
class IdentifyOptions:
    data: DataOptions = field(default_factory=DataOptions)
    split: tuple[float, float, float] = DEFAULT_SPLIT  # fit, selection, test shares of the data file's time
    validate: str | None = None  # selection data file
    tests: tuple[str, ...] = ()  # test data files
    weighted: bool = True
    diagnose: bool = True
    diagnosis: DiagnosisOptions = field(default_factory=DiagnosisOptions)
    diagnosis_cap: int = DIAGNOSIS_CAP
    seed: int = 0
    cond_limit: float = COND_LIMIT
    physical: PhysicalOptions | None = None  # --physical: the convex fit over the full parameters as well
    uncertainty: UncertaintyOptions = field(default_factory=UncertaintyOptions)  # --sigma: which σ the report shows
    essential: float | None = None  # --essential: bound (%) on the relative σ of the essential parameters (essential.py)


@dataclass
class Artifacts:
    """What plots and a saved model need beside the result."""

    hold: Block | None = None  # selection samples of the diagnosis
    models: list = field(default_factory=list)  # (label, design, theta) of every step
    design: Design | None = None  # the final design (its theta_model and t0 set)
    theta: np.ndarray | None = None  # its parameters, every column (0 where regrouped on this data)
    std_percent: np.ndarray | None = None  # their relative σ (inf where regrouped)
    base: object | None = None  # the BaseSet the design's base columns come from
    physical: PhysicalFit | None = None  # with --physical
    uncertainty: Uncertainty | None = None  # of the final fit (its covariance feeds prediction bands)
    grams: object | None = None  # uncertainty.BlockGrams of the fit data, with the map to the final fit's columns


def identify(chain: Chain, data_path: str | Path, opts: IdentifyOptions, progress=None) -> tuple[IdentifyResult, Artifacts]:
    """Fit on the fit data, choose effects on the selection data, report on the test data (see ``roles``)."""
    with np.errstate(all="ignore"):  # numpy's floating-point warnings, this thread only: no process-wide filter
        return _identify(chain, Path(data_path), opts, progress)


def _identify(chain: Chain, data_path: Path, opts: IdentifyOptions, progress) -> tuple[IdentifyResult, Artifacts]:
    from minparam_cli.base.qr import derive_qr

    t_start = time.perf_counter()
    n = chain.dof  # data columns and torque rows: the independent joints (mimic joints follow their master)
    base = derive_qr(chain, seed=opts.seed)
    design = Design(chain, base.kept, base.base_names)
    tests = tuple(Path(t) for t in opts.tests)
    validate = Path(opts.validate) if opts.validate else None
    whole = (validate is not None or opts.split[1] == 0) and (tests or opts.split[2] == 0)
    span = None if whole else time_span(data_path, opts.data)
    sources = plan(data_path, validate, tests, opts.split, span)

    slots = slot_sources(opts.diagnosis.effects) if opts.diagnose else ()
    grams = BlockGrams(opts.uncertainty.block_s or block_length(opts.data.cutoff_hz))
    running = Pass(design, sources, n, opts.data, opts.diagnosis_cap, opts.diagnose, slots, grams)

    def declared(a):  # the design's own columns of an accumulator that also carries the slots
        return a.restrict(list(range(design.p))) if slots else a

    try:
        acc_early, thin, motion, design = running.early()  # the test data are still being read
        _enough(acc_early, design, data_path)
        acc = {k: declared(a) for k, a in acc_early.items()}
        prior = opts.physical is not None and opts.physical.prior != "none"
        # with a prior, the data need not inform every parameter: the prior holds the others (and says which)
        cond_scaled = check_excitation(acc[FIT], design, motion, float("inf") if prior else opts.cond_limit)
        fit0 = solve(acc[FIT], design.names, opts.weighted)
        before = errors(acc[SELECTION], fit0.theta, fit0.columns)
        design = replace(design, theta_model=full_theta(fit0, design.p))
        d = None
        if opts.diagnose:  # beside the reading of the test data, which it never sees
            train, hold = thin[FIT].block(), thin[SELECTION].block()
            diag_opts = replace(opts.diagnosis, weighted=opts.weighted, horizon_s=grams.length)  # σ's blocks: N_eff's lags
            d = diagnose(design, train, hold, diag_opts, progress)
    except BaseException as e:
        first = running.outcome(e)  # the pass's error (a bad test row) before ours, as when it ran first
        running.close()
        if first is e:
            raise
        raise first from e
    acc_all, _, _, reports, _ = running.result()
    keys = list(acc_all)
    test_keys = [k for k in keys if k not in (FIT, SELECTION)]
    _enough({k: acc_all[k] for k in test_keys}, design, data_path)
    acc.update({k: declared(acc_all[k]) for k in test_keys})
    tests_rigid = {k: errors(acc[k], fit0.theta, fit0.columns) for k in test_keys}

    maps = None
    steps_out = [Step(None, (), None, before)]
    stop_reason = "diagnosis off (--no-diagnose)"
    final_fit, after, final_design, acc_final = fit0, before, design, acc
    diag_info, rejected, diag_steps = {}, [], []
    artifacts = Artifacts()
    if d is not None:
        diag_steps = d.steps
        stop_reason = d.stop_reason
        rejected = d.rejected
        artifacts.hold = hold
        artifacts.models = [("rigid body" if s.term is None else f"+ {s.term.label()}", s.design, s.theta) for s in d.steps]
        diag_info = {"samples_fit": len(train), "samples_selection": len(hold), "candidates_per_step": d.candidates_per_step,
                     "bic_threshold": opts.diagnosis.bic_threshold, "min_gain": opts.diagnosis.min_gain}
        steps_out[0] = replace(steps_out[0], statistic=d.steps[0].statistic)
        for s_ in d.steps[1:]:
            assert s_.term is not None  # only the first step (the rigid body) has no term
            label = ("drop " if "drops" in s_.statistic else "") + s_.term.label() \
                + (" [model error, not named]" if s_.statistic.get("named") is False else "")
            steps_out.append(Step(s_.term.effect, tuple(j + 1 for j in s_.term.joints), s_.statistic, s_.errors,
                                  s_.term.hyper, label))
        if d.design.terms:
            final_design = d.design
            maps = final_maps(final_design, slots)
            if maps is not None:  # every added effect has slots: no second pass over the file
                acc_final = {k: a.transform(maps) for k, a in acc_all.items()}
            else:
                grams = BlockGrams(grams.length)
                acc_final, _, _, _, _ = stream(final_design, sources, n, opts.data, opts.diagnosis_cap, keep=False, grams=grams)
            final_fit = solve(acc_final[FIT], final_design.names, opts.weighted)
            kept_before = final_design
            final_design, final_fit, acc_final, removed = keep_physical(final_design, final_fit, acc_final, opts.weighted)
            if removed:  # keep_physical refits on fewer columns: the blocks follow the accumulators' columns
                from minparam_cli.identify.assess.uncertainty import restrict_maps

                maps = restrict_maps(maps, kept_before, final_design, grams)
            steps_out += removed
            after = errors(acc_final[SELECTION], final_fit.theta, final_fit.columns)
            if len(steps_out) > 1:
                # the last step's errors are the refit on all the fit data, measured on all selection samples
                steps_out[-1] = replace(steps_out[-1], errors=after)
    tests_final = {k: errors(acc_final[k], final_fit.theta, final_fit.columns) for k in test_keys}
    evidence = term_evidence(final_design.terms, diag_steps)
    final_fit, artifacts.uncertainty = _honest_sigma(grams, maps, final_fit, opts, progress)
    artifacts.grams = (grams, maps)
    essential = None
    if opts.essential is not None and grams is not None:
        from minparam_cli.identify.assess.essential import essential_report

        essential = essential_report(grams, maps, final_fit, opts.uncertainty, opts.essential, acc_final, test_keys)
    artifacts.design, artifacts.base = final_design, base
    artifacts.theta = full_theta(final_fit, final_design.p)
    artifacts.std_percent = np.full(final_design.p, np.inf)
    artifacts.std_percent[list(final_fit.columns)] = final_fit.std_percent
    physical = None
    if opts.physical is not None:
        physical, artifacts.physical = _physical(chain, base, final_design, final_fit, acc_final, opts.physical, test_keys)

    data_reports = [{"path": r.path, **r.as_dict()} for r in reports]
    dropped: dict = {}
    for r in data_reports:
        for k, v in r["dropped"].items():
            dropped[k] = dropped.get(k, 0) + v
    roles = describe(sources)
    for entry in roles[TEST]:
        entry["samples"] = int(acc[entry["part"]].rows[0])
    for entries in roles.values():
        for entry in entries:
            entry["still_share"] = motion.still_share(entry["part"])
    result = IdentifyResult(
        robot=chain.name,
        data=str(data_path),
        validate=opts.validate,
        test_files=tuple(str(t) for t in tests),
        split=tuple(opts.split),
        roles=roles,
        samples_used=int(sum(acc[k].rows[0] for k in keys)),
        samples_fit=int(acc[FIT].rows[0]),
        samples_selection=int(acc[SELECTION].rows[0]),
        samples_test=int(sum(acc[k].rows[0] for k in test_keys)),
        dropped=dropped,
        preprocessing=data_reports[0],
        files=tuple(data_reports),
        coulomb_model="sign(dq)" if chain.coulomb_smoothing == 0 else f"tanh(dq / {chain.coulomb_smoothing:g})",
        method=final_fit.method,
        condition_number=final_fit.cond,
        condition_number_scaled=cond_scaled,
        sigma_per_joint=tuple(float(x) for x in final_fit.sigma),
        steps=tuple(steps_out),
        stop_reason=stop_reason,
        before=before,
        after=after,
        test=_test_figures(roles, tests_rigid, tests_final, acc),
        effects=tuple(describe_terms(final_design, final_fit, motion, evidence)),
        rejected=tuple(describe_rejected(r, data_reports) for r in rejected),
        parameters=tuple(Estimate(nm, float(v), _finite(s), _finite(s0))
                         for nm, v, s, s0 in zip(final_fit.names, final_fit.theta, final_fit.std_percent, _textbook(artifacts, final_fit), strict=True)),
        sigma=artifacts.uncertainty.summary() if artifacts.uncertainty is not None else None,
        regrouped_on_this_data=tuple(final_fit.dependent),
        nominal_notes=tuple(nominal_notes(chain, base, final_fit, opts.seed)),
        diagnosis=diag_info,
        seed=opts.seed,
        physical=physical,
        essential=essential,
    )
    found = flags(result, final_fit) + (artifacts.uncertainty.flags() if artifacts.uncertainty is not None else [])
    if physical is not None and physical.on_boundary:
        from minparam_cli.identify.physical.provenance import boundary_flag

        found.append(boundary_flag(list(physical.on_boundary), physical.margin_kg))
    return replace(result, flags=tuple(found), elapsed_s=round(time.perf_counter() - t_start, 4)), artifacts


def _enough(accs: dict, design: Design, data_path: Path) -> None:
    """Refuse a part with too few samples (the fit part: no more than the design's columns)."""
    for key, acc in accs.items():
        need = design.p if key == FIT else 0
        if acc.rows.sum() <= need:
            raise DataError(f"{data_path}: the {key} data have too few samples ({int(acc.rows[0])})"
                            + (f" for {design.p} parameters" if key == FIT else ""))


def _textbook(artifacts: Artifacts, fit) -> np.ndarray:
    u = artifacts.uncertainty
    return fit.std_percent if u is None else relative_percent(fit.theta, u.std("textbook"))


def _honest_sigma(grams, maps, fit, opts: IdentifyOptions, progress):
    """The final fit with the σ of ``opts.uncertainty.kind`` (uncertainty.py), and that estimate."""
    if grams is None:
        return fit, None
    uopts, note = opts.uncertainty, None
    if uopts.block_s is None and uopts.kind != "textbook" and len(grams.packed) < 2:  # the default length, not asked for
        note = (f"the fit data ({grams.span():.3g} s) are shorter than two blocks of {grams.length:g} s: the σ shown are "
                f"the textbook ones, not {uopts.kind} (give a shorter --block-length)")
        uopts = replace(uopts, kind="textbook")
    if progress is not None and uopts.kind == "bootstrap":
        progress.label = "bootstrap"
    u = estimate(grams, maps, list(fit.columns), fit.sigma if fit.method == "wls" else None,
                 int(fit.rows), uopts, progress)
    return replace(fit, std_percent=relative_percent(fit.theta, u.std())), replace(u, columns=tuple(fit.columns), note=note)


WEIGHT_FLOOR = 1e-4  # the physical fit's per-joint weight σ_j is at least this fraction of the joint's RMS torque


def _physical(chain: Chain, base, design: Design, fit, acc: dict, popts: PhysicalOptions, test_keys: list):
    """The convex fit on the fit data (same weights as the unconstrained fit), its errors on the
    selection and test data beside the unconstrained ones, and its bodies."""
    from minparam_cli.identify.physical.convex import fit_physical, link_bodies

    weights = fit.sigma if fit.method == "wls" else np.ones(chain.dof)
    # a σ at rounding level (noise-free data) would scale the program's numbers by 1e14 and no conic solver
    # ends there: the weights are floored at WEIGHT_FLOOR of each joint's RMS torque (they never are on
    # measured data, whose σ are percents of it)
    rms = np.sqrt(acc[FIT].y_norm2() / np.maximum(acc[FIT].rows, 1))
    weights = np.maximum(weights, WEIGHT_FLOOR * rms) if np.any(rms > 0) else weights
    R = acc[FIT].stacked(weights)
    pf = fit_physical(chain, base.K, design, R, int(acc[FIT].rows.sum()), popts)
    n_links = chain.layout.n_inertial // 10
    bodies = link_bodies(pf.phi, n_links)
    _provenance(chain, bodies, pf, popts)
    nb = len(design.kept)
    out = PhysicalReport(
        solver=pf.solver, status=pf.status, prior=popts.prior,
        prior_weight=popts.prior_weight if popts.prior != "none" else None,
        margin_kg=popts.margin, data_cost=pf.data_cost, prior_cost=pf.prior_cost,
        elapsed_s=round(pf.elapsed_s, 4),
        selection=errors(acc[SELECTION], pf.theta),
        test={k: errors(acc[k], pf.theta) for k in test_keys},
        base_parameters={nm: float(v) for nm, v in zip(design.names[:nb], pf.theta[:nb], strict=True)},
        effect_coefficients={nm: float(v) for nm, v in zip(design.names[nb:], pf.theta[nb:], strict=True)},
        phi={nm: float(v) for nm, v in zip(pf.names, pf.phi, strict=True)},
        links=tuple(bodies),
        not_informed=tuple(b["link"] for b in bodies if b["informed_directions"] == 0),
        partly_informed=tuple(b["link"] for b in bodies if 0 < b["informed_directions"] < 10),
        not_fixed=tuple(b["link"] for b in bodies if not b["fixed"]),
        on_boundary=tuple(b["link"] for b in bodies if b["on_boundary"]),
        mass_bounds=popts.mass_bounds, total_mass=popts.total_mass,
        geometry=tuple(sorted({e.source for e in popts.ellipsoids if e is not None})),
    )
    return out, pf


def _provenance(chain: Chain, bodies: list, pf: PhysicalFit, popts: PhysicalOptions) -> None:
    """Per link: the directions the data set, where the others come from, whether it is fixed, whether
    it sits on the boundary of physical consistency, and its ellipsoid (identify/physical/provenance.py)."""
    from minparam_cli.identify.physical.convex import length_scale
    from minparam_cli.identify.physical.geometry import ellipsoid_slack
    from minparam_cli.identify.physical.provenance import on_boundary, sources

    L = length_scale(chain)
    bounds = popts.mass_bounds or ((0.0, np.inf),) * len(bodies)
    for i, (b, informed) in enumerate(zip(bodies, pf.informed, strict=True)):
        ell = popts.ellipsoids[i] if i < len(popts.ellipsoids) else None
        phi_link = pf.phi[10 * i : 10 * (i + 1)]
        b["name"] = chain.link_names[i] or f"link{i + 1}"
        b["informed_directions"] = informed  # of its 10 parameters' directions, set by the data
        bounded = bool(np.isfinite(bounds[i][1])) or popts.total_mass is not None
        b["source"], b["fixed"] = sources(informed, popts.prior == "nominal", ell is not None, bounded)
        b["on_boundary"] = on_boundary(phi_link, L, popts.margin)
        hi = float(bounds[i][1])
        b["mass_bounds"] = [float(bounds[i][0]), hi if np.isfinite(hi) else None] if popts.mass_bounds else None
        b["ellipsoid"] = None if ell is None else {**ell.to_dict(), "slack_kg": ellipsoid_slack(phi_link, ell, popts.margin, L)}


def _test_figures(roles: dict, rigid: dict, final: dict, acc: dict) -> TestFigures:
    """Test errors per test part and pooled over all of them (each part's squares summed)."""
    files = tuple(TestFile(entry, rigid[entry["part"]], final[entry["part"]]) for entry in roles[TEST])
    if len(files) == 1:
        return TestFigures(files, files[0].rigid, files[0].final)
    if not files:
        return TestFigures()
    pooled = []
    for errs in (rigid, final):
        rss = sum(np.asarray(e.rms_per_joint) ** 2 * np.maximum(acc[k].rows, 1) for k, e in errs.items())
        rows = sum(np.maximum(acc[k].rows, 1) for k in errs)
        y2 = sum(acc[k].y_norm2().sum() for k in errs)
        pooled.append(Errors(rms_total=float(np.sqrt(rss.sum() / rows.sum())),
                             rms_per_joint=tuple(float(x) for x in np.sqrt(rss / rows)),
                             relative_error=float(np.sqrt(rss.sum() / y2)) if y2 > 0 else float("nan")))
    return TestFigures(files, pooled[0], pooled[1])


def _finite(x: float):
    return float(x) if np.isfinite(x) else None
