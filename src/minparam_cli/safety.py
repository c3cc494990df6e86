"""Guards for reading untrusted files: bounded size, no code, no entities, no alias bombs.

Every description file goes through :func:`read_bounded` (a regular file, at most
``max_file_bytes()``) and YAML through :func:`read_yaml`, which walks the parser's
events before building anything: nesting depth, the number of nodes once every alias
is expanded, and the length of numbers are bounded there, so that a "billion laughs"
file or a 5000-digit integer is refused in milliseconds.  :func:`finite_number` bounds
the values themselves.  docs/security.md lists the limits.
"""

from __future__ import annotations

import functools
import math
import os
import re
import stat
from pathlib import Path

from minparam_cli.errors import DescriptionError

MAX_FILE_BYTES = 16 * 1024 * 1024  # a robot description is never this large
MAX_FILE_ENV = "MINPARAM_MAX_FILE_MB"  # raises (or lowers) MAX_FILE_BYTES, in MiB
MAX_JOINTS = 128
MAX_YAML_DEPTH = 32  # a robot file nests about 5 deep; libyaml's composer recurses in C
MAX_YAML_NODES = 200_000  # nodes once every alias is expanded (128 joints need about 8 000)
MAX_NUMBER_CHARS = 64  # characters of one number as written (a double needs at most 25)
MAX_ABS_VALUE = 1e6  # any value of a description, in the file's units (1000 km, 1e6 kg)


def max_file_bytes() -> int:
    """The size limit of description files: MAX_FILE_BYTES, or $MINPARAM_MAX_FILE_MB MiB."""
    text = os.environ.get(MAX_FILE_ENV)
    if not text:
        return MAX_FILE_BYTES
    try:
        mb = float(text)
    except ValueError:
        mb = float("nan")
    if not (math.isfinite(mb) and mb > 0):
        raise DescriptionError(f"${MAX_FILE_ENV} must be a positive number of MiB, got {text!r}")
    return int(mb * 1024 * 1024)


def file_kind(mode: int) -> str:
    """What a non-regular file is, in words, for the refusal."""
    for test, name in ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a named pipe (FIFO)"), (stat.S_ISCHR, "a character device"),
                       (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return name
    return "not a regular file"


def require_regular_file(path: Path, error=DescriptionError) -> os.stat_result:
    """stat() ``path`` (following links) and refuse anything but a regular file, without opening it:
    opening a FIFO waits for a writer, and a device (/dev/zero, /dev/urandom) never ends."""
    src = str(path)
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise error(f"{src}: cannot read file (no such file)") from None
    except OSError as e:
        raise error(f"{src}: cannot read file ({e.strerror})") from None
    if not stat.S_ISREG(st.st_mode):
        raise error(f"{src}: is {file_kind(st.st_mode)}, expected a regular file")
    return st


def read_bounded(path: Path, limit: int | None = None) -> bytes:
    """Read a regular file of at most ``limit`` bytes; refuse larger files instead of loading them."""
    path = Path(path)
    limit = max_file_bytes() if limit is None else limit
    hint = f" (set ${MAX_FILE_ENV} to raise it)"
    size = require_regular_file(path).st_size
    if size > limit:
        raise DescriptionError(f"file is {size} bytes, larger than the {limit}-byte limit{hint}", str(path))
    try:
        with open(path, "rb") as fh:
            data = fh.read(limit + 1)
    except OSError as e:
        raise DescriptionError(f"cannot read file ({e.strerror})", str(path)) from e
    if len(data) > limit:
        raise DescriptionError(f"file is larger than the {limit}-byte limit{hint}", str(path))
    if not data.strip():
        raise DescriptionError("file is empty", str(path))
    return data


def finite_number(v, src: str, where: str, limit: float = MAX_ABS_VALUE) -> float:
    """A YAML value that must be a number: finite and at most ``limit`` in magnitude."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise DescriptionError(f"expected a number, got {short_repr(v)}", src, where)
    try:
        x = float(v)
    except OverflowError:
        x = math.inf
    if not math.isfinite(x):
        raise DescriptionError(f"expected a finite number, got {short_repr(v)}", src, where)
    return bounded(x, src, where, limit)


def bounded(x: float, src: str, where: str, limit: float = MAX_ABS_VALUE) -> float:
    """``x`` if |x| <= limit, else a refusal naming the field."""
    if abs(x) > limit:
        raise DescriptionError(f"{x:g} is out of range: expected a magnitude of at most {limit:g} (in the file's units)", src, where)
    return x


def short_repr(v, limit: int = 60) -> str:
    """repr() of a value, cut to ``limit`` characters (never expands a large structure in full)."""
    if isinstance(v, (list, tuple, dict)):
        text = f"a {type(v).__name__} of {len(v)} items"
        if len(v) <= 8:
            inner = repr(v) if _small(v) else None
            if inner is not None:
                text = inner
    else:
        text = repr(v)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def key_list(keys, shown: int = 5) -> str:
    """Some of a set of mapping keys, sorted and cut short, for a refusal."""
    names = sorted(str(k) if len(str(k)) <= 40 else str(k)[:37] + "..." for k in keys)
    more = f" and {len(names) - shown} more" if len(names) > shown else ""
    return f"{names[:shown]}{more}"


def mapping_entry(value, allowed, src: str, where: str, expected: str) -> dict:
    """One entry of a description's list (a joint, a loop cut): a mapping whose keys are all ``allowed``;
    else a DescriptionError at ``where`` ("expected a mapping with {expected}", or the unknown keys)."""
    if not isinstance(value, dict):
        raise DescriptionError(f"expected a mapping with {expected}", src, where)
    unknown = set(value) - set(allowed)
    if unknown:
        raise DescriptionError(f"unknown key(s) {key_list(unknown)}", src, where)
    return value


def _small(v, budget: int = 64) -> bool:
    """Whether a nested list/dict holds at most ``budget`` items in all (so repr() is cheap)."""
    stack, seen = [v], 0
    while stack:
        x = stack.pop()
        seen += 1
        if seen > budget:
            return False
        if isinstance(x, dict):
            stack.extend(x.keys())
            stack.extend(x.values())
        elif isinstance(x, (list, tuple)):
            stack.extend(x)
    return True


_DECLARATION = re.compile(rb"<\?xml(\s[^>]*?)?\?>")
_ENCODING = re.compile(rb"""encoding\s*=\s*["']([A-Za-z0-9._-]{1,40})["']""")


def lenient_prolog(data: bytes) -> bytes:
    """The XML declaration as urdfdom (TinyXML2) reads it: blank lines (and a byte-order mark) before it
    are dropped, and its version, which TinyXML2 never checks, becomes 1.0 (pybullet's minitaur files
    say "0.0").  An encoding Python knows is kept; another one is dropped (TinyXML2 reads UTF-8 whatever
    the declaration says); the dropped line breaks follow it, so that line numbers do not move.  Nothing
    after the declaration changes: DOCTYPEs are still refused."""
    body = data[3:] if data.startswith(b"\xef\xbb\xbf") else data
    stripped = body.lstrip(b" \t\r\n")
    m = _DECLARATION.match(stripped)
    if m is None:
        return data
    enc = _ENCODING.search(m.group(0))
    keep = b""
    if enc is not None:
        import codecs

        try:
            codecs.lookup(enc.group(1).decode("ascii"))
            keep = b' encoding="' + enc.group(1) + b'"'
        except LookupError:
            pass
    lines = b"\n" * body[: len(body) - len(stripped)].count(b"\n")  # error messages keep the file's line numbers
    return b'<?xml version="1.0"' + keep + b"?>" + lines + stripped[m.end():]


def parse_xml_safely(data: bytes, source: str):
    """Parse XML with lxml, refusing DTDs, entities and network access.

    Returns the root element.  A URDF never needs a DOCTYPE, so any is refused:
    that closes entity-expansion ("billion laughs") and external-entity attacks.
    """
    from lxml import etree

    parser = etree.XMLParser(
        resolve_entities=False, no_network=True, load_dtd=False, huge_tree=False, remove_comments=True
    )
    try:
        root = etree.fromstring(lenient_prolog(data), parser=parser)
    except etree.XMLSyntaxError as e:
        raise DescriptionError(f"malformed XML ({e.msg}, line {e.lineno})", source) from e
    doc = root.getroottree().docinfo
    if doc.internalDTD is not None or doc.externalDTD is not None or doc.doctype:
        raise DescriptionError("DOCTYPE and entity declarations are not allowed in a URDF", source)
    return root


@functools.lru_cache(maxsize=1)
def _unique_key_loader():
    """A yaml.SafeLoader that refuses a key repeated in one mapping (plain safe_load keeps the last)."""
    import yaml

    # libyaml's parser when present (several times faster); the constructor stays the safe one
    base = getattr(yaml, "CSafeLoader", yaml.SafeLoader)

    class UniqueKeyLoader(base):  # type: ignore[valid-type,misc]  # a base chosen at run time (libyaml's when present)
        def construct_mapping(self, node, deep=False):
            seen = set()
            for key_node, _ in node.value:
                key = self.construct_object(key_node, deep=deep)
                try:
                    hash(key)
                except TypeError:  # a mapping or a list used as a key ("? [1, 2]"): no field is named so
                    raise yaml.constructor.ConstructorError(
                        None, None, f"a key must be a plain value, not a {type(key).__name__}", key_node.start_mark) from None
                if key in seen:
                    raise yaml.constructor.ConstructorError(None, None, f"duplicate key {key!r}", key_node.start_mark)
                seen.add(key)
            return super().construct_mapping(node, deep=deep)

    return UniqueKeyLoader


def _event_path(frames) -> str | None:
    """The YAML path ("joints[2].inertial.mass") of the node being read, from the event frames."""
    parts: list[str] = []
    for kind, key, index in frames:
        if kind == "map" and key is not None:
            parts.append(f".{key}" if parts else str(key))
        elif kind == "seq":
            parts.append(f"[{index}]")
    return "".join(parts) or None


def check_yaml_events(data: bytes, src: str) -> None:
    """Walk the parser's events once, before any node is built, and refuse:

    * nesting deeper than MAX_YAML_DEPTH (libyaml's composer recurses in C and would crash);
    * more than MAX_YAML_NODES nodes once every alias is expanded ("billion laughs": ten nested
      aliases of ten make 10^9 nodes from a 1 kB file), and an alias to a node that contains it;
    * a number written with more than MAX_NUMBER_CHARS characters.

    Counting is by anchor: an alias adds the expanded size of the node it names, so a bomb is
    refused after reading its few lines, without expanding anything.
    """
    import yaml

    loader = _unique_key_loader()
    resolver = yaml.resolver.Resolver()
    numeric = {"tag:yaml.org,2002:int", "tag:yaml.org,2002:float"}
    sizes: dict[str, int] = {}  # anchor -> expanded node count
    open_anchors: set[str] = set()
    frames: list[list] = []  # [kind, current key, 1-based index] per open collection
    counts: list[list] = [[0, None]]  # [expanded nodes so far, anchor] per open collection (+ the document)
    total = 0

    def refuse(message: str) -> None:
        raise DescriptionError(message, src, _event_path(frames))

    def advance(key_text: str | None = None) -> None:
        """One more node in the enclosing collection: its 1-based index, or a mapping's key."""
        if frames:
            f = frames[-1]
            if f[0] == "map" and f[2] % 2 == 0:
                f[1] = key_text if key_text is not None else "?"
            f[2] += 1

    def count(n: int) -> None:
        nonlocal total
        counts[-1][0] += n
        total += n
        if total > MAX_YAML_NODES:
            refuse(f"YAML expands to more than {MAX_YAML_NODES} nodes (aliases nested inside aliases?)")

    try:
        for ev in yaml.parse(data, Loader=loader):
            if isinstance(ev, yaml.ScalarEvent):
                advance(ev.value if len(ev.value) <= 40 else ev.value[:40] + "...")
                if len(ev.value) > MAX_NUMBER_CHARS:  # an explicit !!int, or a plain scalar read as a number
                    tag = ev.tag if ev.tag not in (None, "!") else resolver.resolve(yaml.ScalarNode, ev.value, ev.implicit)
                    if tag in numeric and (ev.tag is not None or not ev.style):
                        refuse(f"a number written with {len(ev.value)} characters (at most {MAX_NUMBER_CHARS})")
                if ev.anchor is not None:
                    sizes[ev.anchor] = 1
                count(1)
            elif isinstance(ev, yaml.AliasEvent):
                advance()
                if ev.anchor in open_anchors:
                    refuse(f"alias *{ev.anchor} refers to a node that contains it")
                count(sizes.get(ev.anchor, 1))
            elif isinstance(ev, (yaml.SequenceStartEvent, yaml.MappingStartEvent)):
                advance()
                if len(frames) >= MAX_YAML_DEPTH:
                    refuse(f"YAML nested more than {MAX_YAML_DEPTH} levels deep")
                count(1)
                if ev.anchor is not None:
                    open_anchors.add(ev.anchor)
                frames.append(["seq" if isinstance(ev, yaml.SequenceStartEvent) else "map", None, 0])
                counts.append([1, ev.anchor])
            elif isinstance(ev, (yaml.SequenceEndEvent, yaml.MappingEndEvent)):
                frames.pop()
                n, anchor = counts.pop()
                if anchor is not None:
                    sizes[anchor] = n
                    open_anchors.discard(anchor)
                counts[-1][0] += n
    except yaml.YAMLError:
        return  # a syntax error: the full parse below reports it with its line


def read_yaml(path: Path):
    """Parse a YAML file safely: bounded size, nesting, alias expansion and numbers (see
    :func:`check_yaml_events`), SafeLoader (no Python objects), no repeated keys."""
    import yaml

    src = str(path)
    data = read_bounded(Path(path))
    check_yaml_events(data, src)
    try:
        return yaml.load(data, Loader=_unique_key_loader())  # noqa: S506 - a SafeLoader subclass
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        where = f" at line {mark.line + 1}" if mark is not None else ""
        problem = getattr(e, "problem", None) or str(e).splitlines()[0]
        raise DescriptionError(f"malformed YAML{where} ({problem})", src) from e
    except (ValueError, OverflowError, RecursionError) as e:  # a value the constructor cannot convert
        raise DescriptionError(f"malformed YAML ({' '.join(str(e).split())[:120]})", src) from None
