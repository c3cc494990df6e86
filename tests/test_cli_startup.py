"""Start-up: `main()` registers only the command it runs, yet every help and error looks the same;
the derive path keeps the other commands' modules (and their libraries) out of the process."""

from __future__ import annotations

import gc
import json
import subprocess
import sys

import pytest
from conftest import ROOT
from typer.testing import CliRunner

from minparam_cli.cli import app as app_module
from minparam_cli.cli.app import COMMANDS, build_app, commands_for, entry, main

# every command line whose output must not depend on how many commands are registered
HELP_LINES = [[name, "--help"] for name in COMMANDS] + [
    ["platform"],
    ["platform", "ik", "--help"],
    ["platform", "fk", "--help"],
    ["platform", "workspace", "--help"],
    ["derive"],  # missing argument: usage error
    ["derive", "--bogus", "robots/puma560.yaml"],
    ["derive", "robots/puma560.yaml", "--method", "nope"],
    ["check", "robots/no_such_file.yaml"],
]


@pytest.fixture(autouse=True)
def _unfreeze():
    """main() freezes the collector's live objects for a fast shutdown; undo it in this process."""
    yield
    gc.unfreeze()


def invoke(app, args):
    r = CliRunner().invoke(app, args)
    return r.exit_code, r.output


def test_commands_for_picks_the_named_command_only():
    assert commands_for(["derive", "robots/puma560.yaml"]) == ("derive",)
    assert commands_for(["platform", "fk", "x.yaml"]) == ("platform",)
    for argv in ([], ["--help"], ["-h"], ["--version"], ["--version", "derive"], ["deriv"], ["robots/puma560.yaml"]):
        assert commands_for(argv) is None, argv


def test_root_help_lists_every_command_in_order():
    code, out = invoke(app_module.app, ["--help"])
    assert code == 0
    listed = [line.split()[0] for line in out.split("Commands:")[1].strip().splitlines()]
    assert listed == list(COMMANDS)


@pytest.mark.parametrize("argv", [["--help"], ["-h"], [], ["--version"], ["deriv", "robots/puma560.yaml"]], ids=str)
def test_main_without_a_command_name_registers_everything(argv, monkeypatch, capsys):
    monkeypatch.setattr(sys, "argv", ["minparam", *argv])
    code = main()
    out, err = capsys.readouterr()
    full = invoke(app_module.app, argv)
    assert code == full[0]
    if argv in (["--help"], ["-h"]):
        assert all(f"  {name} " in out for name in COMMANDS)
    if argv and argv[0] == "deriv":
        assert "No such command 'deriv'" in err


@pytest.mark.parametrize("args", HELP_LINES, ids=" ".join)
def test_a_single_command_app_prints_what_the_full_app_prints(args):
    assert invoke(build_app((args[0],)), args) == invoke(build_app(), args)


def test_main_runs_derive_with_only_derive_registered(monkeypatch, capsys):
    monkeypatch.setattr(sys, "argv", ["minparam", "derive", "robots/puma560.yaml", "--format", "json"])
    gc.unfreeze()
    assert main() == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["n_base"] == 36 and rep["exact"] is False
    assert gc.get_freeze_count() == 0  # main() leaves its caller's collector alone


def test_the_console_script_freezes_before_exit(monkeypatch, capsys):
    monkeypatch.setattr(sys, "argv", ["minparam", "derive", "robots/puma560.yaml", "--format", "json"])
    gc.unfreeze()
    assert entry() == 0
    assert json.loads(capsys.readouterr().out)["n_base"] == 36
    assert gc.get_freeze_count() > 0  # the shutdown's collections skip what was alive at the end (runtime.py)


@pytest.mark.parametrize("argv, code", [(["--version"], 0), (["check", "robots/no_such_file.yaml"], 2)], ids=str)
def test_python_minus_m_minparam_cli_is_the_console_script(argv, code, monkeypatch, capsys):
    """`python -m minparam_cli` (__main__.py) runs the console script's entry(), main() then the freeze,
    and exits with its code: the output and exit code of the full app, here in this process."""
    import runpy

    monkeypatch.setattr(sys, "argv", ["minparam", *argv])
    gc.unfreeze()  # whatever ran before: the count below must be this run's freeze
    with pytest.raises(SystemExit) as e:
        runpy.run_module("minparam_cli", run_name="__main__")
    out, err = capsys.readouterr()
    assert (e.value.code, out + err) == invoke(app_module.app, argv) and e.value.code == code
    assert gc.get_freeze_count() > 0  # entry()'s, not main()'s


def test_main_derive_help_through_main(monkeypatch, capsys):
    monkeypatch.setattr(sys, "argv", ["minparam", "derive", "--help"])
    assert main() == 0
    out = capsys.readouterr().out
    assert out.startswith("Usage: ") and "derive [OPTIONS] PATHS..." in out.splitlines()[0]
    assert "--method" in out and "Examples:" in out


OTHER_COMMANDS = [f"minparam_cli.cli.{name}" for name in COMMANDS if name != "derive"]
HEAVY = ["tabulate", "scipy", "sympy", "matplotlib", "lxml", "yourdfpy"]  # libraries of other commands and formats

PROBE = """
import sys
sys.argv = ["minparam", "derive", "robots/puma560.yaml"]
from minparam_cli.cli.app import main
code = main()
print("MODULES", *sorted(sys.modules), file=sys.stderr)
raise SystemExit(code)
"""


def test_derive_process_imports_only_what_derive_needs():
    r = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True, cwd=ROOT, check=True)
    assert "base         36" in r.stdout
    modules = set(r.stderr.split("MODULES", 1)[1].split())
    assert "minparam_cli.cli.derive" in modules
    assert not modules & set(OTHER_COMMANDS + HEAVY), sorted(modules & set(OTHER_COMMANDS + HEAVY))
