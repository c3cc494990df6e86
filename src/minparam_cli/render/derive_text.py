"""``minparam derive``'s output: one base set in any format, or a batch of them with the summary table.

A base set renders itself (``BaseSet.table()``, ``markdown()``, ``latex()``, ``to_dict()``); here the
format is chosen, and a batch's items (``cli.batch`` results holding base sets or errors) are joined."""

from __future__ import annotations


def render(base, fmt: str) -> str:
    """One base set in ``fmt``."""
    if fmt in ("json", "jsonl"):
        import json  # imported here: the default table output does not need it

        return json.dumps(base.to_dict(), indent=2 if fmt == "json" else None, ensure_ascii=False)
    if fmt == "markdown":
        return base.markdown()
    if fmt == "latex":
        return base.latex()
    return base.table()


def _summary_rows(results: list[dict]) -> list[tuple]:
    rows = []
    for r in results:
        if r["ok"]:
            b = r["result"]
            rows.append((b.robot, r["path"], b.derivation.about.dof, b.n_standard, b.n_base, f"{r['elapsed_s']:.3f}", "ok"))
        else:
            rows.append(("", r["path"], "", "", "", f"{r['elapsed_s']:.3f}", f"{r['status']}: {r['error']}"))
    return rows


def render_batch(results: list[dict], fmt: str, reports: bool = True) -> str:
    """Several robots: JSON items, or each robot's report followed by the summary table.

    In table format the reports are left out when ``reports`` is False (a folder was given: the
    summary is what one reads of a folder of robots); robots named one by one get theirs."""
    import json

    from tabulate import tabulate

    if fmt in ("json", "jsonl"):
        items = []
        for r in results:
            if r["ok"]:
                items.append(r["result"].to_dict())
            else:
                items.append({"source": r["path"], "status": r["status"], "error": r["error"]})
        if fmt == "jsonl":
            return "\n".join(json.dumps(i, ensure_ascii=False) for i in items)
        return json.dumps(items, indent=2, ensure_ascii=False)
    headers = ["robot", "file", "dof", "standard", "base", "time s", "status"]
    if fmt == "table":
        summary = tabulate(_summary_rows(results), headers=headers, tablefmt="simple")
        if not reports:
            return summary
        return "\n\n".join([render(r["result"], fmt) for r in results if r["ok"]] + [summary])
    parts = [render(r["result"], fmt) for r in results if r["ok"]]
    if fmt == "markdown":
        parts.append(tabulate(_summary_rows(results), headers=headers, tablefmt="github"))
    return "\n".join(parts)
