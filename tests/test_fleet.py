"""Batch commands on a real Dask distributed cluster (LocalCluster, two worker processes on this
machine) against the local path (--jobs 1): same JSON, per-item errors, a worker killed mid-batch."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import numpy as np
import pytest
from conftest import cli as run


distributed = pytest.importorskip("distributed")

N_ROBOTS = 200
N_RECORDINGS = 20
ELAPSED = re.compile(r'"elapsed_s": [-+0-9.eE]+')



def timeless(text: str) -> str:
    """JSON text with its wall-clock fields (``elapsed_s``, the only ones that differ run to run) zeroed."""
    return ELAPSED.sub('"elapsed_s": 0', text)


@pytest.fixture(scope="module")
def cluster():
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as c:
        yield c


def write_robots(folder: Path, count: int, seed: int = 20) -> list[Path]:
    """``count`` 2- and 3-joint DH arms with seeded random geometry (revolute, sometimes a prismatic last joint)."""
    rng = np.random.default_rng(seed)
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for i in range(count):
        n = int(rng.integers(2, 4))
        lines = [f"name: variant {i}", "convention: dh", "units: {length: m, angle: deg}", "gravity: [0, 0, -9.81]", "joints:"]
        for j in range(n):
            kind = "prismatic" if j == n - 1 and rng.random() < 0.2 else "revolute"
            alpha = int(rng.choice([0, 90, -90]))
            a, d = round(float(rng.uniform(0.1, 0.6)), 3), round(float(rng.uniform(0.0, 0.3)), 3)
            lines.append(f"  - {{name: j{j + 1}, type: {kind}, alpha: {alpha}, a: {a}, d: {d}, theta: 0}}")
        p = folder / f"v{i:03d}.yaml"
        p.write_text("\n".join(lines) + "\n")
        out.append(p)
    return out


@pytest.fixture(scope="module")
def robots(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("robots")
    write_robots(folder, N_ROBOTS)
    (folder / "v100_broken.yaml").write_text("convention: dh\njoints: []\n")  # sorted among the good ones
    return folder


@pytest.fixture(scope="module")
def recordings(tmp_path_factory) -> Path:
    """Short simulated recordings of two robots (different seeds and injected effects), and a broken one."""
    folder = tmp_path_factory.mktemp("recordings")
    for i in range(N_RECORDINGS):
        effects = ("coulomb", "coulomb,viscous", "viscous:amp=0.3", "")[i % 4]
        r = run("simulate", "robots/planar2r.yaml", "--noise", "0.01", "--seed", i, "--duration", "8",
                "--rate", "100", *(["--effects", effects] if effects else []), "-o", folder / f"r{i:02d}.csv", "--quiet")
        assert r.exit_code == 0, r.output
    (folder / "r05_broken.csv").write_text("t,q1,q2,tau1,tau2\n0,0,0,0,0\n0.005,0,zero,0,0\n")
    return folder


def test_derive_on_the_cluster_gives_the_json_of_jobs_1_and_reports_the_bad_file(robots, cluster):
    local = run("derive", robots, "--format", "json", "--samples", "30", "--jobs", "1", "--quiet")
    remote = run("derive", robots, "--format", "json", "--samples", "30", "--scheduler", cluster.scheduler_address)
    assert local.exit_code == remote.exit_code == 2  # the broken robot: bad input, the batch went on
    items = json.loads(local.stdout)
    assert len(items) == N_ROBOTS + 1
    assert sum("n_base" in i for i in items) == N_ROBOTS
    bad = [i for i in items if "error" in i]
    assert len(bad) == 1 and bad[0]["source"].endswith("v100_broken.yaml")
    assert timeless(remote.stdout) == timeless(local.stdout)
    assert remote.stdout != "" and "v100_broken.yaml" in remote.stderr


def test_a_worker_killed_mid_batch_loses_and_duplicates_nothing(tmp_path, cluster):
    """Item 7's task kills its own worker process the first time it runs (SIGKILL, mid-task): the
    nanny starts a new worker, the scheduler runs the lost tasks again, and every item's result
    comes back exactly once, in input order, equal to the local run's."""
    from minparam_cli.cli.batch import run_batch
    from minparam_cli.api.derivation import derive_file
    from minparam_cli.api.options.derive import DeriveOptions

    files = write_robots(tmp_path / "robots", 40, seed=7)
    log = tmp_path / "runs.log"
    killed = tmp_path / "killed"

    def task(path, opts):
        import os
        import signal

        with open(log, "a") as fh:
            fh.write(f"{Path(path).name}\n")
        if Path(path).name == "v007.yaml" and not killed.exists():
            killed.write_text(str(os.getpid()))
            os.kill(os.getpid(), signal.SIGKILL)
        return derive_file(path, opts)

    opts = DeriveOptions(samples=30)
    done = []
    remote = run_batch(task, files, (opts,), scheduler=cluster.scheduler_address, progress=lambda i, n: done.append(i))
    local = run_batch(derive_file, files, (opts,), jobs=1)
    assert killed.exists()  # a worker did die mid-task
    runs = log.read_text().splitlines()
    assert runs.count("v007.yaml") == 2  # started on the killed worker, run again on a live one
    assert [r["path"] for r in remote] == [str(f) for f in files]
    assert all(r["ok"] for r in remote)
    def strip(rs):
        return [{**r["result"].to_dict(), "elapsed_s": 0} for r in rs]
    assert strip(remote) == strip(local)
    assert done == list(range(1, len(files) + 1))  # the bar counted each item once


def test_identify_batch_on_the_cluster_matches_jobs_1(recordings, cluster, tmp_path):
    a, b = tmp_path / "local", tmp_path / "cluster"
    fast = ("--effects", "coulomb,viscous,offset")  # a small effect library keeps the test short
    robot = Path("robots/planar2r.yaml").resolve()  # a cluster is given absolute paths: the local run too
    local = run("identify", robot, recordings, "-o", a, "--format", "json", "--quiet", *fast)
    remote = run("identify", robot, recordings, "-o", b, "--format", "json", "--quiet", *fast,
                 "--scheduler", cluster.scheduler_address)
    assert local.exit_code == remote.exit_code == 2  # the broken recording
    assert remote.stdout == local.stdout  # the summary has no wall-clock field: byte-identical
    rows = json.loads(local.stdout)
    assert len(rows) == N_RECORDINGS + 1
    broken = [r for r in rows if r["status"] != "ok"]
    assert len(broken) == 1 and "r05_broken.csv" in broken[0]["error"] and "non-numeric value 'zero' on line 3" in broken[0]["error"]
    files = sorted(p.name for p in a.iterdir())
    assert files == sorted(p.name for p in b.iterdir())
    assert len(files) == 2 * N_RECORDINGS + 1  # a report and a model per good recording, and summary.csv
    for name in files:
        assert timeless((a / name).read_text()) == timeless((b / name).read_text()), name
    # the summary's figures are the reports' own
    rep = json.loads((a / "r01.csv.report.json").read_text())
    row = next(r for r in rows if r["recording"].endswith("r01.csv"))
    assert row["before_selection"] == rep["before"]["relative_error"] and row["after_selection"] == rep["after"]["relative_error"]
    assert row["test_final"] == rep["test"]["final"]["relative_error"]
    assert row["after_selection"] < row["before_selection"]
    assert "coulomb" in row["effects"] and "viscous" in row["effects"]  # r01 was simulated with both


def test_identify_manifest_maps_recordings_to_robots_and_models_evaluate(tmp_path):
    (tmp_path / "data").mkdir()
    for i, robot in enumerate(("planar2r", "planar3r")):
        r = run("simulate", f"robots/{robot}.yaml", "--noise", "0.01", "--seed", i, "--duration", "8", "--rate", "100", "--effects", "coulomb",
                "-o", tmp_path / "data" / f"{robot}.csv", "--quiet")
        assert r.exit_code == 0, r.output
    shutil.copy("robots/planar3r.yaml", tmp_path / "arm3.yaml")
    manifest = tmp_path / "fleet.csv"
    manifest.write_text("recording,robot\ndata/planar2r.csv,\ndata/planar3r.csv,arm3.yaml\ndata/missing.csv,\n")
    out = tmp_path / "out"
    r = run("identify", "robots/planar2r.yaml", manifest, "-o", out, "--jobs", "2", "--format", "json", "--quiet",
            "--effects", "coulomb,viscous")
    assert r.exit_code == 2
    rows = json.loads(r.stdout)
    assert [row["status"] for row in rows] == ["ok", "ok", "error"]
    assert rows[1]["robot"] == str(tmp_path / "arm3.yaml") and "missing.csv" in rows[2]["error"]
    assert sorted(p.name for p in out.iterdir()) == ["data__planar2r.csv.model.json", "data__planar2r.csv.report.json",
                                                    "data__planar3r.csv.model.json", "data__planar3r.csv.report.json", "summary.csv"]
    ev = run("evaluate", out / "data__planar3r.csv.model.json", tmp_path / "data" / "planar3r.csv", "--format", "json")
    assert ev.exit_code == 0, ev.output


@pytest.mark.parametrize("extra, message", [
    (["--plot", "figs"], "--plot applies to one recording"),
    (["--save-model", "m.json"], "--save-model applies to one recording"),
    ([], "give the folder for them with -o FOLDER"),
])
def test_batch_refuses_single_recording_options(recordings, tmp_path, extra, message):
    args = [str(tmp_path / a) if a in ("figs", "m.json") else a for a in extra]
    r = run("identify", "robots/planar2r.yaml", recordings, *args)
    assert r.exit_code == 2 and message in r.stderr


def test_scheduler_needs_a_batch_and_a_reachable_scheduler(recordings, tmp_path, monkeypatch):
    from minparam_cli.cli import executor

    monkeypatch.setattr(executor, "CONNECT_TIMEOUT_S", 1)
    r = run("identify", "robots/planar2r.yaml", recordings / "r00.csv", "--scheduler", "tcp://127.0.0.1:9")
    assert r.exit_code == 2 and "--scheduler runs a batch" in r.stderr
    r = run("derive", "robots/planar2r.yaml", "robots/planar3r.yaml", "--scheduler", "tcp://127.0.0.1:9", "-q")
    assert r.exit_code == 2 and "cannot reach a Dask scheduler there" in r.stderr


def test_relative_paths_reach_workers_that_run_elsewhere(robots, cluster, monkeypatch):
    """The workers' working folder is not the command's: relative paths are sent as absolute ones."""
    monkeypatch.chdir(robots)  # the workers started in the repository root, where v000.yaml is not
    r = run("derive", "v000.yaml", "v001.yaml", "--format", "jsonl", "--samples", "30", "--scheduler", cluster.scheduler_address)
    assert r.exit_code == 0, r.output
    assert [json.loads(line)["source"] for line in r.stdout.splitlines()] == [str(robots / "v000.yaml"), str(robots / "v001.yaml")]
