"""The command-line runs pasted in README.md and docs/**/*.md cannot go stale: every ```console block
runs (tests/docs_run.py says how: `$ ` lines are commands, the rest their output, `[…]` the one marker
for variable text) and its output must be what the page shows. One test per page."""

from __future__ import annotations

import re

import docs_run
import pytest
from conftest import ROOT

PAGES = [p for p in docs_run.pages() if docs_run.page_blocks(p)]


@pytest.mark.parametrize("page", PAGES, ids=[str(p.relative_to(ROOT)) for p in PAGES])
def test_page_runs_as_pasted(page):
    report = docs_run.run_page(page)
    skipped = ", ".join(f"{n} {why}" for why, n in sorted(report.not_run.items()))
    print(f"{page.relative_to(ROOT)}: {report.ran} run, {report.matched} matched, not run: {skipped or 'none'}")
    assert not report.failures, "\n\n".join(report.failures) + "\n(re-run: python -m tests.docs_run --update PAGE)"
    if not report.ran:
        pytest.skip(f"no block run: {skipped}")


def test_no_pasted_run_escapes_the_harness():
    """A fenced block of another language that starts with a `$ ` command would not be run: refused."""
    fence = re.compile(r"^```(\w*)[ \t]*\n(.*?)^```", re.S | re.M)
    stray = [f"{p.relative_to(ROOT)}: ```{m.group(1)} at line {p.read_text().count(chr(10), 0, m.start()) + 1}"
             for p in docs_run.pages() for m in fence.finditer(p.read_text(encoding="utf-8"))
             if m.group(1) != "console" and m.group(2).startswith("$ ")]
    assert not stray, stray


def test_a_stale_output_is_caught(tmp_path):
    page = tmp_path / "page.md"
    page.write_text("```console\n$ echo 2\n3\n```\n")
    report = docs_run.run_page(page)
    assert report.ran == 1 and report.matched == 0 and "-3" in report.failures[0] and "+2" in report.failures[0]


def test_marker_matches_within_a_line_and_across_lines(tmp_path):
    page = tmp_path / "page.md"
    page.write_text("```console\n$ printf 'a 1.23 s\\nb\\nc\\nd\\n'\na […] s\n[…]\nd\n```\n"
                    "<!-- not run: a cluster address -->\n```console\n$ false\nnever\n```\n")
    report = docs_run.run_page(page)
    assert (report.ran, report.matched, report.not_run) == (1, 1, {"a cluster address": 1})
    assert not docs_run.matches(["a […] s", "d"], ["a 1 s", "b", "d"])  # an inline marker stays on its line


@pytest.mark.parametrize("page,run,same", [
    ("first dropped 7.34e-16 (relative)", "first dropped 5.71e-16 (relative)", True),  # rounding-level
    ("phi 0.18000002772167104,", "phi 0.1800000277216757,", True),  # a 17-digit float, 2.6e-14 apart
    ("a 0.123457 b", "a 0.123456 b", True),  # one unit of the last printed digit (a rounding flip)
    ("last kept 0.0273", "last kept 0.0275", False),  # two units
    ("theta 3.2191708031693556", "theta 3.21917", False),  # 2.5e-7 relative is not rounding
    ("5 of 6", "4 of 6", False),  # integers are text
    ("v 0.1.0", "v 0.1.1", False),  # so are versions
    ("MX1 2.0", "MX2 2.0", False),
    ("  1    6.865  2.84e-18   8.67e-07 x", "  1    6.865  -3.14e-18  8.67e-07 x", True),  # a column one wider
    ("ab 1.5", "a b 1.5", False),  # spaces only where the page has some
    ("mass 0.5", "mass 0.6", False),  # a one-digit figure may not move by a unit
    ("res 7e-16", "res 9e-13", True),  # below 1e-12 every value is rounding (ABS_TOL)
])
def test_numbers_are_compared_to_rounding_and_text_exactly(page, run, same):
    assert docs_run.matches([page], [run]) is same


def test_a_block_may_declare_a_solver_tolerance(tmp_path):
    page = tmp_path / "page.md"
    body = "```console\n$ echo 'mass 1.00012'\nmass 1.00009\n```\n"
    page.write_text(body + "<!-- tolerance: 1e-3 (an iterative solver's result) -->\n" + body
                    + "<!-- not run: a note -->\n```console\n$ true\n```\n" + body)
    report = docs_run.run_page(page)
    # the declaration holds for its own block only, not for a later one behind another comment
    assert (report.ran, report.matched) == (3, 1) and "block 1 " in report.failures[0] and "block 4 " in report.failures[1]


def test_blocks_share_a_scratch_folder_laid_out_as_the_pages_assume(tmp_path):
    page = tmp_path / "page.md"
    page.write_text("```console\n$ cat > x.txt <<'EOF'\nhello\nEOF\n$ ls robots/puma560.yaml examples/*.py | head -1\n"
                    "examples/computed_torque.py\n```\n\n```console\n$ cat x.txt\nhello\n```\n")
    report = docs_run.run_page(page)
    assert (report.ran, report.matched) == (2, 2), report.failures


def test_update_rewrites_outputs_and_keeps_markers(tmp_path):
    page = tmp_path / "page.md"
    page.write_text("text\n```console\n$ printf 'x 1\\nelapsed 0.5 s\\nr1\\nr2\\nr3\\n'\nx 0\nelapsed […] s\nr1\n[…]\n```\nend\n")
    docs_run.run_page(page, update=True)
    assert page.read_text() == "text\n```console\n$ printf 'x 1\\nelapsed 0.5 s\\nr1\\nr2\\nr3\\n'\nx 1\nelapsed […] s\nr1\n[…]\n```\nend\n"
    assert docs_run.run_page(page).matched == 1
