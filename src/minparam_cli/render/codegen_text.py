"""``minparam codegen``'s summary on stderr: where the code went, the operation counts and the time."""

from __future__ import annotations

from pathlib import Path

from minparam_cli.output import is_stdout


def summary_text(gen, lang: str, output: Path | None, elapsed: float) -> str:
    """Operation counts and time (what the papers compare: multiplications, additions)."""
    where = "stdout" if output is None or is_stdout(output) else (
        f"{output.with_suffix('.c')} + {output.with_suffix('.h')}" if lang == "c" else str(output))
    lines = [f"codegen: {where}, {len(gen.base_names)} base parameters, generated in {elapsed:.2f} s"]
    for fn, c in gen.counts.items():
        calls = ", ".join(f"{v} {k}" for k, v in c.items() if k not in ("mul", "add", "neg") and v)
        lines.append(f"  {fn}: {c['mul']} multiplications, {c['add']} additions" + (f", {calls}" if calls else ""))
    return "\n".join(lines) + "\n"
