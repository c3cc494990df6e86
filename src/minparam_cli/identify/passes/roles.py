"""The three roles of the data in an identification: fit, selection and test.

* **fit**: the parameters are estimated on it (least squares);
* **selection**: scores the candidate effects of the diagnosis (ΔBIC), so it
  chooses the model's structure; the "before" and "after" of the report are
  measured on it;
* **test**: touched by nothing but the final report: neither the fit, nor the
  choice of effects, nor any tuned setting.  Its errors are the honest
  figures of how the model does on data it has never seen.

Where the roles come from.  ``--validate FILE`` gives the selection data and
``--test FILE`` (repeatable) the test data; what is not given comes from the
data file itself, split in time into contiguous blocks in the order
fit → selection → test with the shares of ``--split`` (default 0.6, 0.2,
0.2; the shares of the roles given as files are dropped and the rest scaled
to one).  A test share of 0 with no ``--test`` file is allowed: the report
then has no test figures and says so.

Why contiguous blocks and not a blocked k-fold in time: the samples of a
filtered recording are correlated over a few cut-off periods, so every
boundary between two roles leaks a little; three blocks have two
boundaries, k-fold has 2k.  A k-fold would also fit and select k times over
and still need a test block that no fold touched.  Putting the test block
last asks the model what a user asks of it, to predict motion it has not seen
yet.  The price: a short recording gives short blocks (the Panda's 21 s
gives a 4.2 s test block), so each figure names its source and time span.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from minparam_cli.errors import DataError

FIT, SELECTION, TEST = "fit", "selection", "test"
DEFAULT_SPLIT = (0.6, 0.2, 0.2)


@dataclass(frozen=True)
class Piece:
    """A time interval [start, stop) of one file, in one role; ``part`` keys its accumulators."""

    role: str
    part: str  # "fit", "selection", "test1", "test2", ...
    start: float  # s; -inf: from the first sample
    stop: float  # s; inf: to the last sample


@dataclass(frozen=True)
class Source:
    path: Path
    pieces: tuple[Piece, ...]

    def cuts(self) -> list[float]:
        """Times at which the role changes inside the file (increasing)."""
        return [p.start for p in self.pieces[1:]]


def test_part(k: int) -> str:
    return f"{TEST}{k + 1}"


def plan(data: Path, validate: Path | None, tests: tuple[Path, ...], split: tuple[float, float, float],
         span: tuple[float, float] | None) -> list[Source]:
    """Which file (and which time span of it) plays which role.

    ``span``: the first and last time stamp of ``data`` (needed only when it is split)."""
    if len(split) != 3 or any(not (0 <= s <= 1) for s in split) or split[0] <= 0:
        raise DataError(f"--split needs three shares FIT,SELECTION,TEST in [0, 1] with FIT > 0, got {split}")
    shares = {FIT: split[0], SELECTION: 0.0 if validate else split[1], TEST: 0.0 if tests else split[2]}
    if shares[SELECTION] == 0 and not validate:
        raise DataError("--split gives no selection data: give it a share > 0 or a file (--validate)")
    total = sum(shares.values())
    roles = [r for r in (FIT, SELECTION, TEST) if shares[r] > 0]
    pieces = []
    if len(roles) == 1:
        pieces.append(Piece(FIT, FIT, -float("inf"), float("inf")))
    else:
        if span is None:
            raise DataError(f"{data}: the time span is needed to split the data")
        t0, t1 = span
        if not t1 > t0:
            raise DataError(f"{data}: the last time stamp ({t1}) is not after the first ({t0})")
        acc, start = 0.0, -float("inf")
        for k, r in enumerate(roles):
            acc += shares[r] / total
            stop = float("inf") if k == len(roles) - 1 else t0 + acc * (t1 - t0)
            pieces.append(Piece(r, test_part(0) if r == TEST else r, start, stop))
            start = stop
    _distinct(data, validate, tests)
    out = [Source(Path(data), tuple(pieces))]
    if validate:
        out.append(Source(Path(validate), (Piece(SELECTION, SELECTION, -float("inf"), float("inf")),)))
    for k, path in enumerate(tests):
        out.append(Source(Path(path), (Piece(TEST, test_part(k), -float("inf"), float("inf")),)))
    return out


def _same(a: Path, b: Path) -> bool:
    try:
        return Path(a).resolve() == Path(b).resolve() or Path(a).samefile(b)
    except OSError:
        return False


def _distinct(data: Path, validate: Path | None, tests: tuple[Path, ...]) -> None:
    """Test data must be data that chose nothing: no test file may also be the data or the selection file.
    (The selection file may be the data file: the report then flags its figures as in-sample.)"""
    for k, t in enumerate(tests):
        for other, what in ((data, "the data file"), (validate, "the --validate file")):
            if other is not None and _same(t, other):
                raise DataError(f"--test {t} is also {what}: test data must be data that neither fitted nor chose the model")
        for u in tests[:k]:
            if _same(t, u):
                raise DataError(f"--test {t} is given twice")


def overlaps(data: Path, validate: Path | None) -> bool:
    """Whether the selection file is the data file (allowed, but its figures are then in-sample)."""
    return validate is not None and _same(Path(data), Path(validate))


def parts(sources: list[Source]) -> list[str]:
    """Every accumulator key, fit first, then selection, then the test parts in order."""
    keys = [p.part for s in sources for p in s.pieces]
    order = {FIT: 0, SELECTION: 1}
    return sorted(dict.fromkeys(keys), key=lambda k: (order.get(k, 2), len(k), k))


def describe(sources: list[Source]) -> dict:
    """For the report: where each role's data came from (file and time span)."""
    out: dict = {FIT: [], SELECTION: [], TEST: []}
    for s in sources:
        for p in s.pieces:
            span = None
            if p.start != -float("inf") or p.stop != float("inf"):
                span = [None if p.start == -float("inf") else round(p.start, 6), None if p.stop == float("inf") else round(p.stop, 6)]
            out[p.role].append({"part": p.part, "source": str(s.path), "time_s": span})
    return out


def span_text(entry: Mapping[str, Any]) -> str:
    """'data.csv, 12 ≤ t < 16.8 s' for an entry of ``describe`` (the file alone when it is whole)."""
    span = entry.get("time_s")
    if not span:
        return entry["source"]
    lo, hi = span
    if hi is None:
        return f"{entry['source']}, t ≥ {lo:.4g} s"
    if lo is None:
        return f"{entry['source']}, t < {hi:.4g} s"
    return f"{entry['source']}, {lo:.4g} ≤ t < {hi:.4g} s"
