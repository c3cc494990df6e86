"""`identify A B C --consistency`: the CLI side (call the API, render, write)."""

from __future__ import annotations

import json
from pathlib import Path

from minparam_cli.cli.common import save_png
from minparam_cli.output import Progress, write_output


def run_consistency(opts, data: list[Path], consistency: bool, fmt: str, output, plot, quiet: bool) -> None:
    from minparam_cli.api.identification import run_consistency as run

    bar = Progress(len(data), "recordings", quiet)
    try:
        result = run(opts, list(data), progress=bar, requested=consistency)
    finally:
        bar.close()
    if plot is not None:
        from minparam_cli.render.consistency_plot import consistency_plot

        save_png(consistency_plot(result, f"{result.robot}: {len(data)} recordings (σ: {result.sigma})"),
                 Path(plot) / "consistency.png")
    if fmt == "json":
        text = json.dumps(result.to_dict(), indent=2, ensure_ascii=False)
    else:
        from minparam_cli.render.consistency_text import render_consistency

        text = render_consistency(result)
    write_output(text, output)
