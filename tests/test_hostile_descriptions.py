"""Broken closed-chain descriptions found by an adversarial sweep of the robot readers: one test per kind,
each a one-line refusal (exit 2) in bounded time."""

from __future__ import annotations

import time
from pathlib import Path

import pytest
import yaml
from typer.testing import CliRunner

from minparam_cli.cli.app import app
from minparam_cli.describe import load_description
from minparam_cli.errors import DescriptionError

FOURBAR = Path(__file__).resolve().parents[1] / "robots" / "fourbar_hybroblib.yaml"


def _fourbar(tmp_path, change) -> Path:
    doc = yaml.safe_load(FOURBAR.read_text())
    change(doc)
    p = tmp_path / "fourbar.yaml"
    p.write_text(yaml.safe_dump(doc, sort_keys=False))
    return p


def test_more_loop_cuts_than_joints_is_refused_at_once(tmp_path):
    """1000 copies of the four-bar's one cut: derive took 48 s and codegen over a minute before the refusal."""
    p = _fourbar(tmp_path, lambda d: d.__setitem__("loops", [{**d["loops"][0], "name": f"c{i}"} for i in range(1000)]))
    t0 = time.process_time()
    r = CliRunner().invoke(app, ["derive", str(p)])
    assert r.exit_code == 2 and len(r.stderr.strip().splitlines()) == 1, r.output
    assert "loops: 1000 loop-closing cuts for 3 joints: at most one cut per joint" in r.stderr
    assert time.process_time() - t0 < 2.0


def test_loop_cut_name_used_twice(tmp_path):
    p = _fourbar(tmp_path, lambda d: d["loops"].append(dict(d["loops"][0])))
    with pytest.raises(DescriptionError, match=r"loops\[2\]\.name: cut name 'coupler-rocker' is used twice"):
        load_description(p)
