"""Shared fixtures: the robot files shipped in robots/."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
ROBOTS = ROOT / "robots"
SHARED = ROOT.parent / "shared"
sys.path.insert(0, str(Path(__file__).resolve().parent))


def robot_files() -> list[Path]:
    """Every robot description in robots/ (platform descriptions excluded)."""
    out = []
    for p in sorted(ROBOTS.iterdir()):
        if p.suffix in (".yaml", ".yml"):
            doc = yaml.safe_load(p.read_text())
            if isinstance(doc, dict) and doc.get("kind", "robot") != "robot":
                continue
            out.append(p)
        elif p.suffix == ".urdf":
            out.append(p)
    return out


ROBOT_FILES = robot_files()
ROBOT_IDS = [p.name for p in ROBOT_FILES]


@pytest.fixture(params=ROBOT_FILES, ids=ROBOT_IDS)
def robot_path(request) -> Path:
    return request.param


@pytest.fixture(autouse=True)
def _run_from_repository_root(monkeypatch):
    """Tests name robot files relative to the repository root."""
    monkeypatch.chdir(ROOT)
