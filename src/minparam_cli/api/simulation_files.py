"""``minparam simulate``'s data files: CSV (or stdout) and .npz, streamed chunk by chunk and written
atomically (a failed run leaves no file)."""

from __future__ import annotations

from pathlib import Path

from minparam_cli.errors import InputError
from minparam_cli.output import atomic_write, is_stdout


def data_format(output: Path | None) -> str:
    """"csv" or "npz" from the output's name (stdout: CSV); other suffixes are refused."""
    if output is None or is_stdout(output):
        return "csv"
    suffix = Path(output).suffix.lower()
    if suffix not in (".csv", ".npz"):
        raise InputError(f"{output}: unknown output type {suffix or '(none)'!r}; expected .csv or .npz")
    return suffix[1:]


def write_npz(stream, include_ddq: bool, output: Path) -> None:
    """The stream as an .npz archive (t, q, dq, [ddq,] tau), through ``atomic_write``: a failed run
    leaves no file; memory stays at one chunk (``measured.writing.NpzWriter``)."""
    from minparam_cli.measured.writing import NpzWriter

    n, samples = stream.plan.chain.dof, stream.plan.samples
    names = ("q", "dq", "ddq", "tau") if include_ddq else ("q", "dq", "tau")

    def write(tmp: str) -> None:
        writer = NpzWriter({"t": (samples,), **{name: (samples, n) for name in names}})
        try:
            for chunk in stream:
                writer.write("t", chunk.t)
                for name in names:
                    writer.write(name, getattr(chunk, name))
        except BaseException:
            writer.discard()
            raise
        writer.save(tmp)

    atomic_write(Path(output), write)


def write_csv(stream, include_ddq: bool, output: Path) -> None:
    """The stream as CSV (header t, q1..qn, dq1..dqn, [ddq1..ddqn,] tau1..taun), chunk by chunk,
    through ``atomic_write`` (``-``: stdout)."""
    import numpy as np

    from minparam_cli.experiment.simulate_spec import data_columns
    from minparam_cli.measured.writing import CsvWriter

    n = stream.plan.chain.dof

    def write(tmp: str) -> None:
        with open(tmp, "wb") as fh, CsvWriter(fh, data_columns(n, include_ddq)) as writer:
            for c in stream:
                writer.write(np.hstack([c.t[:, None], c.q, c.dq] + ([c.ddq] if include_ddq else []) + [c.tau]))

    atomic_write(Path(output), write)
