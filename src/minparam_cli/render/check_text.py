"""``minparam check``'s table: one row per file, from the batch's results (``CheckResult`` or the error)."""

from __future__ import annotations


def check_table(results: list[dict]) -> str:
    from tabulate import tabulate

    rows = []
    for r in results:
        if r["ok"]:
            c = r["result"]
            bodies = f"{len(c.bodies)} real" if c.bodies else "no data"
            rows.append((r["path"], c.robot, c.dof, c.joint_types, c.convention, "yes" if c.exact else "no", bodies, "ok"))
        else:
            # an error's line goes to stderr; a skipped file says why here
            rows.append((r["path"], "", "", "", "", "", "", r["status"] if r["status"] == "error" else f"{r['status']}: {r['error']}"))
    return tabulate(rows, headers=["file", "robot", "dof", "joints", "convention", "exact", "bodies", "status"], tablefmt="simple")
