"""Terminal report of `minparam identify` (pure: report dict -> text)."""

from __future__ import annotations

from minparam_cli.render.columns import columns


def _pct(x) -> str:
    return "-" if x is None else f"{100 * x:.3g} %"


def render_identify(r: dict) -> str:
    pre = r["preprocessing"]
    dropped = ", ".join(f"{k.replace('_', ' ')} {v}" for k, v in r["dropped"].items() if v) or "nothing"
    head = [
        ("robot", r["robot"]),
        ("data", r["data"] + (f" (validated on {r['validate']})" if r.get("validate") else "")),
        ("samples", f"{r['samples_used']} used: {r['samples_train']} to identify, {r['samples_holdout']} held out"),
        ("dropped", f"{dropped} (of {pre['rows_read']} rows read)"),
        ("irregular steps", f"{pre['irregular_steps']} (median step {pre['median_step_s']:.6g} s)" if pre.get("median_step_s") else "-"),
        ("filter", pre["filter"] or "none (q, q̇, q̈ given)"),
        ("derived", ", ".join(pre["derived"]) or "-"),
        ("decimation", f"keep 1 sample in {pre['decimation']}"),
        ("fit", f"{r['method'].upper()}, condition number {r['condition_number']:.4g}"),
        ("coulomb", r.get("coulomb_model", "sign(dq)")),
    ]
    out = [columns(head), ""]
    n = len(r["before"]["rms_per_joint"])
    rows = [("rms before", *[f"{x:.4g}" for x in r["before"]["rms_per_joint"]], f"{r['before']['rms_total']:.4g}", _pct(r["before"]["relative_error"])),
            ("rms after", *[f"{x:.4g}" for x in r["after"]["rms_per_joint"]], f"{r['after']['rms_total']:.4g}", _pct(r["after"]["relative_error"]))]
    out.append("Held-out error (N·m or N)")
    out.append(columns(rows, ("", *[f"j{j + 1}" for j in range(n)], "total", "‖r‖/‖τ‖"), right=tuple(range(1, n + 3))))
    out.append("")
    out.append("Diagnosis (each step judged on the held-out data)")
    srows = []
    for i, s in enumerate(r["steps"]):
        st = s["statistic"] or {}
        if "replaces" in st:
            evidence = f"replaces {st['replaces']}: ΔBIC {st['delta_bic_holdout']:.1f}"
        elif "delta_bic_holdout" in st:
            evidence = f"ΔBIC {st['delta_bic_holdout']:.1f}, gain {100 * st['holdout_gain']:.1f} %"
        else:
            evidence = "-"
        srows.append((i, s.get("label") or "rigid-body model as declared", evidence, f"{s['rms_total']:.4g}", _pct(s["relative_error"])))
    out.append(columns(srows, ("step", "effect added", "evidence", "rms", "‖r‖/‖τ‖"), right=(0, 3, 4)))
    out.append(f"stop: {r['stop_reason']}")
    for e in r["effects"]:
        out.append(f"  {e['effect']}: {e['explanation']}")
    out.append("")
    prows = [(k, f"{v['value']:.6g}", "-" if v["std_percent"] is None else f"{v['std_percent']:.3g}") for k, v in r["parameters"].items()]
    out.append(columns(prows, ("parameter", "value", "σ %"), right=(1, 2)))
    for note in r.get("nominal_notes", []):
        out.append(f"note: {note}")
    out.append("")
    out.append(f"seed {r['seed']}; elapsed {r['elapsed_s']:.2f} s")
    return "\n".join(out)
