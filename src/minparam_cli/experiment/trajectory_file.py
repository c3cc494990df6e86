"""A given excitation for ``simulate --trajectory FILE``: ``excite``'s JSON (coefficients) or CSV (samples).

Text in, trajectory out (the CLI reads the file, bounded in size).  The JSON
gives Swevers' series (``experiment.trajectory.FourierTrajectory``), which
``simulate`` evaluates at its own --duration and --rate; the CSV gives the
samples t, q1..qn, dq1..dqn, ddq1..ddqn themselves (further columns, such as
tau, are ignored), used as they are.
"""

from __future__ import annotations

import io
import json
import math
from dataclasses import dataclass

import numpy as np

from minparam_cli.errors import DataError
from minparam_cli.experiment.trajectory import FourierTrajectory

MAX_BYTES = 256 * 2**20


@dataclass(frozen=True, eq=False)
class SampledMotion:
    """Joint motion given sample by sample (SI): t (N,), q, dq, ddq (N, n)."""

    t: np.ndarray
    q: np.ndarray
    dq: np.ndarray
    ddq: np.ndarray
    source: str = ""


def parse_trajectory_json(text: str, n: int, source: str) -> FourierTrajectory:
    """The ``trajectory`` object of an ``excite`` (or ``simulate --truth``) JSON record."""
    try:
        record = json.loads(text)
        traj = record["trajectory"]
        f = float(traj["base_frequency"])
        q0 = np.asarray(traj["q0"], dtype=float)
        a = np.asarray(traj["a"], dtype=float)
        b = np.asarray(traj["b"], dtype=float)
    except (ValueError, TypeError, KeyError) as e:
        what = f"missing {e}" if isinstance(e, KeyError) else str(e).splitlines()[0]
        raise DataError(f"{source}: not a trajectory record ({what}); expected excite's --json output") from None
    if q0.shape != (n,) or a.ndim != 2 or a.shape[0] != n or b.shape != a.shape or a.shape[1] < 1:
        raise DataError(f"{source}: trajectory.q0, a, b must have shapes ({n},), ({n}, H), ({n}, H) for this robot, "
                        f"got {q0.shape}, {a.shape}, {b.shape}")
    if not (math.isfinite(f) and f > 0) or not all(np.isfinite(x).all() for x in (q0, a, b)):
        raise DataError(f"{source}: trajectory coefficients must be finite and base_frequency positive")
    return FourierTrajectory(f, q0, a, b)


def parse_trajectory_csv(text: str, n: int, source: str) -> SampledMotion:
    """t, q1..qn, dq1..dqn, ddq1..ddqn by name from a CSV with a header row."""
    text = text.removeprefix("\ufeff")  # a byte-order mark is not part of the first name
    lines = text.splitlines()
    if not lines:
        raise DataError(f"{source}: empty file; expected a header t,q1..,dq1..,ddq1..")
    header = [h.strip() for h in lines[0].split(",")]
    want = ["t"] + [f"{g}{j}" for g in ("q", "dq", "ddq") for j in range(1, n + 1)]
    missing = [w for w in want if w not in header]
    if missing:
        raise DataError(f"{source}: missing column(s) {', '.join(missing[:4])}{'…' if len(missing) > 4 else ''} "
                        f"for a robot with {n} joints")
    rows = sum(1 for line in lines[1:] if line.strip() and not line.lstrip().startswith("#"))
    if rows < 2:  # before loadtxt, which would warn on stderr about a file without data
        raise DataError(f"{source}: expected at least 2 rows of {len(header)} numbers")
    try:
        table = np.loadtxt(io.StringIO(text), delimiter=",", skiprows=1, ndmin=2)
    except ValueError as e:
        raise DataError(f"{source}: {str(e).splitlines()[0]}") from None
    if table.shape[0] < 2 or table.shape[1] != len(header):
        raise DataError(f"{source}: expected at least 2 rows of {len(header)} numbers")
    if not np.isfinite(table).all():
        raise DataError(f"{source}: every value must be finite")
    col = {h: i for i, h in enumerate(header)}
    t = table[:, col["t"]]
    if np.any(np.diff(t) <= 0):
        raise DataError(f"{source}: t must increase from row to row")
    def pick(g):
        return table[:, [col[f"{g}{j}"] for j in range(1, n + 1)]]
    return SampledMotion(t, pick("q"), pick("dq"), pick("ddq"), source)
