"""Guards for reading untrusted files: bounded size, no code, no entities."""

from __future__ import annotations

import functools
from pathlib import Path

from minparam_cli.errors import DescriptionError

MAX_FILE_BYTES = 16 * 1024 * 1024  # a robot description is never this large
MAX_JOINTS = 128


def read_bounded(path: Path, limit: int = MAX_FILE_BYTES) -> bytes:
    """Read at most ``limit`` bytes; refuse larger files instead of loading them."""
    try:
        size = path.stat().st_size
        if size > limit:
            raise DescriptionError(f"file is {size} bytes, larger than the {limit}-byte limit", str(path))
        with open(path, "rb") as fh:
            data = fh.read(limit + 1)
    except OSError as e:
        raise DescriptionError(f"cannot read file ({e.strerror})", str(path)) from e
    if len(data) > limit:
        raise DescriptionError(f"file is larger than the {limit}-byte limit", str(path))
    if not data.strip():
        raise DescriptionError("file is empty", str(path))
    return data


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
        root = etree.fromstring(data, parser=parser)
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

    class UniqueKeyLoader(base):
        def construct_mapping(self, node, deep=False):
            seen = set()
            for key_node, _ in node.value:
                key = self.construct_object(key_node, deep=deep)
                if key in seen:
                    raise yaml.constructor.ConstructorError(None, None, f"duplicate key {key!r}", key_node.start_mark)
                seen.add(key)
            return super().construct_mapping(node, deep=deep)

    return UniqueKeyLoader


def read_yaml(path: Path):
    """Parse a YAML file safely: bounded size, SafeLoader (no Python objects), no repeated keys."""
    import yaml

    src = str(path)
    data = read_bounded(Path(path))
    try:
        return yaml.load(data, Loader=_unique_key_loader())  # noqa: S506 - a SafeLoader subclass
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        where = f" at line {mark.line + 1}" if mark is not None else ""
        problem = getattr(e, "problem", None) or str(e).splitlines()[0]
        raise DescriptionError(f"malformed YAML{where} ({problem})", src) from e
