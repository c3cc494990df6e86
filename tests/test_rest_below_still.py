"""A velocity derived by the filter below --still-speed reads as rest (dq = 0, so sign(dq) = 0 and a
joint at rest gets no Coulomb torque): only those samples change, velocities read from the file
never do, a saved model keeps the choice (an older model without it is read as the plain sign), and
on the TX40 recording no joint's held-out error rises from the rigid-body model to the final one."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import cli as run

from minparam_cli.measured.blocks import iter_blocks
from minparam_cli.measured.records import Block, DataOptions, DataReport

ROOT = Path(__file__).resolve().parents[1]
ROBOT = ROOT / "robots" / "planar3r.yaml"
N = 3
TX40 = next((p / "shared" / "data" / "staubli-tx40" for p in (ROOT.parent, ROOT.parent.parent)
             if (p / "shared" / "data" / "staubli-tx40" / "curr_data.csv").exists()), None)



@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    """4 s at 500 Hz: joints move, stop for 1.5 s (encoder noise only), move again; torque = noise."""
    rng = np.random.default_rng(5)
    t = np.arange(2000) * 0.002
    moving = (t < 1.0) | (t > 2.5)
    base = np.where(moving[:, None], np.sin(np.outer(t, [1.3, 0.9, 2.1])), np.sin(np.outer(np.full_like(t, 1.0), [1.3, 0.9, 2.1])))
    q = base + rng.normal(scale=1e-4, size=(len(t), N))
    tau = rng.normal(size=(len(t), N))
    d = tmp_path_factory.mktemp("rest")
    path = d / "q_only.csv"
    names = ["t"] + [f"q{j}" for j in range(1, N + 1)] + [f"tau{j}" for j in range(1, N + 1)]
    np.savetxt(path, np.column_stack([t, q, tau]), delimiter=",", header=",".join(names), comments="", fmt="%.17g")
    return path


def blocks(path, **kw) -> tuple[Block, DataReport]:
    rep = DataReport(str(path))
    b = Block.concat(list(iter_blocks(path, N, DataOptions(cutoff_hz=20.0, **kw), rep)))
    return b, rep


def test_only_derived_velocities_below_the_still_speed_become_zero(recording):
    off, rep_off = blocks(recording, rest_below_still=False)
    on, rep_on = blocks(recording)
    assert rep_on.rest_below == 0.01 and rep_off.rest_below is None
    slow = np.abs(off.dq) < 0.01
    assert slow.sum() > 500  # the stop: most of its samples are below the still speed
    np.testing.assert_array_equal(on.dq[slow], 0.0)
    np.testing.assert_array_equal(on.dq[~slow], off.dq[~slow])
    for k in ("t", "q", "ddq", "tau"):  # nothing else changes
        np.testing.assert_array_equal(getattr(on, k), getattr(off, k))
    assert rep_on.still_share == rep_off.still_share  # counted before, on the same velocities


def test_velocities_read_from_the_file_are_never_changed(tmp_path, recording):
    off, _ = blocks(recording, rest_below_still=False)
    names = ["t"] + [f"{k}{j}" for k in ("q", "dq", "ddq", "tau") for j in range(1, N + 1)]
    given = tmp_path / "given.csv"
    np.savetxt(given, np.column_stack([off.t, off.q, off.dq, off.ddq, off.tau]), delimiter=",", header=",".join(names),
               comments="", fmt="%.17g")
    on_given, rep = blocks(given)
    assert rep.rest_below is None
    np.testing.assert_array_equal(on_given.dq, off.dq)


def test_a_saved_model_keeps_the_choice_and_an_older_one_reads_as_the_plain_sign(tmp_path, recording):
    from minparam_cli.model.parse import read_model

    model = tmp_path / "m.json"
    r = run("identify", ROBOT, recording, "--no-diagnose", "--friction", "coulomb", "--cutoff", "20", "--save-model", model, "-q")
    assert r.exit_code == 0, r.output
    doc = json.loads(model.read_text())
    assert doc["data"]["rest_below_still"] is True
    assert read_model(model).data.rest_below_still is True
    del doc["data"]["rest_below_still"]
    old = tmp_path / "old.json"
    old.write_text(json.dumps(doc))
    assert read_model(old).data.rest_below_still is False
    doc["data"]["rest_below_still"] = "yes"
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(doc))
    r = run("evaluate", bad, recording)
    assert r.exit_code == 2 and "rest_below_still" in r.output, r.output


@pytest.mark.skipif(TX40 is None, reason="the shared TX40 recording is not here")
def test_tx40_no_joint_rises_on_the_test_block(tmp_path):
    text = (ROOT / "examples" / "tx40.recording.yaml").read_text(encoding="utf-8")
    desc = tmp_path / "tx40.recording.yaml"
    desc.write_text(text.replace("../../shared/data/staubli-tx40/", f"{TX40}/"), encoding="utf-8")
    reports = {}
    for flag in ("--rest-below-still", "--keep-slow-velocity"):
        r = run("identify", ROOT / "robots" / "tx40.yaml", desc, "--side", "motor", "--cutoff", "20", "--format", "json", "-q", flag)
        assert r.exit_code == 0, r.output
        reports[flag] = json.loads(r.output)
    rep = reports["--rest-below-still"]
    for block in (rep["test"]["rigid"], rep["before"]):
        assert block["rms_total"] > 0
    before, after = rep["test"]["rigid"]["rms_per_joint"], rep["test"]["final"]["rms_per_joint"]
    assert all(a < b for a, b in zip(after, before, strict=True)), (before, after)
    sel_before, sel_after = rep["before"]["rms_per_joint"], rep["after"]["rms_per_joint"]
    assert all(a < b for a, b in zip(sel_after, sel_before, strict=True))
    # the plain sign(dq) (the former default) lets joint 4 rise on the test block: the cause this fixes
    old = reports["--keep-slow-velocity"]["test"]
    assert old["final"]["rms_per_joint"][3] > old["rigid"]["rms_per_joint"][3]
