"""The scripts in examples/ run as a user would run them (a fresh process, from another folder) and
print what their docstrings promise."""

from __future__ import annotations

import os
import re
import subprocess
import sys

from conftest import ROOT


def run(script: str, *args, cwd) -> str:
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src") + os.pathsep + os.environ.get("PYTHONPATH", ""),
           "MPLBACKEND": "Agg"}
    r = subprocess.run([sys.executable, str(ROOT / "examples" / script), *map(str, args)], cwd=cwd, env=env,
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert r.stderr == "", r.stderr  # the library prints nothing of its own
    return r.stdout


def test_derive_latex(tmp_path):
    out = run("derive_latex.py", ROOT / "robots" / "planar2r.yaml", "--symbolic", cwd=tmp_path)
    assert "6 base parameters of 20 standard ones" in out
    assert "\\begin{align*}" in out and "\\end{align*}" in out
    assert r"\mathrm{ZZ}_{2} - a_{2}^{2}\,\mathrm{M}_{2}" in out  # ZZR2 = ZZ2 - a2² M2 (Khalil's rule)


def test_identify_arrays_finds_the_friction_and_plots(tmp_path):
    out = run("identify_arrays.py", "fig.png", "--duration", "6", cwd=tmp_path)
    found = re.search(r"effects found: (.*)", out).group(1)
    assert {"coulomb", "viscous"} <= set(found.split(", "))
    rigid, final = (float(x) for x in re.findall(r"test error\s+([\d.]+) %", out))
    assert final < rigid / 5
    assert (tmp_path / "fig.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_computed_torque_tracks(tmp_path):
    out = run("computed_torque.py", "--duration", "1", cwd=tmp_path)
    exact, wrong, feedback = (float(x) for x in re.findall(r"max tracking error ([\d.]+) rad", out))
    assert exact < 1e-2  # the base regressor reproduces the plant: only the integration error is left
    assert feedback < 0.05 < wrong
