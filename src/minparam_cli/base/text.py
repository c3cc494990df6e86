"""Terminal table, Markdown and LaTeX renderings of a derived base set (``BaseSet.table()``,
``markdown()``, ``latex()``): the base set in, text out.  They read the same objects as the JSON
(``base.report``), so every format says the same thing."""

from __future__ import annotations

import re

from minparam_cli.base.report import format_coefficient
from minparam_cli.output import columns
from minparam_cli.params import latex_name


def _symbolic(b) -> tuple:
    """Each base parameter's symbolic forms ({} where the set is not printed symbolically)."""
    d = b.derivation
    if d is None or d.symbolic is None or d.symbolic.parameters is None:
        return ({},) * b.n_base
    return d.symbolic.parameters


def _fields(b) -> dict:
    d = b.derivation
    return d.symbolic.fields if d is not None and d.symbolic is not None else {}


def _header_lines(b) -> list[tuple[str, str]]:
    a = b.derivation.about
    g = ", ".join(f"{x:g}" for x in a.gravity)
    rows = [
        ("robot", f"{a.robot} ({a.source})"),
        ("method", b.method + (" (exact rational arithmetic)" if b.exact else "")),
        ("dof", f"{a.dof} ({a.convention}" + (", floating base: 6 base coordinates + joints)" if a.floating_base else ")")),
        ("gravity", f"({g}) m/s² [{a.gravity_source}]"),
    ]
    mimic = [(link.joint, link.mimic) for link in a.links if link.mimic is not None]
    if mimic:
        rows.append(("mimic", "; ".join(f"{name} = {_mimic_text(m)}" for name, m in mimic)))
    rows += [
        ("standard", str(b.n_standard)),
        ("base", str(b.n_base)),
    ]
    if b.seed is not None:
        rows.append(("samples", f"{b.samples} random states, seed {b.seed}"))
    m = b.rank_margin or {}
    if m.get("last_kept") is not None:
        fd = m.get("first_dropped")
        rows.append(("rank margin", f"last kept {m['last_kept']:.3g}, first dropped {fd:.3g} (relative)" if fd is not None else f"last kept {m['last_kept']:.3g}"))
    elif m:
        rows.append(("rank margin", m.get("criterion", "")))
    return rows


def _mimic_text(m) -> str:
    """Mimic('j3', -0.5, 0.1) -> '-0.5·j3 + 0.1'."""
    mult = {1: "", -1: "-"}.get(m.multiplier, f"{m.multiplier:g}·")
    off = f" {'+' if m.offset >= 0 else '-'} {abs(m.offset):g}" if m.offset else ""
    return f"{mult}{m.joint}{off}"


def _unidentifiable(b) -> list[str]:
    return [b.standard_names[i] for i in b.unidentifiable]


def table(b) -> str:
    """``minparam derive`` (the terminal table)."""
    head = columns(_header_lines(b))
    rows = [(i + 1, name, s.get("symbolic_text") or expr)
            for i, (name, expr, s) in enumerate(zip(b.names, b.numeric_expressions, _symbolic(b), strict=True))]
    body = columns(rows, ("#", "base parameter", "= standard parameters"), right=(0,))
    out = [head, "", body]
    none = _unidentifiable(b)
    if none:
        out += ["", f"no effect ({len(none)}): " + " ".join(none)]
    names = _joint_rows(b)
    if names:
        out += ["", columns(names, JOINT_HEADERS, right=(0, 4))]
    out += _geometry_notes(b)
    out += _symbolic_footer(b)
    out.append("")
    out.append(f"units: SI (kg, m, kg·m, kg·m²); elapsed {round(b.derivation.elapsed_s, 6):.3f} s")
    return "\n".join(out)


JOINT_HEADERS = ("j", "joint", "link", "type", "parent")


def _joint_rows(b) -> list[tuple]:
    """For a URDF robot: which joint and link the index j of a parameter name (XX3, MXR3) stands for.

    A YAML arm numbers its rows itself; a URDF's order comes from walking its tree, so it is named.
    With a floating base, j = 0 is the free root body."""
    a = b.derivation.about
    if a.convention not in ("urdf", "mjcf"):
        return []
    rows = []
    for link in a.links:
        if link.index is None:
            continue
        if link.index == 0:  # the free root body, carried by the six base coordinates
            rows.append((0, "(floating base)", link.link, "6-DOF", ""))
        else:
            rows.append((link.index, link.joint, link.link, link.type, "" if link.parent is None else link.parent))
    return rows


def _geometry_notes(b) -> list[str]:
    """Weakly identifiable parameters (with the geometry responsible) and the angles --snap-angles changed."""
    out = []
    weak = b.derivation.weak
    if weak:
        out.append(f"weakly identifiable ({len(weak)}, kept with a relative margin below {weak[0]['bound']:g}):")
        for w in weak:
            why = "; ".join(w["geometry"]) if w["geometry"] else "no single near-special joint relation found"
            out.append(f"  {w['parameter']}  margin {w['margin']:.2g}  {why}")
    snap = b.derivation.snap_angles
    if snap is not None:
        changed = snap["changed"]
        out.append(f"--snap-angles {snap['tolerance_rad']:g} rad changed {len(changed)} value{'' if len(changed) == 1 else 's'}:")
        for a in changed:
            out.append(f"  {a['where']}: {a['from']!r} -> {a['to']!r} ({a['degrees']} deg)")
    return ([""] + out) if out else []


def _symbolic_footer(b) -> list[str]:
    fields = _fields(b)
    out = [f"note: {n}" for n in fields.get("symbolic_notes", [])]
    if fields.get("symbols"):
        out.append("symbols (SI): " + ", ".join(f"{k} = {v:g}" for k, v in fields["symbols"].items()))
    return ([""] + out) if out else []


def markdown(b) -> str:
    """``minparam derive --format markdown``."""
    lines = [f"## {b.derivation.about.robot}", ""]
    for k, v in _header_lines(b):
        lines.append(f"- **{k}**: {v}")
    lines += ["", "| # | base parameter | expression |", "|---|---|---|"]
    for i, (name, expr, s) in enumerate(zip(b.names, b.numeric_expressions, _symbolic(b), strict=True)):
        lines.append(f"| {i + 1} | `{name}` | `{s.get('symbolic_text') or expr}` |")
    none = _unidentifiable(b)
    if none:
        lines += ["", "No effect: " + ", ".join(f"`{n}`" for n in none)]
    names = _joint_rows(b)
    if names:
        lines += ["", "| " + " | ".join(JOINT_HEADERS) + " |", "|---|---|---|---|---|"]
        lines += ["| " + " | ".join(f"`{c}`" if i in (1, 2) and c and not str(c).startswith("(") else str(c) for i, c in enumerate(row)) + " |" for row in names]
    notes = [ln for ln in _geometry_notes(b) if ln]
    if notes:
        lines += ["", "```", *notes, "```"]
    lines += [f"- {ln}" for ln in _symbolic_footer(b) if ln]
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


def latex(b) -> str:
    """``minparam derive --format latex``: the base parameters as a LaTeX ``align*`` block."""
    a = b.derivation.about
    g = ", ".join(f"{x:g}" for x in a.gravity)
    lines = [
        f"% {a.robot}: {b.n_base} base parameters of {b.n_standard} ({b.method}), gravity ({g}) m/s^2, SI units",
        r"\begin{align*}",
    ]
    items = list(zip(b.names, b.terms, _symbolic(b), strict=True))
    for i, (name, terms, s) in enumerate(items):
        end = r" \\" if i < len(items) - 1 else ""
        rhs = s.get("symbolic_latex") or latex_terms(terms)
        lines.append(f"  {latex_name(name)} &= {rhs}{end}")
    lines.append(r"\end{align*}")
    return "\n".join(lines) + "\n"
