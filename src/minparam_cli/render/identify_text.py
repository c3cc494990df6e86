"""Terminal report of `minparam identify` (pure: IdentifyResult -> text).

Every figure says which data it comes from: fit (the parameters were
estimated on it), selection (it chose the effects) or test (it chose
nothing).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from minparam_cli.identify.passes.roles import span_text
from minparam_cli.render.columns import columns

if TYPE_CHECKING:
    from minparam_cli.identify.estimate.errors import Errors
    from minparam_cli.identify.physical.report import PhysicalReport
    from minparam_cli.identify.result import IdentifyResult


def _pct(x) -> str:
    return "-" if x is None else f"{100 * x:.3g} %"


def _role(entries: list[dict]) -> str:
    return "; ".join(span_text(e) for e in entries)


def _error_rows(r: IdentifyResult) -> list[tuple]:
    rows = []

    def row(label, e: Errors, data):
        return (label, *[f"{x:.4g}" for x in e.rms_per_joint], f"{e.rms_total:.4g}", _pct(e.relative_error), data)

    phys = r.physical
    rows.append(row("before", r.before, "selection"))
    rows.append(row("after", r.after, "selection"))
    if phys:
        rows.append(row("physical", phys.selection, "selection"))
    files = r.test.files
    for k, f in enumerate(files):
        tag = "test" if len(files) == 1 else f"test {k + 1}"
        rows.append(row("before", f.rigid, tag))
        rows.append(row("after", f.final, tag))
        if phys:
            rows.append(row("physical", phys.test[f.part], tag))
    return rows


def _physical_lines(p: PhysicalReport) -> list[str]:
    """The bodies of the physically consistent fit, one row per link."""
    out = [f"Physically consistent fit ({p.solver}, {p.status}, {p.elapsed_s:.2f} s; prior: {p.prior}"
           + (f", weight {p.prior_weight:g})" if p.prior_weight else ")")]
    rows = []
    for b in p.links:
        src = b.get("source") or {"data": b["informed_directions"]}
        rows.append((b["link"], f"{b['mass']:.4g}", " ".join(f"{x:.3g}" for x in b["com"]),
                     " ".join(f"{x:.3g}" for x in b["principal_moments"]), f"{b['pseudo_inertia_min_eig']:.2g}"
                     + (" (boundary)" if b.get("on_boundary") else ""),
                     f"{b['informed_directions']}/10", " + ".join(f"{k} {v}" for k, v in src.items() if v)
                     + ("" if b.get("fixed", True) else " (not fixed)")))
    out.append(columns(rows, ("link", "mass kg", "centre of mass m", "principal moments kg·m²", "min eig J", "data-set directions",
                              "source of the 10 directions"), right=(0, 1, 4, 5)))
    if p.not_informed:
        out.append(f"links the data did not inform (held by the {'prior' if p.prior != 'none' else 'geometry/bounds or the lightest-body tie-break'}): "
                   + ", ".join(str(x) for x in p.not_informed))
    extra = ([f"geometry: the links' ellipsoids from {', '.join(p.geometry)}"] if p.geometry else []) + \
        ([f"mass bounds: {', '.join(f'{lo:g}-{hi:g}' for lo, hi in p.mass_bounds)} kg"] if p.mass_bounds else []) + \
        ([f"total mass: {p.total_mass:g} kg"] if p.total_mass is not None else [])
    out += extra
    if p.not_fixed:
        out.append("not fixed (only the tie-break holds their free directions; --export-urdf/--export-yaml refuse them): links "
                   + ", ".join(str(x) for x in p.not_fixed))
    return out


def _evidence(st) -> str:
    """The evidence column of one diagnosis step (ΔBIC_eff: the selection statistic under correlated residuals)."""
    bic = "ΔBIC_eff" if "delta_bic_eff" in st else "ΔBIC"
    value = st.get("delta_bic_eff", st.get("delta_bic_selection"))
    if "replaces" in st or "drops" in st:
        how = "replaces" if "replaces" in st else "drops"
        # a tie (the simpler model spans the same columns) is 0 up to rounding: "0.0", never "-0.0"
        return f"{how} {st.get('replaces') or st.get('drops')}: {bic} {round(value, 1) + 0.0:.1f}"
    if "removed" in st:
        return str(st["why"])
    if value is None:
        return f"N_eff {st['n_eff']:.0f} of {st['n_selection']}" if "n_eff" in st else "-"
    text = f"{bic} {value:.1f}" + (f", N_eff {st['n_eff']:.0f}" if "n_eff" in st else "")
    text += f", gain {100 * st['selection_gain']:.1f} %"
    if st.get("periods_seen") is not None:
        text += f", {st['periods_seen']:.2g} periods"
    return text


def render_identify(r: IdentifyResult) -> str:
    """The report, then the payload's identification when there is one."""
    text = _render(r)
    if r.payload is not None:
        from minparam_cli.render.payload_text import render_payload

        text = text.rstrip("\n") + "\n\n" + render_payload(r.payload)
    return text


def _segments(files) -> str:
    """Segments between gaps, over every file, and what the filter dropped at their ends."""
    seg = sum(f.get("segments", 1) for f in files)
    gaps = seg - len(files)
    text = f"{seg}" + (f" ({gaps} gap(s) longer than {files[0].get('gap_steps')} steps, {sum(f.get('gap_s', 0.0) for f in files):.4g} s in all, "
                       "filtered apart)" if gaps else "")
    trimmed = sum(f["dropped"].get("filter_edges", 0) for f in files)
    if files[0].get("trim_s"):
        text += f"; {files[0]['trim_s']:.4g} s dropped at both ends of each ({trimmed} samples in all)"
    return text


def _render(r: IdentifyResult) -> str:
    pre = r.preprocessing
    dropped = ", ".join(f"{k.replace('_', ' ')} {v}" for k, v in r.dropped.items() if v) or "nothing"
    files = r.files or (pre,)
    rows_read = sum(f["rows_read"] for f in files)
    roles = r.roles
    head = [
        ("robot", r.robot),
        ("fit data", f"{r.samples_fit} samples: {_role(roles['fit'])}"),
        ("selection data", f"{r.samples_selection} samples: {_role(roles['selection'])} (chose the effects)"),
        ("test data", f"{r.samples_test} samples: {_role(roles['test'])} (chose nothing)" if roles["test"] else "none"),
        ("dropped", f"{dropped} (of {rows_read} rows read in {len(files)} file(s))"),
        ("irregular steps", f"{pre['irregular_steps']} (median step {pre['median_step_s']:.6g} s)" if pre.get("median_step_s") else "-"),
        ("segments", _segments(files)),
        ("filter", pre["filter"] or "none (q, q̇, q̈ given)"),
        ("derived", ", ".join(pre["derived"]) or "-"),
        ("decimation", f"keep 1 sample in {pre['decimation']}"),
    ]
    if pre.get("still_share") is not None:
        rest = f"; derived |dq| < {pre['rest_below']:g} read as rest (dq = 0)" if pre.get("rest_below") else ""
        head.append(("standstill", " ".join(f"{100 * s:.0f}%" for s in pre["still_share"]) + " of samples per joint" + rest))
    head += [
        ("fit", f"{r.method.upper()}, condition number {r.condition_number:.4g} "
                f"(column-scaled {r.condition_number_scaled:.3g})"),
        ("coulomb", r.coulomb_model),
    ]
    out = [columns(head), ""]
    n = len(r.before.rms_per_joint)
    out.append("Error, rms (N·m or N): before = rigid-body model, after = final model, both fitted on the fit data"
               + ("; physical = the final model's physically consistent fit" if r.physical else ""))
    hdr = ("", *[f"j{j + 1}" for j in range(n)], "total", "‖r‖/‖τ‖", "data")
    out.append(columns(_error_rows(r), hdr, right=tuple(range(1, n + 3))))
    out.append("")
    out.append("Diagnosis (each step judged on the selection data)")
    srows = []
    for i, s in enumerate(r.steps):
        st = s.statistic or {}
        evidence = _evidence(st)
        srows.append((i, s.label or "rigid-body model as declared", evidence, f"{s.errors.rms_total:.4g}", _pct(s.errors.relative_error)))
    out.append(columns(srows, ("step", "effect", "evidence", "rms", "‖r‖/‖τ‖"), right=(0, 3, 4)))
    out.append(f"stop: {r.stop_reason}")
    for e in r.effects:
        out.append(f"  {e['effect']}: {e['explanation']}")
    for e in r.rejected:
        out.append(f"rejected: {e['reading']}")
    for f in r.flags:
        out.append(f"flag: {f}")
    out.append("")
    sig = f"σ % ({r.sigma_kind})"
    phys = r.physical
    if phys:
        out += _physical_lines(phys) + [""]
        both = {**phys.base_parameters, **phys.effect_coefficients}
        prows: list[tuple[str, ...]] = [(v.name, f"{v.value:.6g}", "-" if v.std_percent is None else f"{v.std_percent:.3g}",
                                         f"{both[v.name]:.6g}" if v.name in both else "-") for v in r.parameters]
        out.append(columns(prows, ("parameter", "value", sig, "physical"), right=(1, 2, 3)))
    else:
        prows = [(v.name, f"{v.value:.6g}", "-" if v.std_percent is None else f"{v.std_percent:.3g}") for v in r.parameters]
        out.append(columns(prows, ("parameter", "value", sig), right=(1, 2)))
    from minparam_cli.render.uncertainty_text import essential_lines, sigma_line

    out.append(sigma_line(r.sigma))
    if r.essential is not None:
        out += [""] + essential_lines(r.essential)
    for note in r.nominal_notes:
        out.append(f"note: {note}")
    out.append("")
    out.append(f"seed {r.seed}; elapsed {r.elapsed_s:.2f} s")
    return "\n".join(out)
