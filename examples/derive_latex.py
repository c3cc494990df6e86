"""Base parameters of a robot as LaTeX, ready for a paper or a report.

    python examples/derive_latex.py [ROBOT_FILE] [--symbolic]

Prints how many of the standard parameters are identifiable, the regrouping of each base parameter,
and the LaTeX ``align*`` block (numbers, or the geometry symbols a2, d3, ... with --symbolic).
"""

from __future__ import annotations

import sys
from pathlib import Path

import minparam

ROOT = Path(__file__).resolve().parents[1]


def main(argv: list[str]) -> None:
    args = [a for a in argv if not a.startswith("--")]
    robot_file = Path(args[0]) if args else ROOT / "robots" / "puma560_mdh.yaml"
    base = minparam.derive(robot_file, symbolic="--symbolic" in argv)
    print(f"{base.robot}: {base.n_base} base parameters of {base.n_standard} standard ones")
    print(f"{len(base.unidentifiable)} have no effect at all: {' '.join(base.unidentifiable_names) or '-'}")
    print(f"{len(base.dependent)} regroup into others, e.g. {base.names[0]} = {base.expressions[0]}")
    print()
    print(base.latex())


if __name__ == "__main__":
    main(sys.argv[1:])
