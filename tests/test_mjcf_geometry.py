"""MJCF geoms -> each link's box, and the physical fit's ellipsoids from it (issue 31): the box in the
link frame against a hand computation (collision geoms preferred, a welded body's geom lumped in, a
joint anchor off the body origin), then identify --physical --prior none --mass-bounds on data
simulated from the file: every fitted body inside its link's ellipsoid (tr(J·Q) ≥ 0, here in numpy)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from conftest import cli_ok

pytest.importorskip("mujoco")
pytest.importorskip("cvxpy")

XML = (Path(__file__).parent / "data" / "mjcf" / "geoms_arm.xml").read_text()
H = 0.07 / math.sqrt(2)  # the tip's box (half-sizes 0.05, 0.02) turned by 45°: half-width (0.05 + 0.02)/√2 in x and y
BOXES = [("collision", (-0.05, -0.05, 0.0), (0.05, 0.05, 0.5)),
         ("collision", (-0.03, -H, -0.03), (0.4 + H, H, 0.03)),
         ("visual", (0.01, -0.04, -0.04), (0.09, 0.04, 0.04))]


def test_geoms_give_each_link_its_box(tmp_path):
    from minparam_cli.robot import DeriveOptions, load_chain

    (tmp_path / "geoms.xml").write_text(XML)
    _, chain = load_chain(tmp_path / "geoms.xml", DeriveOptions())
    for got, (kind, lo, hi) in zip(chain.link_geometry, BOXES, strict=True):
        assert got[0] == kind and np.allclose(got[1], lo, atol=1e-12) and np.allclose(got[2], hi, atol=1e-12), (got, lo, hi)


def _q(lo, hi) -> np.ndarray:
    """Q of the ellipsoid through the box's corners (semi-axes √3 times the half-widths), written out here."""
    lo, hi = np.array(lo), np.array(hi)
    c, Si = (lo + hi) / 2, np.diag(1 / (3 * ((hi - lo) / 2) ** 2))
    return np.block([[-Si, (Si @ c)[:, None]], [(Si @ c)[None, :], np.array([[1 - c @ Si @ c]])]])


def test_physical_fit_keeps_each_body_in_its_geoms_ellipsoid(tmp_path):
    import mujoco
    from test_physical_bounds import PARAMS, beyond_margin, pseudo_inertia

    robot, data, out = tmp_path / "geoms.xml", tmp_path / "d.csv", tmp_path / "fit.xml"
    robot.write_text(XML)
    cli_ok("simulate", robot, "--noise", 0.02, "--seed", 1, "-o", data, "-q")
    rep = json.loads(cli_ok("identify", robot, data, "--physical", "--prior", "none", "--mass-bounds", "0,10", "--no-diagnose",
                            "--export-mjcf", out, "-f", "json", "-q").output)["physical"]
    assert rep["prior"] == "none" and rep["geometry"] == ["collision", "visual"] and rep["not_fixed"] == []
    fitted = mujoco.MjModel.from_xml_path(str(out))
    masses = sorted(float(x) for x in fitted.body_mass[1:] if x > 0)
    for b, (_, lo, hi) in zip(rep["links"], BOXES, strict=True):
        J = pseudo_inertia([rep["phi"][f"{p}{b['link']}"] for p in PARAMS])
        scale = np.abs(J).max()
        assert np.linalg.eigvalsh(J)[0] >= -1e-7 * scale
        # the fit keeps the body beyond its margin ε inside: tr((J − ε·diag(L², L², L², 1))·Q) ≥ 0, L = 0.5 m (the robot's size, chain.length_scale)
        slack = np.sum(beyond_margin(J, 0.5, rep["margin_kg"]) * _q(lo, hi))
        assert slack >= -1e-7 * scale and slack == pytest.approx(b["ellipsoid"]["slack_kg"], rel=1e-6, abs=1e-9)
        assert 0 <= b["mass"] <= 10 + 1e-6
        assert any(abs(m - b["mass"]) < 1e-6 * max(1.0, b["mass"]) for m in masses)
