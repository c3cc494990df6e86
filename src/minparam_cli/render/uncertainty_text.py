"""Text for the σ of identify: which kind the table shows, and the essential-parameter reduction (pure)."""

from __future__ import annotations

WHAT = {
    "hac": "Newey–West over time blocks (allows for correlated residuals)",
    "bootstrap": "block bootstrap over time (allows for correlated residuals)",
    "textbook": "textbook σ²(WᵀW)⁻¹ (assumes white, independent residuals)",
}


def sigma_line(s: dict) -> str:
    """One line: the kind of σ shown, its blocks, and how it compares with the textbook σ."""
    kind = s.get("kind", "textbook")
    out = f"σ: {WHAT.get(kind, kind)}"
    if s.get("blocks") and kind != "textbook":
        out += f"; {s['blocks']} blocks of {s['block_length_s']:g} s"
    if kind == "bootstrap":
        out += f", {s['replicates']} replicates, seed {s['seed']}"
    if s.get("ratio_to_textbook_median") is not None and kind != "textbook":
        out += f"; median {s['ratio_to_textbook_median']:.2g}x the textbook σ"
    return out


def essential_lines(e: dict) -> list[str]:
    """The essential parameter set (Pham & Gautier 1991), what was dropped and why, and the cost in error."""
    from minparam_cli.render.columns import columns

    out = [(f"Essential parameters (every relative σ ≤ {e['bound_percent']:g} %): {len(e['parameters'])} kept, "
            f"{len(e['dropped'])} dropped; condition number {e['condition_number']:.4g} (all: {e['condition_number_full']:.4g})")]
    rows = [(k, f"{v['value']:.6g}", f"{v['std_percent']:.3g}") for k, v in e["parameters"].items()]
    out.append(columns(rows, ("essential", "value", "σ %"), right=(1, 2)))
    for d in e["dropped"]:
        out.append(f"dropped {d['parameter']} = {d['value']:.4g}: {d['why']}")
    b, a = e["error_before"], e["error_after"]

    def rel(x):
        return "-" if x is None else f"{100 * x:.3g} %"

    out.append(f"error on {e['error_data']}: rms {b['rms_total']:.4g} -> {a['rms_total']:.4g}, "
               f"‖r‖/‖τ‖ {rel(b['relative_error'])} -> {rel(a['relative_error'])} (all parameters -> essential set)")
    return out


def band_lines(r: dict) -> list[str]:
    """evaluate --band: per file and joint, the share of samples inside the band and its mean half-width."""
    from minparam_cli.render.columns import columns

    b = r["band"]
    n = len(r["pooled"]["rms_per_joint"])
    rows = []
    entries = [(f["path"], f["band"]) for f in r["files"]] + ([("pooled", r["pooled"]["band"])] if len(r["files"]) > 1 else [])
    for label, e in entries:
        rows.append((label, *[f"{100 * x:.1f} %" for x in e["inside_per_joint"]],
                     *[f"{h:.3g} ({hp:.2g})" for h, hp in zip(e["half_width_per_joint"], e["parameter_half_width_per_joint"])]))
    hdr = ("data", *[f"inside {j}" for j in range(1, n + 1)], *[f"± {j} (θ part)" for j in range(1, n + 1)])
    return [(f"Prediction band {100 * b['level']:g} % (z = {b['z']:.3g}; parameter covariance: {b['sigma']}, "
             "plus the fit's residual σ per joint): share of samples inside, mean half-width (N·m or N)"),
            columns(rows, hdr, right=tuple(range(1, 2 * n + 1)))]
