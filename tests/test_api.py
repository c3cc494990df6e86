"""The Python API as a user scripts against it: arrays and DataFrames in, the same numbers as files;
no printing; the project's errors with the CLI's words; warnings through ``warnings``; regressor
identities; the identified model's predictions and its file round trip."""

from __future__ import annotations

import dataclasses
import subprocess
import sys

import numpy as np
import pytest
from conftest import ROOT
from typer.testing import CliRunner

import minparam
from minparam_cli.cli.app import app

ROBOT = "robots/planar2r.yaml"


@pytest.fixture(scope="module")
def sim():
    return minparam.simulate(ROOT / ROBOT, effects="viscous", noise=0.02, duration=5, seed=7)


def figures(r: minparam.Identification) -> dict:
    d = r.to_dict()
    return {k: d[k] for k in ("parameters", "steps", "before", "after", "samples_used", "sigma_per_joint")}


def test_identify_from_arrays_equals_the_npz_file(sim, tmp_path):
    np.savez(tmp_path / "d.npz", **sim.arrays())
    from_file = minparam.identify(ROBOT, tmp_path / "d.npz", diagnose=False)
    from_arrays = minparam.identify(ROBOT, sim.arrays(), diagnose=False)
    assert figures(from_arrays) == figures(from_file)
    renamed = {"time": sim.t, "pos": sim.q, "vel": sim.dq, "acc": sim.ddq, "effort": sim.tau}
    from_renamed = minparam.identify(ROBOT, renamed, diagnose=False,
                                     columns={"t": "time", "q": "pos", "dq": "vel", "ddq": "acc", "tau": "effort"})
    assert figures(from_renamed) == figures(from_file)
    assert from_arrays.to_dict()["data"] == "<data>"
    np.testing.assert_array_equal(from_arrays.theta, from_file.theta)


def test_identify_from_a_dataframe_equals_the_csv_file(sim, tmp_path):
    pd = pytest.importorskip("pandas")
    n = sim.q.shape[1]
    cols = {"t": sim.t}
    for key in ("q", "dq", "ddq", "tau"):
        for j in range(n):
            cols[f"{key}{j + 1}"] = getattr(sim, key)[:, j]
    frame = pd.DataFrame(cols)
    (tmp_path / "d.csv").write_text(",".join(frame.columns) + "\n" + "\n".join(
        ",".join(map(repr, row)) for row in frame.to_numpy().tolist()) + "\n")
    from_csv = minparam.identify(ROBOT, tmp_path / "d.csv", diagnose=False)
    from_frame = minparam.identify(ROBOT, frame, diagnose=False)
    from_columns = minparam.identify(ROBOT, cols, diagnose=False)  # a dict of CSV-style columns
    assert figures(from_frame) == figures(from_csv) == figures(from_columns)


def test_pandas_is_not_imported_for_arrays():
    code = ("import sys, minparam\n"
            f"s = minparam.simulate({str(ROBOT)!r}, duration=3, seed=1)\n"
            f"minparam.identify({str(ROBOT)!r}, s.arrays(), diagnose=False)\n"
            "assert 'pandas' not in sys.modules, 'pandas imported'\n")
    r = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                       env={**__import__("os").environ, "PYTHONPATH": str(ROOT / "src")})
    assert r.returncode == 0, r.stderr


def test_import_minparam_loads_no_heavy_library():
    """The start-up promise (benchmarks/bench_startup.py times it): re-exports only, numpy and the CLI's
    libraries load when a call needs them."""
    code = ("import sys, minparam\n"
            "print(sorted(m for m in ('numpy', 'scipy', 'sympy', 'typer', 'click', 'yaml', 'pandas', 'matplotlib')"
            " if m in sys.modules))\n")
    r = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                       env={**__import__("os").environ, "PYTHONPATH": str(ROOT / "src")})
    assert r.returncode == 0 and r.stdout.strip() == "[]", r.stdout + r.stderr


def test_library_calls_print_nothing(sim, capsys):
    minparam.derive(ROBOT)
    minparam.identify(ROBOT, sim.arrays(), diagnose=False, progress=False)
    minparam.singular("robots/ur5.yaml", [0.1, -0.5, 0.7, 0.3, 0.2, 0.1])
    out, err = capsys.readouterr()
    assert out == "" and err == ""


def test_notes_are_warnings_not_prints(capsys):
    # planar3r.yaml gives no inertial values: simulate uses random ones and says so
    with pytest.warns(minparam.MinparamWarning, match="does not give inertial data"):
        minparam.simulate("robots/planar3r.yaml", duration=1)
    assert capsys.readouterr() == ("", "")


def cli_error(*args) -> str:
    r = CliRunner().invoke(app, [str(a) for a in args])
    assert r.exit_code == 2, r.output
    line = r.stderr.strip()
    assert line.startswith("minparam: error: ")
    return line[len("minparam: error: "):]


def test_bad_robot_file_raises_the_cli_message(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\nconvention: dh\njoints:\n  - {type: revolute, a: 1, alpha: 0}\n")
    with pytest.raises(minparam.DescriptionError) as e:
        minparam.derive(bad)
    assert str(e.value) == cli_error("derive", bad)
    with pytest.raises(minparam.InputError) as e:
        minparam.derive(tmp_path / "missing.yaml")
    assert str(e.value) == cli_error("derive", tmp_path / "missing.yaml")


def test_bad_arrays_raise_data_errors(sim):
    arrays = sim.arrays()
    with pytest.raises(minparam.DataError, match=r"<data>: missing array 'tau'"):
        minparam.identify(ROBOT, {k: v for k, v in arrays.items() if k != "tau"})
    with pytest.raises(minparam.DataError, match=r"the data have 3 joints .* the robot has 2"):
        minparam.identify(ROBOT, {**arrays, "tau": np.hstack([arrays["tau"], arrays["tau"][:, :1]])})
    with pytest.raises(minparam.InputError, match="data: expected a file path, a mapping of arrays or a pandas DataFrame"):
        minparam.identify(ROBOT, [1, 2, 3])


def test_bad_options_raise_input_errors():
    with pytest.raises(minparam.InputError, match="unknown friction kind 'dry'"):
        minparam.derive(ROBOT, friction="coulomb,dry")
    with pytest.raises(minparam.InputError, match="method: 'svd' is not one of"):
        minparam.derive(ROBOT, method="svd")
    with pytest.raises(minparam.InputError, match="split"):
        minparam.identify(ROBOT, "x.csv", split=(0, 0.5, 0.5))


def test_regressor_identities(sim):
    robot = minparam.load_robot(ROBOT)
    phi = robot.chain.phi_nominal
    base = minparam.derive(robot)
    Y = minparam.regressor(robot, sim.q, sim.dq, sim.ddq, base=False)
    Yb = minparam.regressor(robot, sim.q, sim.dq, sim.ddq, base=base)
    assert Y.shape == (len(sim.t), 2, 20) and Yb.shape == (len(sim.t), 2, base.n_base)
    tau = Y @ phi
    # the full model and the base model give the same torque (base = K phi)
    np.testing.assert_allclose(Yb @ (base.K @ phi), tau, rtol=1e-9, atol=1e-9 * np.abs(tau).max())
    # and the torque the simulation computed, less its injected viscous friction and noise
    rigid = minparam.simulate(ROOT / ROBOT, duration=5, seed=7)
    np.testing.assert_allclose(Y @ phi, rigid.tau, rtol=1e-9, atol=1e-9 * np.abs(tau).max())
    # one sample: (dof, P)
    assert minparam.regressor(robot, sim.q[0], sim.dq[0], sim.ddq[0]).shape == (2, base.n_base)
    with pytest.raises(minparam.InputError, match=r"dq: expected shape \(N, 2\)"):
        minparam.regressor(robot, sim.q, sim.dq[:, :1], sim.ddq)


def test_identified_model_predicts_and_round_trips(sim, tmp_path):
    result = minparam.identify(ROBOT, sim.arrays(), friction="viscous", diagnose=False)
    pred = result.predict(sim.q, sim.dq, sim.ddq)
    noise_free = minparam.simulate(ROOT / ROBOT, effects="viscous", duration=5, seed=7).tau
    rel = np.linalg.norm(pred - noise_free) / np.linalg.norm(noise_free)
    assert rel < 0.01, rel  # noise σ 0.02 N·m on torques of several N·m
    assert set(result.parameters) >= {"Fv1", "Fv2"}
    result.model.save(tmp_path / "model.json")
    loaded = minparam.Model.load(tmp_path / "model.json")
    np.testing.assert_array_equal(loaded.predict(sim.q, sim.dq, sim.ddq), pred)
    assert loaded.to_dict() == result.model.to_dict()


def test_results_are_frozen():
    b = minparam.derive(ROBOT)
    with pytest.raises(AttributeError):
        b.names = ()  # type: ignore[misc]
    d = b.to_dict()
    d["n_base"] = -1
    assert b.to_dict()["n_base"] == b.n_base == 6


def test_selection_and_test_data_from_arrays(sim):
    n = len(sim.t)
    parts = [{k: v[s] for k, v in sim.arrays().items()} for s in (slice(0, n // 2), slice(n // 2, 3 * n // 4),
                                                                  slice(3 * n // 4, n))]
    r = minparam.identify(ROBOT, parts[0], validate=parts[1], test=parts[2], diagnose=False)
    d = r.to_dict()
    assert (d["data"], d["validate"], d["test_files"]) == ("<data>", "<validate>", ["<test1>"])
    assert d["samples_test"] == n - 3 * n // 4 and r.test is not None
    # the same test data evaluated with the model give the identify report's test figures
    ev = minparam.evaluate(r.model, parts[2])
    assert ev.pooled is not None
    assert ev.pooled.rms_per_joint == pytest.approx(r.test.rms_per_joint, rel=1e-9)


def test_progress_true_draws_only_on_a_terminal(capsys):
    minparam.derive(ROBOT, method="projection", progress=True)  # stderr is not a terminal here: silent
    calls = []
    minparam.derive(ROBOT, method="projection", progress=lambda done, total: calls.append((done, total)))
    assert calls and capsys.readouterr() == ("", "")


EXCITE_FAST = {"harmonics": 3, "rate": 50, "starts": 2, "max_iterations": 20}
EXCITE_FLAGS = ["--harmonics", "3", "--rate", "50", "--starts", "2", "--max-iterations", "20", "-q"]


def usage_error(*args) -> str:
    """click's one-line usage error of the CLI (exit 2), e.g. 'Invalid value for --box: ...'."""
    r = CliRunner().invoke(app, [str(a) for a in args])
    assert r.exit_code == 2 and "Invalid value for" in r.stderr, r.output
    return r.stderr.strip()


@pytest.mark.parametrize("kw,flags", [
    ({"harmonics": 0}, ["--harmonics", "0"]),
    ({"rest": True, "harmonics": 1}, ["--rest", "--harmonics", "1"]),
    ({"harmonics": 30, "rate": 5}, ["--harmonics", "30", "--rate", "5"]),
    ({"margin": 0.5}, ["--margin", "0.5"]),
    ({"seed": -1}, ["--seed", "-1"]),
    ({"box": [[1, 0], [None, None], [None, None]]}, ["--box", "1:0,:,:"]),
])
def test_excite_bad_options_raise_the_cli_message(kw, flags):
    with pytest.raises(minparam.InputError) as e:
        minparam.excite(ROBOT, **{**EXCITE_FAST, **kw})
    if kw.get("seed", 0) < 0:  # the CLI's option type refuses it before the command runs
        assert "-1" in usage_error("excite", ROBOT, *EXCITE_FLAGS, *flags) and str(e.value) == "--seed must be >= 0, got -1"
    else:
        assert str(e.value) == cli_error("excite", ROBOT, *EXCITE_FLAGS, *flags)


@pytest.mark.parametrize("kw,flags,option", [
    ({"friction": "coulomb,dry"}, ["--friction", "coulomb,dry"], "--friction"),
    ({"box": ":,:,:"}, ["--box", ":,:,:"], "--box"),
    ({"box": "0:1,:,:x"}, ["--box", "0:1,:,:x"], "--box"),
    ({"box": [[0, 1], [0, 1]]}, None, "--box"),
    ({"box": [[0, 1]], "point": None}, None, "--box"),
    ({"point": (1, 2)}, ["--point", "1,2"], "--point"),
])
def test_excite_bad_option_values_name_the_option(kw, flags, option):
    with pytest.raises(minparam.InputError) as e:
        minparam.excite(ROBOT, **{**EXCITE_FAST, **kw})
    assert str(e.value).startswith(f"{option}: ")
    if flags is not None:  # the same words as the CLI's usage error
        assert str(e.value)[len(option) + 2:] in usage_error("excite", ROBOT, *EXCITE_FLAGS, *flags)


def test_excite_prints_nothing_and_warns(capsys):
    with pytest.warns(minparam.MinparamWarning) as rec:
        r = minparam.excite(ROBOT, **EXCITE_FAST)
    messages = [str(w.message) for w in rec]
    assert len(messages) == 2 and "gives no position limits for joint(s) 1, 2" in messages[0]
    assert "no velocity or acceleration limits" in messages[1]
    assert capsys.readouterr() == ("", "")
    # the samples are the series' exact values, and the design beats its own start
    q, dq, ddq = r.evaluate(r.t)
    np.testing.assert_allclose(np.hstack([q, dq, ddq]), np.hstack([r.q, r.dq, r.ddq]), rtol=0, atol=1e-12)
    starts = r.to_dict()["starts"]
    assert r.criterion <= starts[r.to_dict()["best_start"] - 1]["start"]
    with pytest.raises(dataclasses.FrozenInstanceError):
        r.seed = 3  # type: ignore[misc]


def test_codegen_bad_inputs_raise_the_cli_message(tmp_path):
    with pytest.raises(minparam.InputError) as e:
        minparam.codegen(ROBOT, "python", parameters="fit")
    assert str(e.value) == cli_error("codegen", ROBOT, "--lang", "python", "--parameters", "fit")
    with pytest.raises(minparam.InputError) as e:
        minparam.codegen(tmp_path / "missing.yaml", "python")
    assert str(e.value) == f"{tmp_path / 'missing.yaml'}: no such file or folder"
    with pytest.raises(minparam.InputError, match=r"--lang: 'fortran' is not one of 'c', 'python', 'casadi'"):
        minparam.codegen(ROBOT, "fortran")
    with pytest.raises(minparam.InputError) as e:
        minparam.codegen(ROBOT, "python", samples=0)
    assert str(e.value) == "--samples: must be positive"
    assert "must be positive" in usage_error("codegen", ROBOT, "--lang", "python", "--samples", "0")
    with pytest.raises(minparam.InputError) as e:
        minparam.codegen(ROBOT, "c", output=tmp_path / "x.c", name="bad name")
    assert str(e.value) == "--name: must be a C identifier (letters, digits, _), e.g. bad_name"
    with pytest.raises(minparam.InputError, match="--gravity: expected 3 comma-separated numbers, got 2"):
        minparam.codegen(ROBOT, "python", gravity=(0, -9.81))
    with pytest.raises(minparam.InputError, match="model: expected a model file path"):
        minparam.codegen(ROBOT, "python", model=3)


def test_codegen_with_a_model_refuses_other_settings(tmp_path):
    s = minparam.simulate(ROBOT, duration=3, seed=1)
    minparam.identify(ROBOT, s.arrays(), diagnose=False).model.save(tmp_path / "m.json")  # type: ignore[union-attr]
    with pytest.raises(minparam.InputError) as e:
        minparam.codegen(ROBOT, "python", model=tmp_path / "m.json", friction="coulomb")
    assert str(e.value) == cli_error("codegen", ROBOT, "--lang", "python", "--model", tmp_path / "m.json", "--friction", "coulomb")
    with pytest.raises(minparam.InputError) as e:  # a model made for another robot file
        minparam.codegen("robots/planar3r.yaml", "python", model=tmp_path / "m.json")
    assert str(e.value) == cli_error("codegen", "robots/planar3r.yaml", "--lang", "python", "--model", tmp_path / "m.json")


def test_generated_c_is_written_only_under_its_header_name(tmp_path, capsys):
    code = minparam.codegen(ROBOT, "c", output=tmp_path / "arm.c")
    assert '#include "arm.h"' in code.source and code.header is not None
    with pytest.raises(minparam.InputError, match="includes arm.h"):
        code.write(tmp_path / "other.c")
    with pytest.raises(minparam.InputError, match="give a path"):
        minparam.codegen(ROBOT, "python").write()
    assert sorted(p.name for p in code.write()) == ["arm.c", "arm.h"]
    assert (tmp_path / "arm.h").read_text() == code.header
    assert capsys.readouterr() == ("", "")


def test_codegen_takes_a_robots_own_options():
    robot = minparam.load_robot(ROBOT, friction="coulomb,viscous", gravity=(0, -9.81, 0))
    code = minparam.codegen(robot, "python")
    assert code.source == minparam.codegen(ROBOT, "python", friction="coulomb,viscous", gravity="0,-9.81,0").source
    assert code.base_names == minparam.derive(robot).names and "Fv2" in code.base_names
