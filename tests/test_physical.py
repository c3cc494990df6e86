"""identify --physical: the convex fit over the full parameters (pseudo-inertia ⪰ 0 per link)."""

from __future__ import annotations

import json
import sys

import numpy as np
import pytest
from conftest import SHARED, cli, cli_ok

pytest.importorskip("cvxpy")

PANDA_CSV = SHARED / "data" / "panda-gaz2019" / "panda_exciting_traj_1.csv"


def base_truth(robot: str, phi: np.ndarray) -> dict:
    """The base parameters K·φ of the derive stage, for the true standard parameters."""
    from minparam_cli.base.qr import derive_qr
    from minparam_cli.robot import DeriveOptions, load_chain

    _, chain = load_chain(f"robots/{robot}", DeriveOptions())
    base = derive_qr(chain, seed=0)
    return dict(zip(base.base_names, base.K @ phi, strict=True))


def consistent(links: list[dict], tol: float = 1e-9) -> bool:
    return all(b["pseudo_inertia_min_eig"] > -tol and b["triangle_margin"] > -tol and b["mass"] > 0
               and min(b["principal_moments"]) > -tol for b in links)


@pytest.mark.parametrize("robot, seed", [("puma560_mdh.yaml", 1), ("panda.yaml", 2), ("ur5.yaml", 3)])
def test_random_consistent_bodies_are_recovered_within_3_sigma(tmp_path, robot, seed):
    """Data from random physically consistent bodies (simulate --random-inertia): the physical fit's
    base parameters K·φ lie within 3σ of the truth (σ of the unconstrained fit), every link it returns
    is a body, and its test error equals the unconstrained one to 1 %.  The consistency constraint
    alone: no prior (the description's inertials are not these random bodies) and no ellipsoids (random
    bodies need not lie around the links' segments)."""
    data, truth = tmp_path / "d.csv", tmp_path / "t.json"
    cli_ok("simulate", f"robots/{robot}", "--random-inertia", "--noise", 0.01, "--seed", seed, "-o", data, "--truth", truth, "-q")
    rep = json.loads(cli_ok("identify", f"robots/{robot}", data, "--physical", "--prior", "none", "--geometry", "none",
                            "--no-diagnose", "-f", "json", "-q").output)
    true = base_truth(robot, np.asarray(json.loads(truth.read_text())["phi"]))
    phys = rep["physical"]
    assert phys["status"] == "optimal" and consistent(phys["links"])
    # the constraint costs nothing when the truth is a body: every base parameter is within 3σ of the
    # truth, or no farther from it than the unconstrained estimate plus 0.1σ (with 40-odd parameters, a
    # least-squares estimate beyond 3σ happens by chance: seed 2 of the Panda puts ZZR1 at 3.8σ)
    z = []
    for name, v in rep["parameters"].items():
        sigma = abs(v["value"]) * v["std_percent"] / 100
        err_phys, err_ls = abs(phys["base_parameters"][name] - true[name]), abs(v["value"] - true[name])
        assert err_phys <= max(3 * sigma, err_ls + 0.1 * sigma), name
        z.append(err_ls / sigma)
    assert len(z) == len(true) and np.sqrt(np.mean(np.square(z))) < 1.5  # and the σ are honest here
    assert abs(phys["test"]["test1"]["relative_error"] / rep["test"]["final"]["relative_error"] - 1) < 0.01


def test_torques_no_body_can_make_are_not_fitted_with_impossible_bodies(tmp_path):
    """Torques made with ZZ6 < 0 (link 6's inertia about its own axis, a base parameter of its own):
    no mass distribution has that, so the unconstrained fit reproduces the data and the physical fit
    returns real bodies only and pays for it on joint 6."""
    from minparam_cli.experiment.simulate import rigid_torque, simulate
    from minparam_cli.experiment.simulate_spec import SimulationOptions
    from minparam_cli.robot import DeriveOptions, load_chain

    _, chain = load_chain("robots/puma560_mdh.yaml", DeriveOptions())
    phi = np.array(chain.phi_nominal, dtype=float)
    phi[chain.layout.names.index("ZZ6")] = -0.002
    sim = simulate(chain, SimulationOptions(), np.random.default_rng(4))
    tau = rigid_torque(chain, sim.q, sim.dq, sim.ddq, phi) + np.random.default_rng(5).normal(0, 0.001, sim.q.shape)
    header = ["t"] + [f"{k}{j}" for k in ("q", "dq", "ddq", "tau") for j in range(1, 7)]
    path = tmp_path / "no_body.csv"
    np.savetxt(path, np.column_stack([sim.t, sim.q, sim.dq, sim.ddq, tau]), delimiter=",", header=",".join(header), comments="")
    rep = json.loads(cli_ok("identify", "robots/puma560_mdh.yaml", path, "--physical", "--no-diagnose", "-f", "json", "-q").output)
    assert rep["parameters"]["ZZ6"]["value"] < -0.0015  # least squares finds the impossible value
    phys = rep["physical"]
    assert consistent(phys["links"]) and phys["phi"]["ZZ6"] >= 0
    assert phys["test"]["test1"]["rms_per_joint"][5] > 3 * rep["test"]["final"]["rms_per_joint"][5]


def test_the_prior_holds_what_the_data_do_not_inform(tmp_path):
    """Only joint 1 moves: most directions of the outer links' parameters are not in the data.  Without a
    prior that is poor excitation (exit 1); with --prior nominal the fit succeeds, link 6's inertia stays
    at the description's values, and the report counts the directions the data set per link."""
    from minparam_cli.experiment.simulate import rigid_torque, simulate
    from minparam_cli.experiment.simulate_spec import SimulationOptions
    from minparam_cli.robot import DeriveOptions, load_chain

    _, chain = load_chain("robots/puma560_mdh.yaml", DeriveOptions())
    sim = simulate(chain, SimulationOptions(noise=0.0), np.random.default_rng(6))
    q, dq, ddq = sim.q.copy(), sim.dq.copy(), sim.ddq.copy()
    for j in (1, 2, 3, 4, 5):
        q[:, j], dq[:, j], ddq[:, j] = q[0, j], 0.0, 0.0
    tau = rigid_torque(chain, q, dq, ddq, sim.phi) + np.random.default_rng(7).normal(0, 0.01, q.shape)
    header = ["t"] + [f"{k}{j}" for k in ("q", "dq", "ddq", "tau") for j in range(1, 7)]
    path = tmp_path / "frozen.csv"
    np.savetxt(path, np.column_stack([sim.t, q, dq, ddq, tau]), delimiter=",", header=",".join(header), comments="")
    bad = cli("identify", "robots/puma560_mdh.yaml", path, "--no-diagnose")
    assert bad.exit_code == 1 and "joints 2, 3, 4, 5, 6 barely moved" in bad.output  # no prior: poor excitation
    reps = {w: json.loads(cli_ok("identify", "robots/puma560_mdh.yaml", path, "--physical", "--prior", "nominal",
                                 "--prior-weight", w, "--no-diagnose", "-f", "json", "-q").output) for w in ("1e-4", "1e-2")}
    for rep in reps.values():
        phys = rep["physical"]
        assert consistent(phys["links"])
        informed = [b["informed_directions"] for b in phys["links"]]
        assert max(informed) < 10 and min(informed) >= 0  # no link fully set by one joint's motion
        assert set(phys["partly_informed"] + phys["not_informed"]) == set(range(1, 7))
        # the prior only holds what the data leave open: the test error is the unconstrained fit's
        assert phys["test"]["test1"]["rms_total"] <= 1.05 * rep["test"]["final"]["rms_total"]
    # a heavier prior holds the parameters nearer the description's
    assert reps["1e-2"]["physical"]["prior_cost"] < 0.5 * reps["1e-4"]["physical"]["prior_cost"]


@pytest.mark.skipif(not PANDA_CSV.exists(), reason="../shared/data/panda-gaz2019 is absent (GPL data, not shipped)")
def test_panda_physical_costs_at_most_10_percent_test_error():
    """Issue 13, point 4: on the real Panda recording, the physical fit with the same effects is within
    10 % of the unconstrained fit on the test data, and every link is a body."""
    rep = json.loads(cli_ok("identify", "robots/panda.yaml", PANDA_CSV, "--physical", "-f", "json", "-q").output)
    phys = rep["physical"]
    assert consistent(phys["links"])
    assert phys["test"]["test1"]["relative_error"] <= 1.10 * rep["test"]["final"]["relative_error"]


@pytest.mark.parametrize("args, needle", [
    (["--prior", "nominal"], "needs --physical"),
    (["--physical", "--prior-weight", "-1"], "positive"),
    (["--physical", "--prior", "nominal", "--robot-scara"], None),
])
def test_bad_physical_options(tmp_path, args, needle):
    if needle is None:  # the SCARA description has no inertial values to pull toward
        data = tmp_path / "p.csv"
        cli_ok("simulate", "robots/scara.yaml", "--random-inertia", "-o", data, "-q", "--seed", 1)
        r = cli("identify", "robots/scara.yaml", data, "--physical", "--prior", "nominal")
        assert r.exit_code == 2 and "no inertial values" in r.output and len(r.output.strip().splitlines()) == 1
        return
    data = tmp_path / "d.csv"
    cli_ok("simulate", "robots/planar2r.yaml", "-o", data, "-q")
    r = cli("identify", "robots/planar2r.yaml", data, *args)
    assert r.exit_code == 2 and needle in r.output


def test_missing_cvxpy_is_one_line_naming_the_extra(tmp_path, monkeypatch):
    data = tmp_path / "d.csv"
    cli_ok("simulate", "robots/planar2r.yaml", "-o", data, "-q")
    monkeypatch.setitem(sys.modules, "cvxpy", None)  # import cvxpy now raises ImportError
    r = cli("identify", "robots/planar2r.yaml", data, "--physical", "--no-diagnose")
    assert r.exit_code == 2 and "pip install 'minparam[physical]'" in r.output
    assert len(r.output.strip().splitlines()) == 1
