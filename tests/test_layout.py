"""The code's map holds (STYLE.md, ARCHITECTURE.md): no two modules import each other, at module
level or inside a function (a lazy import is still a dependency), and the stages never import the
command line."""

from __future__ import annotations

import ast
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src"


def _modules() -> dict[str, Path]:
    out = {}
    for p in SRC.rglob("*.py"):
        parts = p.relative_to(SRC).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        out[name] = p
    return out


def _imports(name: str, path: Path, modules: dict[str, Path]) -> set[str]:
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")[: len(package.split(".")) - (node.level - 1)]
                base = ".".join(parts + ([base] if base else []))
            for alias in node.names:
                full = f"{base}.{alias.name}"
                found.add(full if full in modules else base)
        elif isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
    return {m for m in found if m in modules and m != name}


def test_no_two_modules_import_each_other():
    modules = _modules()
    edges = {m: _imports(m, p, modules) for m, p in modules.items()}
    pairs = sorted({tuple(sorted((a, b))) for a in edges for b in edges[a] if a in edges.get(b, ())})
    assert not pairs, pairs


def test_stages_never_import_the_command_line():
    modules = _modules()
    below = [m for m in modules if m.startswith("minparam_cli.") and not m.startswith(("minparam_cli.cli", "minparam_cli.__main__"))]
    offenders = {m: sorted(i for i in _imports(m, modules[m], modules) if i.startswith("minparam_cli.cli")) for m in below}
    assert not {m: v for m, v in offenders.items() if v}


def test_the_checker_sees_a_lazy_import_pair(tmp_path, monkeypatch):
    """The check can fail: two modules that import each other inside functions are found."""
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("def f():\n    from pkg.b import g\n")
    (pkg / "b.py").write_text("def g():\n    from . import a\n")
    monkeypatch.setattr(__import__(__name__), "SRC", tmp_path)
    modules = _modules()
    assert _imports("pkg.a", modules["pkg.a"], modules) == {"pkg.b"}
    assert _imports("pkg.b", modules["pkg.b"], modules) == {"pkg.a"}


# The map, from the bottom up (docs/architecture.md): a module may import its own room, the rooms
# of its own layer and the layers below, never a layer above.  A room is a top-level module or
# package of minparam_cli, or a subpackage of identify/.
LAYERS = (
    ("minparam_cli", "errors", "params", "safety", "optional", "runtime", "output", "factoring"),
    ("describe",),
    ("joint_matrices", "chain", "robot"),
    ("dynamics",),
    ("base", "kinematics", "codegen", "loops"),
    ("measured",),
    ("experiment", "identify.estimate"),
    ("identify.passes",),
    ("identify.diagnosis", "identify.physical"),
    ("identify.assess",),
    ("identify",),
    ("model",),
    ("render",),
    ("api",),
    ("cli", "__main__"),
)
MAX_LINES = 400


def _room(module: str) -> str:
    parts = module.split(".")[1:]
    if not parts:
        return "minparam_cli"
    if parts[0] == "identify" and len(parts) > 2:  # identify.<subpackage>.<module>
        return f"identify.{parts[1]}"
    if parts[0] == "identify" and len(parts) == 2 and (SRC / "minparam_cli" / "identify" / parts[1]).is_dir():
        return f"identify.{parts[1]}"
    return parts[0]


def _layer(room: str) -> int:
    for i, rooms in enumerate(LAYERS):
        if room in rooms:
            return i
    raise AssertionError(f"room {room!r} is not on the map (tests/test_layout.py LAYERS, docs/architecture.md)")


def _upward_imports() -> list[str]:
    modules = _modules()
    found = []
    for name, path in sorted(modules.items()):
        if not name.startswith("minparam_cli"):
            continue
        here = _layer(_room(name))
        for imported in sorted(_imports(name, path, modules)):
            if imported.startswith("minparam_cli") and _layer(_room(imported)) > here:
                found.append(f"{name} -> {imported}")
    return found


def test_every_room_is_on_the_map_and_no_import_runs_up_it():
    assert not _upward_imports()


def _pretend_import(monkeypatch, importer: str, imported: str) -> None:
    """Make the checks see ``importer`` import ``imported`` (to show that a check can fail)."""
    real = _imports

    def with_extra(name, path, modules):
        found = real(name, path, modules)
        return found | {imported} if name == importer else found

    monkeypatch.setattr(__import__(__name__), "_imports", with_extra)


def test_the_map_check_sees_an_upward_import(monkeypatch):
    """The check can fail: a stage importing the command line is found."""
    _pretend_import(monkeypatch, "minparam_cli.dynamics.regressor", "minparam_cli.cli.app")
    assert _upward_imports() == ["minparam_cli.dynamics.regressor -> minparam_cli.cli.app"]


def test_no_source_file_passes_the_line_limit():
    long = {str(p.relative_to(SRC)): n for p in SRC.rglob("*.py") if (n := len(p.read_text(encoding="utf-8").splitlines())) > MAX_LINES}
    assert not long, f"split these files (over {MAX_LINES} lines): {long}"


# The command line is a shell over the API (issue 30, "one driver"): parse, call ``minparam_cli.api``,
# render, exit code.  Every module of cli/ imports nothing else of the package.
CLI_MAY_IMPORT = ("minparam_cli.api", "minparam_cli.render", "minparam_cli.cli")
CLI_MAY_IMPORT_MODULES = ("minparam_cli", "minparam_cli.output", "minparam_cli.errors", "minparam_cli.runtime",
                          "minparam_cli.optional")


def _cli_modules() -> tuple[str, ...]:
    return tuple(sorted(m.rpartition(".")[2] for m in _modules() if m.startswith("minparam_cli.cli.")))


def _cli_strays(names: tuple[str, ...] | None = None) -> dict[str, list[str]]:
    modules = _modules()
    out = {}
    for short in names or _cli_modules():
        name = f"minparam_cli.cli.{short}"
        stray = sorted(m for m in _imports(name, modules[name], modules)
                       if m.startswith("minparam_cli") and m not in CLI_MAY_IMPORT_MODULES
                       and not m.startswith(tuple(p + "." for p in CLI_MAY_IMPORT)))
        if stray:
            out[name] = stray
    return out


def test_the_commands_import_only_the_api_the_renderers_and_output():
    assert {"derive", "identify", "evaluate", "platform"} <= set(_cli_modules())
    assert not _cli_strays()


def test_the_cli_check_sees_a_stage_import(monkeypatch):
    """The check can fail: a command importing a stage module is found."""
    _pretend_import(monkeypatch, "minparam_cli.cli.evaluate", "minparam_cli.identify.stage")
    assert _cli_strays() == {"minparam_cli.cli.evaluate": ["minparam_cli.identify.stage"]}
