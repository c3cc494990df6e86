"""Run the shell sessions pasted in the documentation and compare them with what the page shows.

A page's runs are ```console blocks: a line starting with `$ ` is a command (a line ending in `\\`
continues it; a here-document `<<'EOF'` takes the lines up to its terminator), the lines after it,
up to the next command, are its output (stdout and stderr merged). Each command runs in its own
`bash -c` (files carry over to the next command, shell variables, `cd` and `$?` do not: a page
shows an exit code with `; echo "exit $?"` on the command's own line). One marker, `[…]`, stands for
what differs from run to run (timings, temporary paths, dates) or what the page leaves out:
inside a line it matches any text within that line; a line that is only `[…]` matches any number
of lines (none included).

A console block right after `<!-- not run: REASON -->` is counted, not run (a cluster address,
a file that is not shipped, benchmark output). A block whose commands name `../shared/data` runs
only where that folder exists (the real recordings are not shipped; a clean clone lacks them), as
does a block that names a shipped file pointing there (examples/tx40.recording.yaml), and
is counted as "needs ../shared/data" otherwise (a block that uses files made from them names
../shared/data itself, by making them again).

All blocks of a page run in order in one scratch folder laid out as the pages assume: `../shared`
linking to the repository's `../shared` when it exists, `minparam` on PATH running this checkout's
code, robots/, examples/, benchmarks/ and tests/data/ copied from the repository (what a page may use that it does not create itself),
and an empty docs/img/ takes the figures a page draws.

`python -m tests.docs_run PAGE...` checks pages and prints a diff per differing block;
`python -m tests.docs_run --update PAGE...` re-runs them and writes what the commands print into
the pages, keeping the lines that hold the marker where they still match.
"""

from __future__ import annotations

import argparse
import difflib
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared"
MARK = "[…]"
NOT_RUN = re.compile(r"<!--\s*not run:\s*(.*?)\s*-->\s*\n\s*$")
TOLERANCE = re.compile(r"<!--\s*tolerance:\s*([0-9.eE+-]+)\b[^>]*?-->\s*\n\s*$")  # the comment right before the block
FENCE = re.compile(r"^```console[ \t]*\n(.*?)^```[ \t]*$", re.S | re.M)
HEREDOC = re.compile(r"<<-?\s*['\"]?(\w+)['\"]?")
NEEDS_SHARED = "needs ../shared/data"
SHIPPED = ("robots", "examples", "benchmarks", "tests/data")  # what a page may use, copied into the scratch folder
TIMEOUT_S = 600
# what --update itself writes as the marker: a wall-clock time (`elapsed 0.3 s`, `generated in 0.3 s`,
# `seed 0, 0.3 s`, a solver's `optimal, 0.3 s`, excite's `time 12 s (8 s CPU)`), a temporary path
VARIABLE = [(re.compile(r"(elapsed |generated in |seed \d+, |optimal, )[0-9.]+(?:e[-+]?[0-9]+)?( m?s)\b"), r"\1[…]\2"),
            (re.compile(r"^(time +)[0-9.]+( s \()[0-9.]+( s CPU\))"), r"\1[…]\2[…]\3"),
            (re.compile(r'("(?:elapsed|exact)_s": )[0-9.e-]+'), r"\1[…]"),
            (re.compile(r"/tmp/[^\s'\"]+"), "[…]")]


@dataclass
class Step:
    command: str
    expected: list[str]  # the pasted output lines


@dataclass
class Block:
    page: Path
    number: int  # 1-based among the page's console blocks
    line: int  # 1-based line of the opening fence
    start: int  # offset of the block's body in the page text
    body: str
    skip: str | None
    steps: list[Step] = field(default_factory=list)
    rel_tol: float | None = None  # `<!-- tolerance: REL reason -->` before the block: its numbers to REL relative


def parse_steps(body: str) -> list[Step]:
    lines = body.split("\n")
    if lines and lines[-1] == "":
        lines.pop()
    steps: list[Step] = []
    i = 0
    while i < len(lines):
        if not lines[i].startswith("$ "):
            if steps:
                raise ValueError(f"parse error at {lines[i]!r}")
            raise ValueError(f"a console block must start with a `$ ` command, not {lines[i]!r}")
        cmd = [lines[i][2:]]
        i += 1
        while cmd[-1].endswith("\\") and i < len(lines):
            cmd.append(lines[i])
            i += 1
        heredoc = HEREDOC.search(cmd[0])
        if heredoc:
            end = heredoc.group(1)
            while i < len(lines):
                cmd.append(lines[i])
                i += 1
                if cmd[-1].strip() == end:
                    break
        start = i
        while i < len(lines) and not lines[i].startswith("$ "):
            i += 1
        steps.append(Step("\n".join(cmd), lines[start:i]))
    return steps


def page_blocks(page: Path) -> list[Block]:
    text = page.read_text(encoding="utf-8")
    out = []
    for k, m in enumerate(FENCE.finditer(text)):
        before = NOT_RUN.search(text[: m.start()])
        tol = TOLERANCE.search(text[: m.start()])
        block = Block(page, k + 1, text.count("\n", 0, m.start()) + 1, m.start(1), m.group(1),
                      before.group(1) if before else None, rel_tol=float(tol.group(1)) if tol else None)
        try:
            block.steps = parse_steps(m.group(1))
        except ValueError as exc:
            if block.skip is None:  # a pasted output that is not run need not show its command
                raise ValueError(f"{page.name} line {block.line}: {exc}") from None
        out.append(block)
    return out


def _line_regex(line: str) -> str:
    return ".*".join(re.escape(part) for part in line.split(MARK))


# a decimal number written with a point or an exponent (integers are compared as text), not part of
# a word or of a dotted version or address
FLOAT = r"(?<![\w.])[-+]?(?:\d+\.\d*|\.\d+|\d+(?=[eE]))(?:[eE][-+]?\d+)?(?![\w.])"
ABS_TOL = 1e-12  # below this a value is rounding (a residual, the smallest singular value of a singular matrix)
REL_TOL = 1e-9


def _tolerant_regex(line: str, floats: list[str]) -> str:
    """The line's regex with each decimal number a group (its text appended to ``floats``)."""
    out = []
    for part in line.split(MARK):
        pos, pieces = 0, []
        for m in re.finditer(FLOAT, part):
            pieces += [_text_regex(part[pos:m.start()]), f"({FLOAT})"]
            floats.append(m.group())
            pos = m.end()
        out.append("".join(pieces) + _text_regex(part[pos:]))
    return ".*".join(out)


def _text_regex(text: str) -> str:
    """``text`` literally, but a run of spaces as any run of spaces: a table's columns move when a
    number in them is printed one character wider (a minus sign, one more digit)."""
    return "[ \t]+".join(re.escape(piece) for piece in re.split(r"[ \t]+", text))


def close(page: str, run: str, rel_tol: float = REL_TOL) -> bool:
    """Whether a number printed by a run is the page's to within one unit of its last printed digit,
    ``rel_tol`` relative or ABS_TOL: BLAS and LAPACK round differently on different processors, so the
    last digits of a 17-digit float or a rounding-level residual are not the page's to keep (a block
    whose numbers come from an iterative solver's tolerance says so: ``TOLERANCE``)."""
    if page == run:
        return True
    x, y = float(page), float(run)
    mantissa, _, exponent = page.lower().partition("e")
    decimals = len(mantissa.split(".")[1]) if "." in mantissa else 0
    unit = 10.0 ** (int(exponent or 0) - decimals)
    digits = len(mantissa.replace("-", "").replace("+", "").replace(".", "").lstrip("0"))
    slack = unit if digits >= 2 else unit / 2  # a one-digit figure (0.1) may not move by a whole unit
    return abs(x - y) <= max(slack * (1 + 1e-9), rel_tol * max(abs(x), abs(y)), ABS_TOL)


def matches(expected: list[str], actual: list[str], rel_tol: float = REL_TOL) -> bool:
    """Whether the actual output lines fit the pasted ones, `[…]` read as described above, and each
    decimal number (``FLOAT``) ``close`` to the page's."""
    text = "".join(a + "\n" for a in actual)
    parts, floats = [], []
    for line in expected:
        if line.strip() == MARK:
            parts.append(r"(?:[^\n]*\n)*?")
        else:
            parts.append(_tolerant_regex(line.rstrip(), floats) + r"\n")
    m = re.fullmatch("".join(parts), text)
    return m is not None and all(close(e, a, rel_tol) for e, a in zip(floats, m.groups(), strict=True))


def merged(expected: list[str], actual: list[str], rel_tol: float = REL_TOL) -> list[str]:
    """The lines --update writes: the actual output, with the page's marker lines kept where they fit
    and times and temporary paths marked."""
    if matches(expected, actual, rel_tol):
        return expected
    actual = [_mark_variable(a) for a in actual]
    segments: list[list[str]] = [[]]
    for line in expected:
        if line.strip() == MARK:
            segments.append([])
        else:
            segments[-1].append(line)
    if len(segments) == 1:  # no line marker: line by line, a marked line kept where it still fits
        padded = expected + [""] * max(0, len(actual) - len(expected))
        return [e if MARK in e and re.fullmatch(_line_regex(e), a) else a
                for e, a in zip(padded[:len(actual)], actual, strict=True)]
    out: list[str] = []
    pos = 0
    for k, seg in enumerate(segments):
        if k == 0:  # the first segment is the start of the output
            take = actual[:len(seg)]
        elif not seg:  # a marker at the end (or two in a row) stands for the rest
            out.append(MARK)
            continue
        else:  # a later one: where it best fits after pos; the last one runs to the end of the output
            best = max(range(pos, max(pos + 1, len(actual) - len(seg) + 1)), default=pos,
                       key=lambda j: difflib.SequenceMatcher(None, seg, actual[j:j + len(seg)]).ratio())
            take = actual[best:] if k == len(segments) - 1 else actual[best:best + len(seg)]
            out.append(MARK)
            pos = best
        out.extend(merged(seg, take, rel_tol) if seg and len(take) == len(seg) else take)
        pos += len(take)
    return out


def _uses_shared_data(command: str) -> bool:
    """Whether a command names ../shared/data, or a shipped file that does (a recording description)."""
    if "../shared/data" in command:
        return True
    for word in re.findall(r"[\w./-]+\.ya?ml", command):
        path = ROOT / word
        if path.is_file() and path.stat().st_size < 100_000 and re.search(
                r"path:\s*\S*shared/data", path.read_text(encoding="utf-8")):
            return True
    return False


def _mark_variable(line: str) -> str:
    for pattern, replacement in VARIABLE:
        line = pattern.sub(replacement, line)
    return line


def scratch() -> Path:
    """A scratch folder laid out as the pages assume; returns the folder the commands run in."""
    top = Path(tempfile.mkdtemp(prefix="minparam-docs-"))
    work = top / "minparam"
    work.mkdir()
    for name in SHIPPED:
        shutil.copytree(ROOT / name, work / name, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    (work / "docs" / "img").mkdir(parents=True)  # pages that draw a figure write it here
    if SHARED.is_dir():
        (top / "shared").symlink_to(SHARED)
    bin_dir = top / "bin"
    bin_dir.mkdir()
    launcher = bin_dir / "minparam"
    # as pip's entry point would: the program name in messages is `minparam`
    launcher.write_text(f"#!{sys.executable}\nimport sys\nfrom minparam_cli.cli.app import entry\nsys.exit(entry())\n")
    launcher.chmod(0o755)
    return work


def environment(work: Path) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PYTEST", "COLUMNS", "LINES"))}
    env["PATH"] = f"{work.parent / 'bin'}{os.pathsep}{env.get('PATH', '')}"
    # the minparam this process imports (an editable checkout's src/, or the site-packages CI installed into,
    # with its compiled kernel: src/ of a clean clone has none, and the numpy regressor rounds differently)
    import minparam_cli

    where = str(Path(minparam_cli.__file__).resolve().parents[1])
    env["PYTHONPATH"] = where + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    env.update(NO_COLOR="1", TERM="dumb", LC_ALL="C.UTF-8", PYTHONHASHSEED="0", TZ="UTC")
    return env


def run_step(step: Step, work: Path, env: dict[str, str]) -> list[str]:
    proc = subprocess.run(["bash", "-c", step.command], cwd=work, env=env, stdout=subprocess.PIPE,
                          stderr=subprocess.STDOUT, timeout=TIMEOUT_S, check=False)
    text = proc.stdout.decode("utf-8", "replace")
    lines = text.split("\n")
    if lines and lines[-1] == "":
        lines.pop()
    return [line.rstrip() for line in lines]


@dataclass
class Report:
    ran: int = 0
    matched: int = 0
    not_run: dict[str, int] = field(default_factory=dict)
    failures: list[str] = field(default_factory=list)
    seconds: float = 0.0


def run_page(page: Path, update: bool = False) -> Report:
    """Run a page's console blocks in order; with update, write the actual outputs into the page."""
    t0 = time.perf_counter()
    report = Report()
    blocks = page_blocks(page)
    if not blocks:
        return report
    work = scratch()
    env = environment(work)
    edits: list[tuple[int, int, str]] = []
    try:
        for block in blocks:
            reason = block.skip
            if reason is None and not SHARED.joinpath("data").is_dir() and any(
                    _uses_shared_data(s.command) for s in block.steps):
                reason = NEEDS_SHARED
            if reason is not None:
                report.not_run[reason] = report.not_run.get(reason, 0) + 1
                continue
            report.ran += 1
            ok = True
            diffs = []
            body: list[str] = []
            for step in block.steps:
                actual = run_step(step, work, env)
                tol = REL_TOL if block.rel_tol is None else block.rel_tol
                if not matches(step.expected, actual, tol):
                    ok = False
                    diffs.append(f"$ {step.command}\n" + "\n".join(difflib.unified_diff(
                        step.expected, actual, "page", "run", lineterm="", n=2)))
                body.extend([f"$ {step.command}", *merged(step.expected, actual, tol)])
            if ok:
                report.matched += 1
            else:
                rel = page.relative_to(ROOT) if page.is_relative_to(ROOT) else page
                report.failures.append(f"{rel} block {block.number} (line {block.line}):\n" + "\n\n".join(diffs))
                edits.append((block.start, block.start + len(block.body), "\n".join(body) + "\n"))
    finally:
        shutil.rmtree(work.parent, ignore_errors=True)
    if update and edits:
        text = page.read_text(encoding="utf-8")
        for start, end, body in sorted(edits, reverse=True):
            text = text[:start] + body + text[end:]
        page.write_text(text, encoding="utf-8")
    report.seconds = time.perf_counter() - t0
    return report


def pages() -> list[Path]:
    return [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tests.docs_run", description=__doc__.split("\n\n")[0])
    parser.add_argument("pages", nargs="*", type=Path, help="pages to run (default: README.md and docs/**/*.md)")
    parser.add_argument("--update", action="store_true", help="write the actual outputs into the pages")
    args = parser.parse_args(argv)
    total = Report()
    for page in [p.resolve() for p in args.pages] or pages():
        r = run_page(page, update=args.update)
        total.ran += r.ran
        total.matched += r.matched
        total.seconds += r.seconds
        for k, v in r.not_run.items():
            total.not_run[k] = total.not_run.get(k, 0) + v
        for f in r.failures:
            print(f, end="\n\n")
        rel = page.relative_to(ROOT) if page.is_relative_to(ROOT) else page
        print(f"{rel}: {r.ran} run, {r.matched} matched, {sum(r.not_run.values())} not run, {r.seconds:.1f} s"
              + (" (updated)" if args.update and r.failures else ""), flush=True)
    print(f"total: {total.ran} blocks run, {total.matched} matched, not run: {total.not_run or 'none'}, "
          f"{total.seconds:.1f} s")
    return 0 if total.ran == total.matched or args.update else 1


if __name__ == "__main__":
    sys.exit(main())
