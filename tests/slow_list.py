"""The slow tier: which tests `python -m pytest -m "not slow"` leaves out, read from tests/slow_tests.txt.

Why one list file and not `@pytest.mark.slow` on each test: most slow tests are cases of parametrised grids
(a scenario per robot, effect and seed) whose one small case stays fast, and a decorator cannot mark "every
case but one" without rewriting each grid into `pytest.param(..., marks=...)` calls. The list names each slow
test (or, with `*`, a group of cases) next to its fast sibling, the smaller case that keeps the same code in
the fast tier; tests/test_fast_tier.py fails when an entry names no test, when a sibling is missing or slow,
or when a test file has no fast test left, so the list cannot rot silently. tests/conftest.py marks the tests.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import pytest

LIST = Path(__file__).with_name("slow_tests.txt")
ARROW = " => "
# (node id, marked slow) of every test, as tests/conftest.py saw them before `-m`/`-k` deselected any, when the
# session collected the whole suite
COLLECTED = pytest.StashKey[list[tuple[str, bool]]]()


@dataclass(frozen=True)
class Entry:
    pattern: str  # a node id relative to the repository root; `*` matches any text
    sibling: str  # the node id of a fast test on a smaller case of the same code
    line: int

    @cached_property
    def _regex(self) -> re.Pattern[str]:  # compiled once: the list has hundreds of entries, re's cache 512
        return re.compile("\\A" + ".*".join(re.escape(part) for part in self.pattern.split("*")) + "\\Z", flags=re.DOTALL)

    def matches(self, node_id: str) -> bool:
        """This entry marks ``node_id`` slow (its own sibling never)."""
        if "*" not in self.pattern:
            return node_id == self.pattern and node_id != self.sibling
        return node_id != self.sibling and self._regex.match(node_id) is not None


def read(path: Path = LIST) -> list[Entry]:
    """The entries of the list: `PATTERN => SIBLING` a line; blank lines and lines starting with # are skipped."""
    out = []
    for n, raw in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        pattern, arrow, sibling = line.partition(ARROW)
        if not arrow or not pattern.strip() or not sibling.strip():
            raise ValueError(f"{path.name}:{n}: expected 'SLOW TEST{ARROW}FAST SIBLING', got {line!r}")
        out.append(Entry(pattern.strip(), sibling.strip(), n))
    return out


def matcher(entries: list[Entry]) -> Callable[[str], bool]:
    """``is_slow(node_id)``: some entry marks the test slow."""
    return lambda node_id: any(e.matches(node_id) for e in entries)
