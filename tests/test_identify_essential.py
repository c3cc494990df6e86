"""identify --essential: Pham & Gautier's elimination of the base parameters the data do not determine."""

from __future__ import annotations

import json

import numpy as np
import uncertainty_data as ud
from typer.testing import CliRunner

from minparam_cli.cli.app import app
from minparam_cli.identify.stage import IdentifyOptions, identify
from minparam_cli.identify.assess.uncertainty import UncertaintyOptions


def _run(path, bound=10.0, kind="hac"):
    ch = ud.chain()
    return identify(ch, path, IdentifyOptions(diagnose=False, essential=bound, uncertainty=UncertaintyOptions(kind=kind)))[0].to_dict()


def test_parameters_that_are_zero_are_dropped_the_rest_kept(tmp_path):
    """planar2r's centres of mass lie on the link x axes: MY1 = MY2 = 0, so their relative σ are huge; every
    other base parameter and friction coefficient is well excited and stays, close to the truth."""
    path = ud.write(tmp_path / "w.csv", 40.0, 5, None, scale=0.05)
    rep = _run(path)
    e = rep["essential"]
    assert sorted(d["parameter"] for d in e["dropped"]) == ["MY1", "MY2"]
    assert set(e["parameters"]) == set(rep["parameters"]) - {"MY1", "MY2"}
    assert all(v["std_percent"] <= e["bound_percent"] for v in e["parameters"].values())
    assert all(d["std_percent"] > e["bound_percent"] and "largest relative σ" in d["why"] for d in e["dropped"])
    # dropped in decreasing order of relative σ at the time, each one the largest of those left
    assert e["condition_number"] <= e["condition_number_full"]
    for name, truth in (("Fc1", 0.3), ("Fv1", 0.5), ("Fc2", 0.3), ("Fv2", 0.5)):
        assert abs(e["parameters"][name]["value"] - truth) < 0.05 * truth
    # dropping parameters that are zero costs (almost) nothing on the test data
    assert e["error_data"] == "test1"
    assert e["error_after"]["rms_total"] <= 1.01 * e["error_before"]["rms_total"]


def test_reduced_fit_is_the_least_squares_fit_of_the_kept_columns(tmp_path):
    """Independent check: the essential values equal a weighted least-squares fit on the raw samples of the
    fit part with the dropped columns removed (regressor built directly, weights the report's σ_j)."""
    from minparam_cli.base.qr import derive_qr
    from minparam_cli.measured.records import Block
    from minparam_cli.identify.passes.design import Design

    path = ud.write(tmp_path / "c.csv", 40.0, 3, 2.0)
    rep = _run(path, bound=5.0)
    ch = ud.chain()
    base = derive_qr(ch, seed=0)
    d = Design(ch, base.kept, base.base_names)
    tab = np.loadtxt(path, delimiter=",", skiprows=1)
    t = tab[:, 0]
    fit = t < rep["roles"]["fit"][0]["time_s"][1]
    b = Block(t[fit], tab[fit, 1:3], tab[fit, 3:5], tab[fit, 5:7], tab[fit, 7:9])
    X = d.columns(b)
    names = list(d.names)
    keep = [names.index(k) for k in rep["essential"]["parameters"]]
    s = np.array(rep["sigma_per_joint"])
    A = np.vstack([X[:, j][:, keep] / s[j] for j in range(2)])
    y = np.concatenate([b.tau[:, j] / s[j] for j in range(2)])
    theta = np.linalg.lstsq(A, y, rcond=None)[0]
    got = np.array([v["value"] for v in rep["essential"]["parameters"].values()])
    assert np.allclose(got, theta, rtol=1e-6, atol=1e-9)
    assert rep["essential"]["dropped"]  # the coloured noise leaves some parameters above 5 %


def test_cli_essential_table_and_bad_bound(tmp_path):
    path = ud.write(tmp_path / "c.csv", 20.0, 1, 2.0)
    r = CliRunner().invoke(app, ["identify", ud.ROBOT, str(path), "--friction", "viscous,coulomb", "--no-diagnose", "--quiet", "--essential"])
    assert r.exit_code == 0, r.output
    assert "Essential parameters" in r.output and "dropped MY1" in r.output and "dropped MY2" in r.output
    r = CliRunner().invoke(app, ["identify", ud.ROBOT, str(path), "--no-diagnose", "--quiet", "--essential", "--essential-bound", "0"])
    assert r.exit_code == 2 and "--essential-bound" in r.output and len(r.output.strip().splitlines()) == 1
    r = CliRunner().invoke(app, ["identify", ud.ROBOT, str(path), "--friction", "viscous,coulomb", "--no-diagnose", "--quiet", "--essential", "-f", "json"])
    dropped = [d["parameter"] for d in json.loads(r.output)["essential"]["dropped"]]
    assert {"MY1", "MY2"} <= set(dropped)
