"""Which columns of a table with a header (CSV) hold t and each joint's q, dq, ddq, tau.

``--columns KEY=SPEC,...`` (KEY one of t, q, dq, ddq, tau) where SPEC is

* for t: the exact column name (``t=time``);
* a prefix followed by the joint number (``q=pos``: pos1..posn, or pos0..pos(n-1));
* a pattern with ``{}`` where the joint number stands (``q=position_{}``, ``tau={}_effort``),
  numbered from 1 or from 0 as the file has it;
* an explicit list, one column per joint in the robot's joint order, joined by ``|``
  (``q=pos_a|pos_b|pos_c``).

The specs are kept as the text the user gave (that is what a saved model stores) and read here.
"""

from __future__ import annotations

import re

from minparam_cli.errors import DataError

KEYS = ("t", "q", "dq", "ddq", "tau")
NUMBER = "{}"  # where the joint number stands in a pattern
LIST_SEP = "|"  # separates the columns of an explicit list
# --time-unit: what a time stamp of 1 means, as the divisor that turns it into seconds
TIME_UNITS = {"s": 1.0, "ms": 1e3, "us": 1e6, "ns": 1e9}


def spec_problem(key: str, spec: str) -> str | None:
    """Why ``spec`` cannot name the columns of ``key``, in words, or None."""
    if key not in KEYS:
        return f"keys are {', '.join(KEYS)}; got {key!r}"
    if not spec:
        return f"{key}= needs a column name"
    if key == "t":
        if LIST_SEP in spec or NUMBER in spec:
            return f"t is one column: give its name (t=NAME), got {spec!r}"
        return None
    if LIST_SEP in spec:
        items = spec.split(LIST_SEP)
        if any(not x.strip() for x in items):
            return f"{key}={spec}: an empty name in the list (columns joined by '{LIST_SEP}', one per joint)"
        if len({x.strip() for x in items}) != len(items):
            return f"{key}={spec}: a column named twice in the list"
        return None
    if spec.count(NUMBER) > 1:
        return f"{key}={spec}: one '{NUMBER}' for the joint number, got {spec.count(NUMBER)}"
    if spec == NUMBER:
        return f"{key}={spec}: a pattern needs text beside '{NUMBER}'"
    return None


def parse_columns(text: str) -> dict[str, str]:
    """``t=time,q=pos,...`` as {key: spec}; ValueError (one line) for a malformed item."""
    out: dict[str, str] = {}
    for item in filter(None, (x.strip() for x in text.split(","))):
        if "=" not in item:
            raise ValueError(f"expected KEY=NAME items, got {item!r}")
        k, v = (x.strip() for x in item.split("=", 1))
        problem = spec_problem(k, v)
        if problem:
            raise ValueError(problem)
        if k in out:
            raise ValueError(f"{k} given twice")
        out[k] = v
    return out


def require_named(present: dict, columns: dict[str, str], src: str) -> None:
    """Refuse an array (an .npz member, a mapping's key) that ``--columns`` names but the data lack."""
    missing = [f"{k}={columns[k]}" for k in KEYS if k in columns and present.get(k) is None]
    if missing:
        raise DataError(f"{src}: no array named by --columns {', '.join(missing)}")


def header_names(header: list[str]) -> list[str]:
    """A header's column names as matched: blanks around each name dropped, and a name in double
    quotes unquoted (``"t","q1",...`` as Python's csv module with QUOTE_NONNUMERIC or R's write.csv
    write it), a doubled quote inside it read as one."""
    names = []
    for h in header:
        h = h.strip()
        if len(h) >= 2 and h[0] == h[-1] == '"':
            h = h[1:-1].replace('""', '"').strip()
        names.append(h)
    return names


def looks_headerless(header: list[str]) -> bool:
    """Whether a CSV's first line is a row of numbers rather than column names."""
    values = header_names(header)
    if not values or not all(values):
        return False
    try:
        [float(v) for v in values]
    except ValueError:
        return False
    return True


def headerless_error(src: str, width: int, n: int) -> DataError:
    """The one-line refusal of a file without a header: what header to add for its width."""
    layouts = {1 + 2 * n: ("q", "tau"), 1 + 3 * n: ("q", "dq", "tau"), 1 + 4 * n: ("q", "dq", "ddq", "tau")}
    lead = f"{src}: no header row (line 1 holds {width} numbers)"
    if n <= 0:
        return DataError(f"{lead}; add a first line naming the columns: t, q1.., dq1.. (optional), ddq1.. (optional), tau1..")
    if width not in layouts:
        return DataError(f"{lead}; add a first line naming the columns (t, then q1..q{n}, dq1..dq{n} (optional), "
                         f"ddq1..ddq{n} (optional), tau1..tau{n}: 1 + 2·{n}, 3·{n} or 4·{n} values for this robot)")
    header = ",".join(["t"] + [f"{k}{j}" for k in layouts[width] for j in range(1, n + 1)])
    if len(header) > 200:
        header = "t," + ",".join(f"{k}1..{k}{n}" for k in layouts[width])
        return DataError(f"{lead}; add a first line naming them in order: {header}")
    return DataError(f"{lead}; add a first line naming them, e.g. sed -i '1i {header}' {src}")


def time_index(header: list[str], n: int, columns: dict[str, str], src: str) -> int:
    """Index of the time column, refusing a file without a header first."""
    names = header_names(header)
    if not any(names):
        raise DataError(f"{src}: empty file (no header row, no data)")
    if looks_headerless(names):
        raise headerless_error(src, len(names), n)
    if len(names) == 1:
        for sep, what in ((";", "';'"), ("\t", "tabs")):
            if sep in names[0]:
                raise DataError(f"{src}: no comma-separated header: the header has {what} between its names; "
                                "use comma-separated values")
        raise DataError(f"{src}: the header has a single column ({names[0][:40]!r}): expected comma-separated "
                        "columns t, q1.., tau1..")
    name = columns.get("t", "t")
    if name not in names:
        raise DataError(f"{src}: missing time column '{name}' (use --columns t=NAME)")
    return names.index(name)


def column_indices(header: list[str], n: int, columns: dict[str, str], src: str) -> dict[str, list[int] | None]:
    """Column index of t and of every joint's q, dq, ddq, tau (None for an absent dq or ddq).

    A numbered key (prefix or pattern) must have exactly the joints 1..n or 0..n-1; a file whose
    joint columns go beyond n, or stop short of it, is refused, in joint terms.
    """
    names = header_names(header)
    idx: dict[str, list[int] | None] = {"t": [time_index(names, n, columns, src)]}
    for key in KEYS[1:]:
        # q and tau always; dq and ddq when --columns names them (a named column that is missing is an error)
        idx[key] = key_indices(names, key, columns.get(key, key), n, src, required=key in ("q", "tau") or key in columns)
    used = sorted({names[i] for ix in idx.values() if ix for i in ix})
    twice = next((name for name in used if names.count(name) > 1), None)
    if twice is not None:  # which of the two holds the signal cannot be told
        raise DataError(f"{src}: column {twice!r} appears {names.count(twice)} times among the column names; name each column once")
    return idx


def key_indices(names: list[str], key: str, spec: str, n: int, src: str, required: bool = True) -> list[int] | None:
    """The column index of every joint's ``key`` (q, dq, ddq or tau) named by ``spec`` (a prefix, a
    pattern with {} or a | list) among ``names``; None when no column matches and not ``required``."""
    if LIST_SEP in spec:
        return _listed(names, spec, key, n, src)
    before, after = spec.split(NUMBER, 1) if NUMBER in spec else (spec, "")
    numbered = re.compile(re.escape(before) + r"(0|[1-9][0-9]*)" + re.escape(after))
    found = {int(m.group(1)): i for i, m in enumerate(map(numbered.fullmatch, names)) if m}
    joints = sorted(found)
    shown = before + "{}" + after
    if not joints:
        if required:
            first, last = shown.replace("{}", "1"), shown.replace("{}", str(n))
            raise DataError(f"{src}: missing columns {first}..{last} "
                            f"(use --columns {key}=PREFIX, {key}=PATTERN_{{}} or {key}=NAME1|NAME2|...)")
        return None
    if joints == list(range(1, n + 1)) or joints == list(range(0, n)):
        return [found[j] for j in joints]
    raise DataError(f"{src}: {_joint_mismatch(before, after, joints, n)}")


def _listed(names: list[str], spec: str, key: str, n: int, src: str) -> list[int]:
    """The columns of an explicit list, one per joint in joint order."""
    wanted = [x.strip() for x in spec.split(LIST_SEP)]
    if len(wanted) != n:
        raise DataError(f"{src}: --columns {key}= lists {len(wanted)} column{'s' if len(wanted) != 1 else ''}, "
                        f"the robot has {n} joint{'s' if n != 1 else ''}")
    missing = [w for w in wanted if w not in names]
    if missing:
        raise DataError(f"{src}: missing column{'s' if len(missing) > 1 else ''} "
                        f"{', '.join(repr(m) for m in missing[:4])}{', ...' if len(missing) > 4 else ''} "
                        f"(listed in --columns {key}=)")
    return [names.index(w) for w in wanted]


def _joint_mismatch(before: str, after: str, joints: list[int], n: int) -> str:
    """The data's joint columns ``joints`` (numbers in before{}after) against the robot's n joints, in words."""
    def col(j) -> str:
        return f"{before}{j}{after}"

    robot = f"the robot has {n}"
    m = len(joints)
    if joints == list(range(1, m + 1)) or joints == list(range(0, m)):  # q1..qm or q0..q(m-1)
        shown = col(joints[0]) if m == 1 else f"{col(joints[0])}..{col(joints[-1])}"
        return f"the data have {m} joint{'s' if m != 1 else ''} ({shown}), {robot}"
    shown = ", ".join(col(j) for j in joints[:8]) + (", ..." if m > 8 else "")
    base = 0 if joints[0] == 0 else 1
    missing = [col(j) for j in range(base, n + base) if j not in joints]
    extra = [col(j) for j in joints if not base <= j < n + base]
    what = "; ".join(part for part in (
        f"{', '.join(missing[:4])}{', ...' if len(missing) > 4 else ''} missing" if missing else "",
        f"{', '.join(extra[:4])}{', ...' if len(extra) > 4 else ''} beyond joint {n}" if extra else "",
    ) if part)
    return f"the data have columns {shown}, {robot} joint{'s' if n != 1 else ''} ({what})"
