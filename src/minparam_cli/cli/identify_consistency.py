"""`identify A B C --consistency`: the CLI side (parse checks, call the stage, render, write)."""

from __future__ import annotations

import json
from pathlib import Path

from minparam_cli.cli.common import save_png
from minparam_cli.output import Progress, write_output
from minparam_cli.errors import InputError


def run_consistency(chain, data: list[Path], opts, consistency: bool, fmt: str, output, plot, quiet: bool, excluded: dict) -> None:
    from minparam_cli.identify.consistency import consistency as run

    if not consistency:
        raise InputError(f"{len(data)} data files given: compare several recordings with --consistency, "
                         "or give selection and test data with --validate and --test")
    for flag, value in excluded.items():
        if value:
            raise InputError(f"--consistency does not combine with {flag}: every recording is split into fit, "
                             "selection and test data by --split and fitted with the declared model")
    bar = Progress(len(data), "recordings", quiet)
    try:
        report, _ = run(chain, list(data), opts, progress=bar)
    finally:
        bar.close()
    if plot is not None:
        from minparam_cli.render.consistency_plot import consistency_plot

        save_png(consistency_plot(report, f"{chain.name}: {len(data)} recordings (σ: {report['sigma']})"),
                 Path(plot) / "consistency.png")
    if fmt == "json":
        text = json.dumps(report, indent=2, ensure_ascii=False)
    else:
        from minparam_cli.render.consistency_text import render_consistency

        text = render_consistency(report)
    write_output(text, output)
