"""The Python API and the CLI cannot drift: for every command, the API result's ``to_dict()`` equals
the JSON the command prints for the same call (run through the real entry point), timings aside."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

import minparam
from minparam_cli.cli.app import app

ROBOT = "robots/planar2r.yaml"
PLATFORM = "robots/dodekapod_dang2013.yaml"
LENGTHS = [238.6357, 269.3776, 256.0046, 247.4046, 185.4388, 190.2705]  # Dang 2013 example (docs/platform.md)


def cli_json(*args, jsonl: bool = False):
    r = CliRunner().invoke(app, [str(a) for a in args])
    assert r.exit_code == 0, r.output
    if jsonl:
        return [json.loads(line) for line in r.stdout.splitlines() if line.strip()]
    return json.loads(r.stdout)


TIMINGS = ("elapsed_s", "cpu_s", "exact_s")


def untimed(x):
    """The report without its wall-clock and CPU-time fields (elapsed_s, cpu_s, and the symbolic
    verification's exact_s), the only values two runs may not share."""
    if isinstance(x, dict):
        return {k: untimed(v) for k, v in x.items() if k not in TIMINGS}
    if isinstance(x, list):
        return [untimed(v) for v in x]
    return x


def same(api: dict, cli: dict) -> None:
    # through JSON, as the CLI writes it: tuples become lists, NaN stays NaN (compared as text)
    assert json.dumps(untimed(api), sort_keys=True) == json.dumps(untimed(cli), sort_keys=True)


@pytest.fixture(scope="module")
def sim_files(tmp_path_factory):
    """A short simulated record of the planar 2R with friction (CSV, truth), and the CLI's identify report
    and model file on it."""
    d = tmp_path_factory.mktemp("api_cli")
    from conftest import ROOT

    robot = ROOT / ROBOT
    r = CliRunner().invoke(app, ["simulate", str(robot), "--effects", "coulomb,viscous", "--noise", "0.05",
                                 "--duration", "5", "--seed", "3", "-o", str(d / "sim.csv"), "--truth",
                                 str(d / "truth.json"), "-q"])
    assert r.exit_code == 0, r.output
    report = cli_json("identify", robot, d / "sim.csv", "-f", "json", "--save-model", d / "m.json")
    return robot, d, report


def test_derive(tmp_path):
    for kw, flags in (({}, []), ({"method": "projection", "friction": "coulomb,viscous", "rotor_inertia": True},
                                 ["--method", "projection", "--friction", "coulomb,viscous", "--rotor-inertia"])):
        api = minparam.derive(ROBOT, **kw)
        same(api.to_dict(), cli_json("derive", ROBOT, "-f", "json", *flags))


def test_derive_symbolic():
    api = minparam.derive(ROBOT, symbolic=True)
    same(api.to_dict(), cli_json("derive", ROBOT, "--symbolic", "-f", "json"))
    assert "ZZ2 - a2**2*M2" in api.expressions  # geometry symbols where derive(ROBOT) has 0.64 = 0.8²


def test_derive_symbolic_numbers():
    api = minparam.derive("benchmarks/data/symbolic/oblique_axis.urdf", symbolic_numbers=True)
    cli = cli_json("derive", "benchmarks/data/symbolic/oblique_axis.urdf", "--symbolic-numbers", "-f", "json")
    same(api.to_dict(), cli)
    assert cli["symbolic_numbers"] == ["j2_axis_phi", "j2_x", "j2_z"] and set(cli["symbols"]) == {"g"}


def test_check():
    api = minparam.check("robots/puma560_mdh.yaml")
    (cli,) = cli_json("check", "robots/puma560_mdh.yaml", "--json", jsonl=True)
    same(api.to_dict(), cli)


def test_simulate(sim_files):
    robot, d, _ = sim_files
    api = minparam.simulate(robot, effects="coulomb,viscous", noise=0.05, duration=5, seed=3)
    same(api.to_dict(), json.loads((d / "truth.json").read_text()))
    table = np.loadtxt(d / "sim.csv", delimiter=",", skiprows=1)
    n = api.q.shape[1]
    np.testing.assert_array_equal(table, np.hstack([api.t[:, None], api.q, api.dq, api.ddq, api.tau]))
    assert table.shape[1] == 1 + 4 * n


def test_simulate_motor_side_payload_and_given_trajectory(tmp_path):
    """The options beyond the joint-side defaults map one to one too: motor-side currents through a
    coupled transmission with motor friction, a payload, and a given excite trajectory."""
    import yaml
    from conftest import ROBOTS

    doc = yaml.safe_load((ROBOTS / "puma560_mdh.yaml").read_text())
    doc["transmission"] = {"ratios": [62.6, 107.8, 53.7, 76.0, 71.9, 76.7], "coupling": [[6, 5, 13.25]],
                           "drive_gains": [0.8, 0.9, 1.1, 0.7, 1.3, 0.6], "motor_friction": ["coulomb", "viscous"]}
    robot = tmp_path / "puma.yaml"
    robot.write_text(yaml.safe_dump(doc))
    traj = tmp_path / "traj.csv"
    r = CliRunner().invoke(app, ["excite", str(robot), "--harmonics", "2", "--starts", "1", "--max-iterations", "5",
                                 "-o", str(traj), "--json", str(tmp_path / "traj.json"), "-q"])
    assert r.exit_code == 0, r.output
    given = str(tmp_path / "traj.json")
    flags = ["--side", "motor", "--current", "--motor-params", "Fcm6=0.06,Fvm6=0.0006", "--payload-mass", "2.8",
             "--payload-com", "0.02,-0.01,0.05", "--noise", "0.01", "--duration", "2", "--seed", "5", "--trajectory", given]
    r = CliRunner().invoke(app, ["simulate", str(robot), *flags, "-o", str(tmp_path / "m.csv"),
                                 "--truth", str(tmp_path / "t.json"), "-q"])
    assert r.exit_code == 0, r.output
    api = minparam.simulate(robot, side="motor", current=True, motor_params={"Fcm6": 0.06, "Fvm6": 0.0006},
                            payload_mass=2.8, payload_com=(0.02, -0.01, 0.05), noise=0.01, duration=2, seed=5,
                            trajectory=given)
    cli_truth = json.loads((tmp_path / "t.json").read_text())
    same(api.to_dict(), cli_truth)
    assert cli_truth["motor_side"]["current"] is True and cli_truth["payload"]["mass"] == 2.8
    table = np.loadtxt(tmp_path / "m.csv", delimiter=",", skiprows=1)
    np.testing.assert_array_equal(table, np.hstack([api.t[:, None], api.q, api.dq, api.ddq, api.tau]))
    # and the API refuses what the CLI refuses, in the same words
    r = CliRunner().invoke(app, ["simulate", str(robot), "--current", "-o", str(tmp_path / "x.csv")])
    assert r.exit_code == 2
    with pytest.raises(minparam.InputError) as e:
        minparam.simulate(robot, current=True)
    assert str(e.value) in r.output


def test_identify_and_model_file(sim_files):
    robot, d, cli = sim_files
    api = minparam.identify(robot, d / "sim.csv")
    same(api.to_dict(), cli)
    assert api.model is not None
    same(api.model.to_dict(), json.loads((d / "m.json").read_text()))


def test_identify_with_options(sim_files):
    """Options map one to one: a run with non-default ones gives the CLI's report too."""
    robot, d, _ = sim_files
    cli = cli_json("identify", robot, d / "sim.csv", "-f", "json", "--no-diagnose", "--friction", "coulomb,viscous",
                   "--split", "0.5,0.3,0.2", "--ols", "--cutoff", "8", "--filter", "--seed", "2", "--gravity", "0,-9.8,0")
    api = minparam.identify(robot, d / "sim.csv", diagnose=False, friction=["coulomb", "viscous"], split=(0.5, 0.3, 0.2),
                            ols=True, cutoff=8, filter=True, seed=2, gravity=(0, -9.8, 0))
    same(api.to_dict(), cli)
    assert api.to_dict()["method"] == "ols" and "Fv2" in api.parameters


def test_identify_uncertainty_options(sim_files):
    """The σ kind, its block length and the essential reduction map one to one as well."""
    robot, d, _ = sim_files
    cli = cli_json("identify", robot, d / "sim.csv", "-f", "json", "--no-diagnose", "--sigma", "bootstrap",
                   "--block-length", "2", "--replicates", "50", "--essential", "--essential-bound", "20")
    api = minparam.identify(robot, d / "sim.csv", diagnose=False, sigma="bootstrap", block_length=2, replicates=50,
                            essential=20)
    same(api.to_dict(), cli)
    assert api.to_dict()["sigma"]["kind"] == "bootstrap" and "essential" in api.to_dict()


def test_evaluate(sim_files):
    robot, d, _ = sim_files
    cli = cli_json("evaluate", d / "m.json", d / "sim.csv", "-f", "json")
    api = minparam.evaluate(d / "m.json", d / "sim.csv")
    same(api.to_dict(), cli)
    # Model.load gives the same model; evaluated as an object it names itself <model>, nothing else changes
    loaded = minparam.Model.load(d / "m.json")
    again = minparam.evaluate(loaded, d / "sim.csv").to_dict()
    assert again.pop("model_file") == "<model>"
    cli.pop("model_file")
    same(again, cli)


def test_singular():
    q_deg = [10, -30, 40, 20, 0, 15]
    twist = [0.1, 0.2, 0.3, 0.1, 0.1, 0.1]
    cli = cli_json("singular", "robots/ur5.yaml", "--q", ",".join(map(str, q_deg)), "--twist",
                   ",".join(map(str, twist)), "-f", "json")
    api = minparam.singular("robots/ur5.yaml", q_deg, twist=twist, degrees=True)
    same(api.to_dict(), cli)
    # radians give the same document
    same(minparam.singular("robots/ur5.yaml", np.radians(q_deg), twist=twist).to_dict(), cli)
    assert api.singular == cli["singular"]


def test_singular_scan_and_symbolic():
    cli = cli_json("singular", "robots/planar3r.yaml", "--scan", "--step", "30", "--symbolic", "-f", "json")
    api = minparam.singular("robots/planar3r.yaml", scan=True, step=30, degrees=True, symbolic=True)
    same(api.to_dict(), cli)


def test_platform():
    pose = [0, 0, 200, 5, -3, 10]
    same(minparam.platform_ik(PLATFORM, pose).to_dict(),
         cli_json("platform", "ik", PLATFORM, "--pose", ",".join(map(str, pose)), "-f", "json"))
    fk = minparam.platform_fk(PLATFORM, LENGTHS)
    same(fk.to_dict(), cli_json("platform", "fk", PLATFORM, "--lengths", ",".join(map(str, LENGTHS)), "-f", "json"))
    truss = "robots/platforms/dodekapod_truss.yaml"
    tik = minparam.platform_ik(truss)
    same(tik.to_dict(), cli_json("platform", "ik", truss, "-f", "json"))
    same(minparam.platform_fk(truss, tik.lengths, frame=("B1", "B2", "B3")).to_dict(),
         cli_json("platform", "fk", truss, "--lengths", ",".join(map(repr, tik.lengths)), "--frame", "B1,B2,B3", "-f", "json"))
    ws = minparam.platform_workspace(PLATFORM, samples=2000, seed=4)
    same(ws.to_dict(), cli_json("platform", "workspace", PLATFORM, "--samples", "2000", "--seed", "4", "-f", "json"))
    assert 0 < ws.reachable <= 1


EXCITE_FAST = {"harmonics": 3, "rate": 50, "starts": 2, "max_iterations": 20}


@pytest.mark.filterwarnings("ignore::minparam_cli.errors.MinparamWarning")  # planar2r.yaml gives no limits: two notes
def test_excite(tmp_path):
    """The --json record and the CSV bytes, with the default options and with declared friction, rest and a box."""
    for kw, flags in (({}, []), ({"friction": ["coulomb", "viscous"], "rest": True, "seed": 2, "box": [[None, None], [-0.5, None], [None, None]],
                                  "criterion": "logdet"},
                                 ["--friction", "coulomb,viscous", "--rest", "--seed", "2", "--box", ":,-0.5:,:", "--criterion", "logdet"])):
        out, js = tmp_path / "e.csv", tmp_path / "e.json"
        r = CliRunner().invoke(app, ["excite", ROBOT, "--harmonics", "3", "--rate", "50", "--starts", "2", "--max-iterations", "20",
                                     "-o", str(out), "--json", str(js), "-q", *flags])
        assert r.exit_code == 0, r.output
        api = minparam.excite(ROBOT, **EXCITE_FAST, **kw)
        same(api.to_dict(), json.loads(js.read_text()))
        assert api.to_csv() == out.read_text()
        table = np.loadtxt(out, delimiter=",", skiprows=1)
        np.testing.assert_array_equal(table, np.hstack([api.t[:, None], api.q, api.dq, api.ddq]))
        np.testing.assert_array_equal(api.a, api.to_dict()["trajectory"]["a"])
        assert api.seed == kw.get("seed", 0) and api.harmonics == 3


@pytest.fixture(scope="module")
def model_file(tmp_path_factory):
    d = tmp_path_factory.mktemp("codegen_model")
    r = CliRunner().invoke(app, ["simulate", ROBOT, "--effects", "coulomb,viscous", "--noise", "0.05", "--duration", "5",
                                 "--seed", "3", "-o", str(d / "sim.csv"), "-q"])
    assert r.exit_code == 0, r.output
    minparam.identify(ROBOT, d / "sim.csv").model.save(d / "m.json")  # type: ignore[union-attr]
    return d / "m.json"


@pytest.mark.parametrize("lang", ["python", "c", "casadi"])
def test_codegen_text_is_the_files_the_cli_writes(tmp_path, lang):
    suffix = ".c" if lang == "c" else ".py"
    out = tmp_path / f"gen{suffix}"
    r = CliRunner().invoke(app, ["codegen", ROBOT, "--lang", lang, "-o", str(out), "--friction", "coulomb", "--full", "-q"])
    assert r.exit_code == 0, r.output
    api = minparam.codegen(ROBOT, lang, output=out, friction=["coulomb"], full=True)
    assert api.source == out.read_text()
    if lang == "c":
        assert api.header == out.with_suffix(".h").read_text()
    assert set(api.counts) == {"base_regressor", "regressor"} and api.base_names == minparam.derive(ROBOT, friction="coulomb").names
    # write() puts the same bytes where -o did
    again = tmp_path / "again"
    again.mkdir()
    written = api.write(again / out.name)
    assert [p.read_text() for p in written] == [out.read_text()] + ([out.with_suffix(".h").read_text()] if lang == "c" else [])


def test_codegen_to_stdout_is_the_clis_stdout():
    r = CliRunner().invoke(app, ["codegen", ROBOT, "--lang", "python", "--method", "projection", "--gravity", "0,-9.81,0", "-q"])
    assert r.exit_code == 0, r.output
    assert minparam.codegen(ROBOT, "python", method="projection", gravity=(0, -9.81, 0)).source == r.stdout


@pytest.mark.parametrize("lang,which", [("python", None), ("c", "fit")])
def test_codegen_with_a_model_is_the_clis_text(tmp_path, model_file, lang, which):
    out = tmp_path / ("gen.c" if lang == "c" else "gen.py")
    flags = ["--parameters", which] if which else []
    r = CliRunner().invoke(app, ["codegen", ROBOT, "--lang", lang, "--model", str(model_file), "-o", str(out), *flags, "-q"])
    assert r.exit_code == 0, r.output
    api = minparam.codegen(ROBOT, lang, model=model_file, parameters=which, output=out)
    assert api.source == out.read_text()
    assert "inverse_dynamics" in api.counts and "inverse_dynamics" in api.source
