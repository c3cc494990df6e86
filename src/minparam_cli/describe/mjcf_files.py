"""What an MJCF file makes MuJoCo read or build, checked before MuJoCo's compiler runs (``describe/mjcf.py``).

MuJoCo's compiler is C code that cannot be interrupted: a file it opens that never ends (a named
pipe, a device) or a model it is asked to multiply a million times would hang the command.  So,
before compiling, the XML (the main file and, recursively, the files it includes) is scanned here:

* every ``file*`` attribute (``<include>``, ``<mesh>``, ``<texture>``, ``<hfield>``, ``<skin>``,
  ``<model>``) that names something existing must name a regular file, in the included files and the
  attached models (``<model file>``, with their own asset folders) too: a folder, a FIFO or a device
  is refused in one line (a missing file is left to MuJoCo, whose message names it);
* an included file is size-bounded (``safety.read_bounded``) and carries no DOCTYPE, like the main file;
  the assets (meshes, textures, height fields) together may be at most ``MAX_ASSET_BYTES`` (MuJoCo reads
  each whole into memory, and a mesh's convex hull takes time in proportion);
* ``<replicate count>``, and the ``count`` of ``<composite>`` and ``<flexcomp>`` (the product of its
  numbers), nested, may make at most ``MAX_COPIES`` copies of what they hold.

The XML is read by lxml (attribute values decoded); a text lxml cannot parse (MuJoCo's parser is more
lenient about some prologs) is scanned with patterns instead, every count then taken as nested.
"""

from __future__ import annotations

import html
import math
import os
import re
import stat
from pathlib import Path

from minparam_cli.errors import DescriptionError
from minparam_cli.safety import file_kind, read_bounded

MAX_COPIES = 10_000  # bodies, geoms or particles one nest of <replicate>/<composite>/<flexcomp> may make
MAX_INCLUDES = 256  # files read through <include>, all levels together
MAX_ASSET_BYTES = 1 << 30  # the asset files one model reads, together (the largest robot in MuJoCo Menagerie: under 100 MB)
ASSET_DIRS = ("meshdir", "texturedir", "assetdir")
MULTIPLIERS = ("replicate", "composite", "flexcomp")
_FILE_ATTR = re.compile(rb"<\s*([A-Za-z_][\w.\-:]*)[^>]*?\s(file\w*)\s*=\s*(\"[^\"]*\"|'[^']*')", re.DOTALL)
_COUNT = re.compile(rb"<\s*(replicate|composite|flexcomp)\b[^>]*?\scount\s*=\s*(\"[^\"]*\"|'[^']*')", re.DOTALL)
DECLARATION = re.compile(rb"<!\s*(DOCTYPE|ENTITY)", re.IGNORECASE)  # refused in the main file (mjcf.check_mjcf_text) and the included ones
_COMMENT = re.compile(rb"<!--.*?-->", re.DOTALL)
_DIRS = re.compile(rb"\s(meshdir|texturedir|assetdir)\s*=\s*(\"[^\"]*\"|'[^']*')")


def check_mjcf_files(path: Path, data: bytes, src: str) -> None:
    """Refuse, in one line, an MJCF whose includes or assets are not regular files, or whose
    replication would make more than MAX_COPIES copies (module docstring)."""
    top = Path(path).parent
    files, folders = _scan(data, src)
    scans = [(files, top, [top] + [top / d for d in folders])]  # (file attributes, their folder, asset folders)
    seen: set[Path] = set()
    assets: dict[Path, int] = {}
    while scans:
        files, here, dirs = scans.pop()
        for tag, attr, value in files:
            where = f'<{tag} {attr}="{value}">'
            target = _existing(value, [here, *dirs], src, where)
            followed = tag in ("include", "model")  # XML MuJoCo reads too: an <include>, or a model to <attach>
            if target is not None and not followed:
                assets[target] = target.stat().st_size
                if sum(assets.values()) > MAX_ASSET_BYTES:
                    raise DescriptionError(f"the model's asset files add up to more than {MAX_ASSET_BYTES >> 20} MiB "
                                           f"({len(assets)} files so far)", src, where)
            if target is None or not followed or target in seen:
                continue  # missing: MuJoCo names it
            seen.add(target)
            if len(seen) > MAX_INCLUDES:
                raise DescriptionError(f"more than {MAX_INCLUDES} included files", src, where)
            sub = read_bounded(target)
            if DECLARATION.search(sub):
                raise DescriptionError(f"the included file {target.name} has a DOCTYPE or entity declaration, which an MJCF file may not have", src, where)
            sub_files, sub_folders = _scan(sub, src)
            # an included file shares the including model's asset folders; an attached model has its own
            sub_dirs = dirs if tag == "include" else [target.parent] + [target.parent / d for d in sub_folders]
            scans.append((sub_files, target.parent, sub_dirs))


def _scan(data: bytes, src: str) -> tuple[list[tuple[str, str, str]], list[str]]:
    """([(tag, attribute, file name)], asset folders) of one XML text; refuses too many copies."""
    from lxml import etree

    parser = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False, huge_tree=True, remove_comments=True)
    data = _COMMENT.sub(b"", data)  # MuJoCo accepts "--" inside a comment, lxml does not: without them both read the file
    try:
        root = etree.fromstring(data, parser=parser)
    except (etree.XMLSyntaxError, ValueError):
        root = None
    if root is None:  # patterns; counts taken as nested (an upper bound)
        files = [(t.decode("utf-8", "replace"), a.decode("utf-8", "replace"), _value(v)) for t, a, v in _FILE_ATTR.findall(data)]
        copies = math.prod(_copies(_value(v)) for _, v in _COUNT.findall(data))
        _refuse_copies(copies, src)
        return files, [_value(v) for _, v in _DIRS.findall(data)]
    files = []
    dirs = [v for comp in root.iter("compiler") for k, v in comp.attrib.items() if k in ASSET_DIRS and v]
    for node in root.iter(etree.Element):
        files += [(str(node.tag), str(a), str(v)) for a, v in node.attrib.items() if str(a).startswith("file") and v]
        if node.tag in MULTIPLIERS and node.get("count"):
            n = math.prod(_copies(a.get("count", "1")) for a in [node, *node.iterancestors(*MULTIPLIERS)])
            _refuse_copies(n, src, f'<{node.tag} count="{node.get("count")}">')
    return files, dirs


def _value(quoted: bytes) -> str:
    return html.unescape(quoted[1:-1].decode("utf-8", "replace"))


def _copies(count: str) -> int:
    """The copies one count attribute makes: the product of its numbers (MuJoCo refuses what is not a number)."""
    try:
        return math.prod(max(int(float(c)), 1) for c in count.split()[:3])
    except (ValueError, OverflowError):
        return 1


def _refuse_copies(n: int, src: str, where: str = "") -> None:
    if n > MAX_COPIES:
        raise DescriptionError(f"replication makes {n} copies (nested counts multiply), more than the limit of {MAX_COPIES}", src, where)


def _existing(name: str, folders: list[Path], src: str, where: str) -> Path | None:
    """The first of ``name`` (when absolute) or folder/name that exists, refused unless a regular file."""
    candidates = [Path(name)] if os.path.isabs(name) else [f / name for f in folders]
    for p in candidates:
        try:
            st = os.stat(p)
        except (OSError, ValueError):
            continue
        if not stat.S_ISREG(st.st_mode):
            raise DescriptionError(f"{p} is {file_kind(st.st_mode)}, expected a regular file", src, where)
        return p.resolve()
    return None
