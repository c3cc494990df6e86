"""Generated code of a closed chain's base regressor (issue 35 point 5): the NumPy and the C output,
fed states of every tree joint on the loops' manifold, equal the model's Gᵀ·Y_tree[:, kept]
(loops/derive.py) to 1e-10, and the base regressor times the base parameters is the torque."""

from __future__ import annotations

import ctypes
import importlib.util
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from minparam_cli.api.derivation import derive_file
from minparam_cli.api.options.derive import DeriveOptions
from minparam_cli.cli.app import app
from minparam_cli.loops.derive import actuated_regressor
from minparam_cli.loops.model import closed_model
from minparam_cli.loops.sample import manifold_states
from minparam_cli.robot import load_chain

ROOT = Path(__file__).resolve().parents[1]
ROBOTS = [ROOT / "robots" / "parallelogram_arm.yaml", ROOT / "robots" / "planar_3rrr.yaml"]
CC = shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")


def _reference(path, samples=20):
    desc, chain = load_chain(path, DeriveOptions().stage(), loops=True)
    model = closed_model(desc, chain)
    base = derive_file(path, DeriveOptions())
    q, qd, qdd, G = manifold_states(model, samples, seed=7)
    Y = actuated_regressor(model, q, qd, qdd, G)
    return model, base, q, qd, qdd, Y[:, :, list(base.kept)], Y


def _generate(path, lang, out):
    r = CliRunner().invoke(app, ["codegen", str(path), "--lang", lang, "-o", str(out)])
    assert r.exit_code == 0, r.output


@pytest.mark.parametrize("path", ROBOTS, ids=lambda p: p.stem)
def test_numpy_output_equals_the_model(path, tmp_path):
    model, base, q, qd, qdd, Yb, Y = _reference(path)
    _generate(path, "python", tmp_path / "gen.py")
    spec = importlib.util.spec_from_file_location("gen", tmp_path / "gen.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    out = mod.base_regressor(q, qd, qdd)
    scale = np.abs(Yb).max()
    assert np.abs(out - Yb).max() < 1e-10 * scale
    # and the regrouping holds: Y_b (K φ) = Y φ for random standard parameters
    phi = np.random.default_rng(1).normal(size=base.n_standard)
    assert np.abs(out @ (base.K @ phi) - Y @ phi).max() < 1e-9 * np.abs(Y @ phi).max()
    assert np.abs(mod.base_regressor(q[0], qd[0], qdd[0]) - Yb[0]).max() < 1e-10 * scale


@pytest.mark.skipif(CC is None, reason="no C compiler on PATH")
@pytest.mark.parametrize("path", ROBOTS, ids=lambda p: p.stem)
def test_c_output_equals_the_model(path, tmp_path):
    model, base, q, qd, qdd, Yb, _ = _reference(path)
    _generate(path, "c", tmp_path / "gen.c")
    lib = tmp_path / "libgen.so"
    subprocess.run([CC, "-O2", "-std=c99", "-Wall", "-Wextra", "-Werror", "-shared", "-fPIC", "-o", str(lib),
                    str(tmp_path / "gen.c"), "-lm"], check=True, timeout=300)
    fn = ctypes.CDLL(str(lib)).gen_base_regressor
    fn.restype = ctypes.c_int
    f, nb = len(model.actuated), base.n_base
    for s in range(len(q)):
        out = np.zeros(f * nb)
        args = [np.ascontiguousarray(x[s]).ctypes.data_as(ctypes.POINTER(ctypes.c_double)) for x in (q, qd, qdd)]
        assert fn(*args, out.ctypes.data_as(ctypes.POINTER(ctypes.c_double))) == 0
        assert np.abs(out.reshape(f, nb) - Yb[s]).max() < 1e-10 * np.abs(Yb).max()


def test_closed_chain_codegen_refuses_what_it_cannot_write(tmp_path):
    for extra, needle in ((["--lang", "casadi"], "casadi"), (["--lang", "c", "--full"], "--full")):
        r = CliRunner().invoke(app, ["codegen", str(ROBOTS[0]), "-o", str(tmp_path / "x.out"), *extra])
        assert r.exit_code == 2 and needle in r.output and "Traceback" not in r.output, r.output
