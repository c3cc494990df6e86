"""Terminal table, Markdown and LaTeX renderings of a derive report."""

from __future__ import annotations

import re

from minparam_cli.params import latex_name
from minparam_cli.render.columns import columns
from minparam_cli.render.report import format_coefficient


def _header_lines(r: dict) -> list[tuple[str, str]]:
    g = ", ".join(f"{x:g}" for x in r["gravity"])
    rows = [
        ("robot", f"{r['robot']} ({r['source']})"),
        ("method", r["method"] + (" (exact rational arithmetic)" if r.get("exact") else "")),
        ("dof", f"{r['dof']} ({r['convention']}" + (", floating base: 6 base coordinates + joints)" if r.get("floating_base") else ")")),
        ("gravity", f"({g}) m/s² [{r.get('gravity_source', 'file')}]"),
    ]
    mimic = [(link["joint"], link["mimic"]) for link in r.get("links", []) if link.get("mimic")]
    if mimic:
        rows.append(("mimic", "; ".join(f"{name} = {_mimic_text(m)}" for name, m in mimic)))
    rows += [
        ("standard", str(r["n_standard"])),
        ("base", str(r["n_base"])),
    ]
    if r.get("seed") is not None:
        rows.append(("samples", f"{r['samples']} random states, seed {r['seed']}"))
    m = r.get("rank_margin") or {}
    if m.get("last_kept") is not None:
        fd = m.get("first_dropped")
        rows.append(("rank margin", f"last kept {m['last_kept']:.3g}, first dropped {fd:.3g} (relative)" if fd is not None else f"last kept {m['last_kept']:.3g}"))
    elif m:
        rows.append(("rank margin", m.get("criterion", "")))
    return rows


def _mimic_text(m: dict) -> str:
    """{'joint': 'j3', 'multiplier': -0.5, 'offset': 0.1} -> '-0.5·j3 + 0.1'."""
    mult = {1: "", -1: "-"}.get(m["multiplier"], f"{m['multiplier']:g}·")
    off = f" {'+' if m['offset'] >= 0 else '-'} {abs(m['offset']):g}" if m["offset"] else ""
    return f"{mult}{m['joint']}{off}"


def render_table(r: dict) -> str:
    head = columns(_header_lines(r))
    rows = [(i + 1, b["name"], b.get("symbolic_text") or b["expression"]) for i, b in enumerate(r["base_parameters"])]
    body = columns(rows, ("#", "base parameter", "= standard parameters"), right=(0,))
    out = [head, "", body]
    if r["unidentifiable"]:
        out += ["", f"no effect ({len(r['unidentifiable'])}): " + " ".join(r["unidentifiable"])]
    names = _joint_rows(r)
    if names:
        out += ["", columns(names, JOINT_HEADERS, right=(0, 4))]
    out += _geometry_notes(r)
    out += _symbolic_footer(r)
    out.append("")
    out.append(f"units: SI (kg, m, kg·m, kg·m²); elapsed {r['elapsed_s']:.3f} s")
    return "\n".join(out)


JOINT_HEADERS = ("j", "joint", "link", "type", "parent")


def _joint_rows(r: dict) -> list[tuple]:
    """For a URDF robot: which joint and link the index j of a parameter name (XX3, MXR3) stands for.

    A YAML arm numbers its rows itself; a URDF's order comes from walking its tree, so it is named.
    With a floating base, j = 0 is the free root body."""
    if r.get("convention") != "urdf":
        return []
    rows = []
    for link in r.get("links", []):
        if link.get("index") is None:
            continue
        if link["index"] == 0:  # the free root body, carried by the six base coordinates
            rows.append((0, "(floating base)", link["link"], "6-DOF", ""))
        else:
            rows.append((link["index"], link["joint"], link["link"], link["type"], "" if link["parent"] is None else link["parent"]))
    return rows


def _geometry_notes(r: dict) -> list[str]:
    """Weakly identifiable parameters (with the geometry responsible) and the angles --snap-angles changed."""
    out = []
    weak = r.get("weakly_identifiable") or []
    if weak:
        out.append(f"weakly identifiable ({len(weak)}, kept with a relative margin below {weak[0]['bound']:g}):")
        for w in weak:
            why = "; ".join(w["geometry"]) if w["geometry"] else "no single near-special joint relation found"
            out.append(f"  {w['parameter']}  margin {w['margin']:.2g}  {why}")
    snap = r.get("snap_angles")
    if snap is not None:
        changed = snap["changed"]
        out.append(f"--snap-angles {snap['tolerance_rad']:g} rad changed {len(changed)} value{'' if len(changed) == 1 else 's'}:")
        for a in changed:
            out.append(f"  {a['where']}: {a['from']!r} -> {a['to']!r} ({a['degrees']} deg)")
    return ([""] + out) if out else []


def _symbolic_footer(r: dict) -> list[str]:
    out = [f"note: {n}" for n in r.get("symbolic_notes", [])]
    if r.get("symbols"):
        out.append("symbols (SI): " + ", ".join(f"{k} = {v:g}" for k, v in r["symbols"].items()))
    return ([""] + out) if out else []


def render_markdown(r: dict) -> str:
    lines = [f"## {r['robot']}", ""]
    for k, v in _header_lines(r):
        lines.append(f"- **{k}**: {v}")
    lines += ["", "| # | base parameter | expression |", "|---|---|---|"]
    for i, b in enumerate(r["base_parameters"]):
        lines.append(f"| {i + 1} | `{b['name']}` | `{b.get('symbolic_text') or b['expression']}` |")
    if r["unidentifiable"]:
        lines += ["", "No effect: " + ", ".join(f"`{n}`" for n in r["unidentifiable"])]
    names = _joint_rows(r)
    if names:
        lines += ["", "| " + " | ".join(JOINT_HEADERS) + " |", "|---|---|---|---|---|"]
        lines += ["| " + " | ".join(f"`{c}`" if i in (1, 2) and c and not str(c).startswith("(") else str(c) for i, c in enumerate(row)) + " |" for row in names]
    notes = [ln for ln in _geometry_notes(r) if ln]
    if notes:
        lines += ["", "```", *notes, "```"]
    lines += [f"- {ln}" for ln in _symbolic_footer(r) if ln]
    return "\n".join(lines) + "\n"


def latex_terms(terms: dict[str, float]) -> str:
    out = ""
    for name, c in terms.items():
        mag = abs(c)
        body = latex_name(name) if format_coefficient(mag) == "1" else rf"{_latex_number(mag)}\,{latex_name(name)}"
        if not out:
            out = ("-" if c < 0 else "") + body
        else:
            out += (" - " if c < 0 else " + ") + body
    return out


def _latex_number(x: float) -> str:
    s = format_coefficient(x)
    m = re.match(r"^([0-9.]+)e([+-]\d+)$", s)
    if m:
        return rf"{m.group(1)}\cdot 10^{{{int(m.group(2))}}}"
    return s


def render_latex(r: dict) -> str:
    g = ", ".join(f"{x:g}" for x in r["gravity"])
    lines = [
        f"% {r['robot']}: {r['n_base']} base parameters of {r['n_standard']} ({r['method']}), gravity ({g}) m/s^2, SI units",
        r"\begin{align*}",
    ]
    items = r["base_parameters"]
    for i, b in enumerate(items):
        end = r" \\" if i < len(items) - 1 else ""
        rhs = b.get("symbolic_latex") or latex_terms(b["terms"])
        lines.append(f"  {latex_name(b['name'])} &= {rhs}{end}")
    lines.append(r"\end{align*}")
    return "\n".join(lines) + "\n"
