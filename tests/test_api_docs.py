"""docs/api.md and the README's Python example cannot go stale: every ```python block runs (in order,
as one script, from the repository root), and a ```text block right after one is its exact output."""

from __future__ import annotations

import contextlib
import io
import re
import warnings

import pytest
from conftest import ROOT

FENCE = re.compile(r"```(\w*)\n(.*?)```", re.S)


def blocks(path) -> list[tuple[str, str | None]]:
    """(python code, the text block right after it or None) for each python block of a Markdown file."""
    found = [(m.group(1), m.group(2), m.start(), m.end()) for m in FENCE.finditer(path.read_text(encoding="utf-8"))]
    text = path.read_text(encoding="utf-8")
    out = []
    for k, (lang, body, _, end) in enumerate(found):
        if lang != "python":
            continue
        expected = None
        if k + 1 < len(found) and found[k + 1][0] == "text" and not text[end:found[k + 1][2]].strip():
            expected = found[k + 1][1]
        out.append((body, expected))
    return out


def run_blocks(path) -> None:
    namespace: dict = {"__name__": "__docs__"}
    for i, (code, expected) in enumerate(blocks(path)):
        buf = io.StringIO()
        with contextlib.redirect_stdout(buf), warnings.catch_warnings():
            warnings.simplefilter("ignore")  # a block that wants warnings records them itself
            exec(compile(code, f"{path.name} block {i + 1}", "exec"), namespace)
        if expected is not None:
            assert buf.getvalue() == expected, f"{path.name} block {i + 1}:\n{buf.getvalue()}"


def test_api_md_examples_run_and_print_what_the_page_shows():
    path = ROOT / "docs" / "api.md"
    assert len(blocks(path)) >= 12  # one per function at least
    run_blocks(path)


def test_readme_python_example_runs():
    path = ROOT / "README.md"
    assert blocks(path), "the README has a Python example"
    run_blocks(path)


def test_a_stale_output_is_caught(tmp_path):
    page = tmp_path / "page.md"
    page.write_text("```python\nprint(1 + 1)\n```\n\n```text\n3\n```\n")
    with pytest.raises(AssertionError, match="page.md block 1"):
        run_blocks(page)


def test_package_docstring_example():
    import doctest

    import minparam

    failed, tried = doctest.testmod(minparam, verbose=False)
    assert tried >= 2 and failed == 0
