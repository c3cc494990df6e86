"""Terminal report of `minparam identify` (pure: report dict -> text).

Every figure says which data it comes from: fit (the parameters were
estimated on it), selection (it chose the effects) or test (it chose
nothing).
"""

from __future__ import annotations

from minparam_cli.identify.passes.roles import span_text
from minparam_cli.render.columns import columns


def _pct(x) -> str:
    return "-" if x is None else f"{100 * x:.3g} %"


def _role(entries: list[dict]) -> str:
    return "; ".join(span_text(e) for e in entries)


def _error_rows(r: dict) -> list[tuple]:
    rows = []

    def row(label, e, data):
        return (label, *[f"{x:.4g}" for x in e["rms_per_joint"]], f"{e['rms_total']:.4g}", _pct(e["relative_error"]), data)

    phys = r.get("physical")
    rows.append(row("before", r["before"], "selection"))
    rows.append(row("after", r["after"], "selection"))
    if phys:
        rows.append(row("physical", phys["selection"], "selection"))
    files = r["test"]["files"]
    for k, f in enumerate(files):
        tag = "test" if len(files) == 1 else f"test {k + 1}"
        rows.append(row("before", f["rigid"], tag))
        rows.append(row("after", f["final"], tag))
        if phys:
            rows.append(row("physical", phys["test"][f["part"]], tag))
    return rows


def _physical_lines(p: dict) -> list[str]:
    """The bodies of the physically consistent fit, one row per link."""
    out = [f"Physically consistent fit ({p['solver']}, {p['status']}, {p['elapsed_s']:.2f} s; prior: {p['prior']}"
           + (f", weight {p['prior_weight']:g})" if p["prior_weight"] else ")")]
    rows = []
    for b in p["links"]:
        rows.append((b["link"], f"{b['mass']:.4g}", " ".join(f"{x:.3g}" for x in b["com"]),
                     " ".join(f"{x:.3g}" for x in b["principal_moments"]), f"{b['pseudo_inertia_min_eig']:.2g}",
                     f"{b['informed_directions']}/10"))
    out.append(columns(rows, ("link", "mass kg", "centre of mass m", "principal moments kg·m²", "min eig J", "data-set directions"),
                       right=(0, 1, 4, 5)))
    if p["not_informed"]:
        out.append(f"links the data did not inform (held by the {'prior' if p['prior'] != 'none' else 'lightest-body tie-break'}): "
                   + ", ".join(str(x) for x in p["not_informed"]))
    return out


def render_identify(r: dict) -> str:
    pre = r["preprocessing"]
    dropped = ", ".join(f"{k.replace('_', ' ')} {v}" for k, v in r["dropped"].items() if v) or "nothing"
    rows_read = sum(f["rows_read"] for f in r.get("files", [pre]))
    roles = r["roles"]
    head = [
        ("robot", r["robot"]),
        ("fit data", f"{r['samples_fit']} samples: {_role(roles['fit'])}"),
        ("selection data", f"{r['samples_selection']} samples: {_role(roles['selection'])} (chose the effects)"),
        ("test data", f"{r['samples_test']} samples: {_role(roles['test'])} (chose nothing)" if roles["test"] else "none"),
        ("dropped", f"{dropped} (of {rows_read} rows read in {len(r.get('files', [pre]))} file(s))"),
        ("irregular steps", f"{pre['irregular_steps']} (median step {pre['median_step_s']:.6g} s)" if pre.get("median_step_s") else "-"),
        ("filter", pre["filter"] or "none (q, q̇, q̈ given)"),
        ("derived", ", ".join(pre["derived"]) or "-"),
        ("decimation", f"keep 1 sample in {pre['decimation']}"),
    ]
    if pre.get("still_share") is not None:
        rest = f"; derived |dq| < {pre['rest_below']:g} read as rest (dq = 0)" if pre.get("rest_below") else ""
        head.append(("standstill", " ".join(f"{100 * s:.0f}%" for s in pre["still_share"]) + " of samples per joint" + rest))
    head += [
        ("fit", f"{r['method'].upper()}, condition number {r['condition_number']:.4g} "
                f"(column-scaled {r['condition_number_scaled']:.3g})"),
        ("coulomb", r.get("coulomb_model", "sign(dq)")),
    ]
    out = [columns(head), ""]
    n = len(r["before"]["rms_per_joint"])
    out.append("Error, rms (N·m or N): before = rigid-body model, after = final model, both fitted on the fit data"
               + ("; physical = the final model's physically consistent fit" if r.get("physical") else ""))
    hdr = ("", *[f"j{j + 1}" for j in range(n)], "total", "‖r‖/‖τ‖", "data")
    out.append(columns(_error_rows(r), hdr, right=tuple(range(1, n + 3))))
    out.append("")
    out.append("Diagnosis (each step judged on the selection data)")
    srows = []
    for i, s in enumerate(r["steps"]):
        st = s["statistic"] or {}
        if "replaces" in st:
            evidence = f"replaces {st['replaces']}: ΔBIC {st['delta_bic_selection']:.1f}"
        elif "removed" in st:
            evidence = st["why"]
        elif "delta_bic_selection" in st:
            evidence = f"ΔBIC {st['delta_bic_selection']:.1f}, gain {100 * st['selection_gain']:.1f} %"
        else:
            evidence = "-"
        srows.append((i, s.get("label") or "rigid-body model as declared", evidence, f"{s['rms_total']:.4g}", _pct(s["relative_error"])))
    out.append(columns(srows, ("step", "effect", "evidence", "rms", "‖r‖/‖τ‖"), right=(0, 3, 4)))
    out.append(f"stop: {r['stop_reason']}")
    for e in r["effects"]:
        out.append(f"  {e['effect']}: {e['explanation']}")
    for e in r.get("rejected", []):
        out.append(f"rejected: {e['reading']}")
    for f in r.get("flags", []):
        out.append(f"flag: {f}")
    out.append("")
    sig = f"σ % ({r.get('sigma', {}).get('kind', 'textbook')})"
    phys = r.get("physical")
    if phys:
        out += _physical_lines(phys) + [""]
        both = {**phys["base_parameters"], **phys["effect_coefficients"]}
        prows = [(k, f"{v['value']:.6g}", "-" if v["std_percent"] is None else f"{v['std_percent']:.3g}",
                  f"{both[k]:.6g}" if k in both else "-") for k, v in r["parameters"].items()]
        out.append(columns(prows, ("parameter", "value", sig, "physical"), right=(1, 2, 3)))
    else:
        prows = [(k, f"{v['value']:.6g}", "-" if v["std_percent"] is None else f"{v['std_percent']:.3g}") for k, v in r["parameters"].items()]
        out.append(columns(prows, ("parameter", "value", sig), right=(1, 2)))
    if r.get("sigma"):
        from minparam_cli.render.uncertainty_text import sigma_line

        out.append(sigma_line(r["sigma"]))
    if r.get("essential"):
        from minparam_cli.render.uncertainty_text import essential_lines

        out += [""] + essential_lines(r["essential"])
    for note in r.get("nominal_notes", []):
        out.append(f"note: {note}")
    out.append("")
    out.append(f"seed {r['seed']}; elapsed {r['elapsed_s']:.2f} s")
    return "\n".join(out)
