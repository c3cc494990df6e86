"""ROS bags (rosbag2 MCAP and SQLite, ROS 1) of sensor_msgs/JointState give the same identification
as the CSV they were written from: the bag reader yields the tables the CSV reader yields."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import cli

rosbags = pytest.importorskip("rosbags")

ROBOTS = Path(__file__).resolve().parents[1] / "robots"
PUMA = ROBOTS / "puma560_mdh.yaml"
NAMES = [f"j{k}" for k in range(1, 7)]  # puma560_mdh.yaml's joint names (checked below)


def read_csv(path: Path):
    with open(path) as fh:
        header = fh.readline().strip().split(",")
    return header, np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)


def write_bag(path: Path, kind: str, csv: Path, names=NAMES, topic="/joint_states", velocity=True,
              shuffle=False, extra_topics=(), order=None) -> Path:
    """The CSV's rows as JointState messages (header stamp = t in ns, effort = tau)."""
    from rosbags.typesys import Stores, get_typestore

    header, table = read_csv(csv)
    col = {h: i for i, h in enumerate(header)}
    n = len(names)
    ros1 = kind == "ros1"
    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    JointState = store.types["sensor_msgs/msg/JointState"]
    Header = store.types["std_msgs/msg/Header"]
    Time = store.types["builtin_interfaces/msg/Time"]
    if ros1:
        from rosbags.rosbag1 import Writer

        writer = Writer(path)
    else:
        from rosbags.rosbag2 import StoragePlugin, Writer

        plugin = StoragePlugin.MCAP if kind == "mcap" else StoragePlugin.SQLITE3
        writer = Writer(path, version=9, storage_plugin=plugin)
    serialize = store.serialize_ros1 if ros1 else store.serialize_cdr
    perm = np.arange(n)[::-1] if shuffle else np.arange(n)  # messages may list the joints in any order
    with writer:
        conns = [writer.add_connection(t, JointState.__msgtype__, typestore=store) for t in (topic, *extra_topics)]
        for r, row in enumerate(table):
            ns = int(round(row[col["t"]] * 1e9))
            pick = lambda key, row=row: np.array([row[col[f"{key}{j + 1}"]] for j in perm], dtype=np.float64)  # noqa: E731
            msg = JointState(
                header=Header(**({"seq": r} if ros1 else {}), stamp=Time(sec=ns // 10**9, nanosec=ns % 10**9), frame_id=""),
                name=[names[j] for j in perm],
                position=pick("q"),
                velocity=pick("dq") if velocity else np.zeros(0),
                effort=pick("tau"),
            )
            data = serialize(msg, JointState.__msgtype__)
            for c in conns:
                writer.write(c, ns, data)
    return path


@pytest.fixture(scope="module")
def sim(tmp_path_factory):
    """A simulate run (with dq, without ddq) and the same data without dq; stamps are whole ns."""
    d = tmp_path_factory.mktemp("sim")
    r = cli("simulate", PUMA, "--effects", "coulomb,viscous", "--noise", "0.05", "--duration", "12", "--no-ddq",
            "-o", d / "sim.csv")
    assert r.exit_code == 0, r.output
    header, table = read_csv(d / "sim.csv")
    keep = [i for i, h in enumerate(header) if not h.startswith("dq")]
    np.savetxt(d / "nodq.csv", table[:, keep], delimiter=",", header=",".join(header[i] for i in keep),
               comments="", fmt="%.17g")
    return d


def identify_json(data, *extra):
    r = cli("identify", PUMA, data, "--format", "json", "--seed", "0", *extra)
    assert r.exit_code == 0, r.output
    return json.loads(r.output)


PATH_KEYS = ("data", "source", "path", "model_file", "elapsed_s")  # where the file's name (or the run time) shows


def flatten(x, prefix="") -> dict:
    """Every number and text of a report, keyed by its place; file names and the run time left out."""
    out = {}
    items = x.items() if isinstance(x, dict) else enumerate(x) if isinstance(x, list) else None
    if items is None:
        return {prefix: x}
    for k, v in items:
        if k in PATH_KEYS and (isinstance(v, str) or v is None or k == "elapsed_s"):
            continue
        out.update(flatten(v, f"{prefix}.{k}"))
    return out


def same_identification(a: dict, b: dict, rtol=1e-9) -> None:
    """Same report: effects, parameters, steps and error figures to ``rtol``, texts equal."""
    assert a["parameters"] and list(a["parameters"]) == list(b["parameters"])
    assert [e["effect"] for e in a["effects"]] == [e["effect"] for e in b["effects"]]
    fa, fb = flatten(a), flatten(b)
    assert fa.keys() == fb.keys()
    for k, va in fa.items():
        vb = fb[k]
        if isinstance(va, float) and isinstance(vb, float):
            np.testing.assert_allclose(vb, va, rtol=rtol, atol=1e-300, err_msg=k)
        else:
            assert va == vb, k


@pytest.mark.parametrize("kind,name", [("mcap", "run.mcap"), ("sqlite", "run_db"), ("ros1", "run.bag")])
def test_bag_identifies_like_its_csv(sim, tmp_path, kind, name):
    bag = write_bag(tmp_path / name, kind, sim / "sim.csv", shuffle=True, extra_topics=())
    ref = identify_json(sim / "sim.csv")
    got = identify_json(bag)
    same_identification(ref, got)


def test_sqlite_file_and_folder_and_missing_velocity(sim, tmp_path):
    """A bare .db3 file reads like its folder; messages without velocity are differentiated like
    a CSV without dq columns."""
    folder = write_bag(tmp_path / "nodq", "sqlite", sim / "nodq.csv", velocity=False)
    ref = identify_json(sim / "nodq.csv")
    same_identification(ref, identify_json(folder))
    db3 = next(folder.glob("*.db3"))
    same_identification(ref, identify_json(db3))


def test_topic_choice(sim, tmp_path):
    bag = write_bag(tmp_path / "two.mcap", "mcap", sim / "sim.csv", extra_topics=("/other_states",))
    r = cli("identify", PUMA, bag)
    assert r.exit_code == 2
    assert "2 sensor_msgs/msg/JointState topics (/joint_states, /other_states); choose one with --topic" in r.output
    assert "Traceback" not in r.output
    same_identification(identify_json(sim / "sim.csv"), identify_json(bag, "--topic", "/other_states"))
    r = cli("identify", PUMA, bag, "--topic", "/nope")
    assert r.exit_code == 2 and "no topic '/nope' in the bag" in r.output


def test_joint_names_must_match(sim, tmp_path):
    bag = write_bag(tmp_path / "names.mcap", "mcap", sim / "sim.csv", names=[f"joint_{k}" for k in range(1, 7)])
    r = cli("identify", PUMA, bag)
    assert r.exit_code == 2
    assert "message 1 on /joint_states lacks joints j1, j2, j3, j4, ... of the robot (it names: joint_1" in r.output


def test_damaged_and_special_bags_are_one_line(tmp_path):
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"\x00" * 100)
    r = cli("identify", PUMA, junk)
    assert r.exit_code == 2 and "cannot read the bag" in r.output and len(r.output.strip().splitlines()) == 1
    fifo = tmp_path / "pipe.bag"
    import os

    os.mkfifo(fifo)
    r = cli("identify", PUMA, fifo)
    assert r.exit_code == 2 and "expected a regular file" in r.output


def test_evaluate_reads_a_bag(sim, tmp_path):
    model = tmp_path / "model.json"
    r = cli("identify", PUMA, sim / "sim.csv", "--save-model", model, "-q")
    assert r.exit_code == 0, r.output
    bag = write_bag(tmp_path / "eval.mcap", "mcap", sim / "sim.csv")
    a = cli("evaluate", model, sim / "sim.csv", "--format", "json")
    b = cli("evaluate", model, bag, "--format", "json")
    assert a.exit_code == 0 and b.exit_code == 0, b.output
    fa, fb = flatten(json.loads(a.output)), flatten(json.loads(b.output))
    assert fa.keys() == fb.keys() and len(fa) > 10
    for k, va in fa.items():
        if isinstance(va, float):
            np.testing.assert_allclose(fb[k], va, rtol=1e-9, err_msg=k)
        else:
            assert fb[k] == va, k


def test_puma_joint_names():
    from minparam_cli.robot import DeriveOptions, load_chain

    _, chain = load_chain(PUMA, DeriveOptions())
    assert tuple(chain.joint_names) == tuple(NAMES)


def test_missing_extra_is_one_line(monkeypatch, tmp_path):
    import sys

    monkeypatch.setitem(sys.modules, "rosbags", None)  # import rosbags raises ImportError
    bag = tmp_path / "x.mcap"
    bag.write_bytes(b"")
    r = cli("identify", PUMA, bag)
    assert r.exit_code == 2
    assert "needs the rosbags library: pip install 'minparam[ros]'" in r.output
