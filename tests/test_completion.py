"""Shell completion through typer's own mechanism: --show-completion / --install-completion for
bash, zsh and fish, and the completion protocol their scripts call (``_MINPARAM_COMPLETE``)."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest
from conftest import ROOT

RUN = "import sys; sys.argv[0] = 'minparam'; from minparam_cli.cli.app import entry; sys.exit(entry())"


def minparam(*args: str, env: dict | None = None) -> subprocess.CompletedProcess:
    full = {**os.environ, **(env or {})}
    for key in ("_MINPARAM_COMPLETE", "_TYPER_COMPLETE_ARGS", "COMP_WORDS", "COMP_CWORD"):
        if env is None or key not in env:
            full.pop(key, None)
    return subprocess.run([sys.executable, "-c", RUN, *args], cwd=ROOT, env=full, capture_output=True, text=True, timeout=120)


# typer detects the running shell; this variable of typer's makes the options take the shell's name instead
NAMED_SHELL = {"_TYPER_COMPLETE_TEST_DISABLE_SHELL_DETECTION": "1"}


def test_the_root_help_offers_both_options():
    out = minparam("--help").stdout
    assert "--install-completion" in out and "--show-completion" in out


@pytest.mark.parametrize(("shell", "marker"), [("bash", "complete -o default -F _minparam_completion minparam"),
                                               ("zsh", "compdef _minparam_completion minparam"),
                                               ("fish", "complete --command minparam")])
def test_show_completion_prints_each_shells_script(shell, marker):
    r = minparam("--show-completion", shell, env=NAMED_SHELL)
    assert r.returncode == 0, r.stderr
    assert marker in r.stdout and f"_MINPARAM_COMPLETE=complete_{shell}" in r.stdout


def test_install_completion_writes_the_script_and_sources_it(tmp_path):
    r = minparam("--install-completion", "bash", env={**NAMED_SHELL, "HOME": str(tmp_path)})
    assert r.returncode == 0, r.stderr
    script = tmp_path / ".bash_completions" / "minparam.sh"
    assert "_minparam_completion" in script.read_text()
    assert f"source '{script}'" in (tmp_path / ".bashrc").read_text()


def test_bash_completes_command_names_and_options():
    r = minparam(env={"_MINPARAM_COMPLETE": "complete_bash", "COMP_WORDS": "minparam de", "COMP_CWORD": "1"})
    assert r.stdout.split() == ["derive"]
    r = minparam(env={"_MINPARAM_COMPLETE": "complete_bash", "COMP_WORDS": "minparam singular --q", "COMP_CWORD": "2"})
    assert "--quiet" in r.stdout.split() and "--q" in r.stdout.split()


def test_zsh_completes_command_names_with_their_help():
    r = minparam(env={"_MINPARAM_COMPLETE": "complete_zsh", "_TYPER_COMPLETE_ARGS": "minparam si"})
    assert '"simulate":' in r.stdout and '"singular":' in r.stdout and "derive" not in r.stdout


def test_fish_completes_choices():
    r = minparam(env={"_MINPARAM_COMPLETE": "complete_fish", "_TYPER_COMPLETE_ARGS": "minparam derive --method ",
                      "_TYPER_COMPLETE_FISH_ACTION": "get-args"})
    assert r.stdout.split() == ["qr", "projection"]
