"""Aligned text columns for the single-robot table.

tabulate renders every other table; this one is on the hot path of
`minparam derive`, where importing tabulate (it pulls importlib.metadata and
html) costs more than the whole base-set computation.
"""

from __future__ import annotations


def columns(rows: list[tuple], headers: tuple[str, ...] | None = None, right: tuple[int, ...] = ()) -> str:
    """Rows of cells as left-aligned columns (right-aligned for indices in ``right``),
    with a dashed rule under the headers when given."""
    cells = [[str(c) for c in r] for r in rows]
    if headers:
        cells.insert(0, list(headers))
    if not cells:
        return ""
    widths = [max(len(r[i]) for r in cells) for i in range(len(cells[0]))]

    def line(r):
        parts = [c.rjust(w) if i in right else c.ljust(w) for i, (c, w) in enumerate(zip(r, widths))]
        return "  ".join(parts).rstrip()

    out = [line(r) for r in cells]
    if headers:
        out.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(out)
