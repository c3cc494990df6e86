"""simulate streams: two passes in chunks give the same data whatever the chunk size, the CSV and npz
writers hold one chunk at a time and write numbers that read back exactly."""

from __future__ import annotations

import io
import zipfile
from pathlib import Path

import numpy as np
import pytest

from minparam_cli.chain import build_chain
from minparam_cli.cli.app import app
from minparam_cli.describe import load_description
from minparam_cli.experiment.simulate import Stream, plan, simulate
from minparam_cli.experiment.simulate_spec import SimulationOptions, parse_effects
from minparam_cli.measured.writing import CsvWriter, NpzWriter, csv_block

ROOT = Path(__file__).resolve().parents[1]
EFFECTS = "coulomb,viscous,gain@2,load_coulomb@3,cogging@1:k=12,drift@2,spring@1"


@pytest.fixture(scope="module")
def chain():
    return build_chain(load_description(ROOT / "robots" / "puma560.yaml"))


def _options(chain, **kw):
    base = dict(duration=7.3, rate=100.0, effects=parse_effects(EFFECTS, chain.dof), noise=0.05, noise_q=1e-3)
    base.update(kw)
    return SimulationOptions(**base)


def test_chunk_size_does_not_change_the_data(chain):
    opts = _options(chain)
    whole = simulate(chain, opts, np.random.default_rng(4))
    p = plan(chain, opts, np.random.default_rng(4), chunk=37)
    stream = Stream(p)
    parts = list(stream)
    assert max(len(c.t) for c in parts) == 37 and len(parts) == -(-whole.samples // 37)
    for name in ("t", "q", "dq", "ddq", "tau", "tau_effects"):
        got = np.concatenate([getattr(c, name) for c in parts])
        want = getattr(whole, name)
        # the Gram sums that scale the effects add in another order: equal to rounding
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12 * np.abs(want).max(), err_msg=name)
    # noise is drawn chunk by chunk from the same generator: q noise identical to the last bit
    np.testing.assert_array_equal(np.concatenate([c.q - c.q_true for c in parts]), whole.q - whole.q_true)
    assert stream.limits.max_abs_tau == pytest.approx(whole.limits.max_abs_tau, rel=1e-12)


def test_injected_rms_matches_the_data(chain):
    """The RMS reported per effect (from the Gram matrices) is the RMS of that effect's torque in the data."""
    opts = _options(chain, noise=0.0, noise_q=0.0, effects=parse_effects("viscous@2,cogging@1:k=12", chain.dof))
    sim = simulate(chain, opts, np.random.default_rng(1))
    total = np.sqrt(np.mean(sim.tau_effects**2, axis=0))
    assert sim.effects[0].rms[0] == pytest.approx(total[1], rel=1e-10)
    assert sim.effects[1].rms[0] == pytest.approx(total[0], rel=1e-10)
    # the default amplitude: strength × RMS of the joint's rigid torque
    rigid = np.sqrt(np.mean(sim.tau_rigid**2, axis=0))
    assert total[1] == pytest.approx(opts.strength * rigid[1], rel=1e-10)


def test_stream_reads_once_and_reports_progress(chain):
    seen = []
    p = plan(chain, _options(chain), np.random.default_rng(0), progress=lambda d, t: seen.append((d, t)), chunk=100)
    stream = Stream(p, progress=lambda d, t: seen.append((d, t)))
    list(stream)
    done = [d for d, _ in seen]
    assert done == sorted(done) and done[-1] == 2 * p.samples and {t for _, t in seen} == {2 * p.samples}
    with pytest.raises(RuntimeError):
        list(stream)


@pytest.mark.parametrize("fast", [True, False])
def test_csv_numbers_read_back_exactly(fast):
    rng = np.random.default_rng(9)
    block = rng.normal(size=(50, 6)) * 10.0 ** rng.integers(-30, 30, size=(50, 6))
    block[0] = [0.0, -0.0, 1e-5, 1e16, 5e-324, 123456789.0]
    text = csv_block(block, fast=fast).decode()
    back = np.array([[float(x) for x in line.split(",")] for line in text.splitlines()])
    np.testing.assert_array_equal(back, block)
    assert np.array_equal(np.signbit(back), np.signbit(block))


@pytest.mark.parametrize("background", [True, False])
def test_csv_writer_keeps_the_row_order(background):
    """Blocks of any size, formatted in batches (in a worker thread or not), come out in order."""
    rng = np.random.default_rng(5)
    blocks = [rng.normal(size=(k, 2)) for k in (3, 40000, 1, 70000, 7)]
    buf = io.BytesIO()
    with CsvWriter(buf, ("t", "q1"), background=background) as writer:
        for b in blocks:
            writer.write(b)
    lines = buf.getvalue().decode().splitlines()
    assert lines[0] == "t,q1"
    np.testing.assert_array_equal(np.array([[float(x) for x in ln.split(",")] for ln in lines[1:]]), np.vstack(blocks))
    with pytest.raises(ValueError):
        CsvWriter(io.BytesIO(), ("t", "q1")).write(np.zeros((1, 3)))


def test_npz_writer_is_what_savez_writes(tmp_path):
    rng = np.random.default_rng(2)
    t, q = rng.normal(size=11), rng.normal(size=(11, 3))
    w = NpzWriter({"t": (11,), "q": (11, 3)})
    for s in range(0, 11, 4):
        w.write("t", t[s:s + 4])
        w.write("q", q[s:s + 4])
    w.save(str(tmp_path / "a.npz"))
    with np.load(tmp_path / "a.npz") as z:
        np.testing.assert_array_equal(z["t"], t)
        np.testing.assert_array_equal(z["q"], q)
    assert not Path(w.folder).exists()
    incomplete = NpzWriter({"t": (5,)})
    incomplete.write("t", np.zeros(2))
    with pytest.raises(ValueError):
        incomplete.save(str(tmp_path / "b.npz"))
    assert not (tmp_path / "b.npz").exists() and not Path(incomplete.folder).exists()


def test_cli_csv_and_npz_carry_the_same_doubles(tmp_path):
    from typer.testing import CliRunner

    runner = CliRunner()
    robot = str(ROOT / "robots" / "puma560.yaml")
    args = ["simulate", robot, "-e", "coulomb,viscous", "--noise", "0.05", "--duration", "30", "--rate", "100", "--seed", "3", "-q"]
    r1 = runner.invoke(app, args + ["-o", str(tmp_path / "d.csv")])
    r2 = runner.invoke(app, args + ["-o", str(tmp_path / "d.npz")])
    assert r1.exit_code == 0 and r2.exit_code == 0, r1.output + r2.output
    csv = np.loadtxt(tmp_path / "d.csv", delimiter=",", skiprows=1)
    with np.load(tmp_path / "d.npz") as z:
        npz = np.hstack([z["t"][:, None], z["q"], z["dq"], z["ddq"], z["tau"]])
        assert zipfile.ZipFile(tmp_path / "d.npz").namelist() == ["t.npy", "q.npy", "dq.npy", "ddq.npy", "tau.npy"]
    np.testing.assert_array_equal(csv, npz)
    assert csv.shape == (3000, 1 + 4 * 6)


def test_thread_count_does_not_change_a_bit(chain):
    """The first pass runs chunks on threads; their sums are taken in chunk order."""
    opts = _options(chain)
    one = plan(chain, opts, np.random.default_rng(8), chunk=50, threads=1)
    three = plan(chain, opts, np.random.default_rng(8), chunk=50, threads=3)
    np.testing.assert_array_equal(one.tau_rigid, three.tau_rigid)
    assert one.effects == three.effects and one.max_abs_ddq == three.max_abs_ddq
