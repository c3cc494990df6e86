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
    if s.get("blocks"):
        out += f"; {s['blocks']} blocks of {s['block_length_s']:g} s"
    if kind == "bootstrap":
        out += f", {s['replicates']} replicates, seed {s['seed']}"
    if s.get("ratio_to_textbook_median") is not None and kind != "textbook":
        out += f"; median {s['ratio_to_textbook_median']:.2g}x the textbook σ"
    return out
