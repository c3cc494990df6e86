"""The compiled regressor kernel and the numpy reference give the same regressor."""

from __future__ import annotations

import os

import numpy as np
import pytest
import reference_dynamics as ref
from test_urdf import inertial, joint, link, urdf

from minparam_cli.chain import build_chain
from minparam_cli.describe import load_description
from minparam_cli.dynamics import regressor as reg

ALL_EXTRAS = ("rotor_inertia", "coulomb", "viscous", "offset")
needs_kernel = pytest.mark.skipif(reg._rnea is None, reason="compiled kernel not built (no C compiler at install)")


def test_ci_builds_the_kernel():
    """.ci/run sets MINPARAM_REQUIRE_KERNEL=1: a silent fallback to numpy must not pass CI."""
    if os.environ.get("MINPARAM_REQUIRE_KERNEL") != "1":
        pytest.skip("MINPARAM_REQUIRE_KERNEL is not set")
    assert reg._rnea is not None


def _states(chain, N, seed):
    rng = np.random.default_rng(seed)
    return reg.random_states(chain, N, rng)


@needs_kernel
def test_kernel_equals_numpy_on_every_robot_with_every_extra(robot_path):
    chain = build_chain(load_description(robot_path))
    chain = chain.with_extras(tuple(ALL_EXTRAS for _ in range(chain.n)))
    q, qd, qdd = _states(chain, 57, 5)
    Yk = reg.regressor(chain, q, qd, qdd, backend="kernel")
    Yn = reg.regressor(chain, q, qd, qdd, backend="numpy")
    assert Yk.shape == Yn.shape == (57, chain.n, chain.layout.size)
    assert np.abs(Yk - Yn).max() <= 1e-12 * np.abs(Yn).max()


def _tree_with_prismatic(tmp_path):
    """A waist carrying a 2R arm and a prismatic lift with a wrist: a tree with both joint types."""
    body = link("world") + link("torso", inertial(5)) + link("a1", inertial(1.5, "0.1 0 0"))
    body += link("a2", inertial(1.0, "0.15 0.02 0")) + link("lift", inertial(2.0, "0 0 0.1", "0.1 0.2 0.3"))
    body += link("wrist", inertial(0.5, "0.02 0 0.05"))
    body += joint("waist", "revolute", "world", "torso", "0 0 0.5", axis="0 0 1")
    body += joint("sh", "revolute", "torso", "a1", "0 0.3 0.2", "1.5707963 0 0", "0 0 1")
    body += joint("el", "revolute", "a1", "a2", "0.3 0 0", axis="0 0 1")
    body += joint("up", "prismatic", "torso", "lift", "0.1 -0.3 0", "0 0.4 0", "0 0 1")
    body += joint("tw", "revolute", "lift", "wrist", "0 0 0.2", "0.3 0 0", "1 0 0")
    return build_chain(load_description(urdf(tmp_path, "tree_lift.urdf", body)))


@needs_kernel
def test_kernel_on_a_tree_with_a_prismatic_joint(tmp_path):
    chain = _tree_with_prismatic(tmp_path)
    assert chain.parents == (-1, 0, 1, 0, 3) and not chain.revolute[3]
    q, qd, qdd = _states(chain, 40, 2)
    Yk = reg.regressor(chain, q, qd, qdd, backend="kernel")
    Yn = reg.regressor(chain, q, qd, qdd, backend="numpy")
    assert np.abs(Yk - Yn).max() <= 1e-12 * np.abs(Yn).max()


@pytest.mark.parametrize("backend", ["numpy", pytest.param("kernel", marks=needs_kernel)])
def test_each_backend_matches_euler_lagrange_on_the_tree(tmp_path, backend):
    chain = _tree_with_prismatic(tmp_path)
    rng = np.random.default_rng(8)
    phi = rng.standard_normal(10 * chain.n)
    q, qd, qdd = rng.standard_normal((3, 3, chain.n))
    Y = reg.regressor(chain, q, qd, qdd, include_extras=False, backend=backend)
    for s in range(3):
        tau_ref = ref.inverse_dynamics(chain, phi, q[s], qd[s], qdd[s])
        assert np.linalg.norm(Y[s] @ phi - tau_ref) <= 1e-9 * np.linalg.norm(tau_ref)


@needs_kernel
def test_kernel_accepts_non_contiguous_input_and_no_samples():
    chain = build_chain(load_description(os.path.join(os.path.dirname(__file__), "..", "robots", "puma560.yaml")))
    q, qd, qdd = _states(chain, 30, 1)
    Yk = reg.regressor(chain, q[::2], qd[::2], qdd[::2], backend="kernel")
    Yn = reg.regressor(chain, q[::2], qd[::2], qdd[::2], backend="numpy")
    assert np.abs(Yk - Yn).max() <= 1e-12 * np.abs(Yn).max()
    empty = np.zeros((0, chain.n))
    assert reg.regressor(chain, empty, empty, empty, backend="kernel").shape == (0, chain.n, chain.layout.size)


@needs_kernel
def test_kernel_refuses_buffers_of_the_wrong_size():
    chain = build_chain(load_description(os.path.join(os.path.dirname(__file__), "..", "robots", "planar2r.yaml")))
    terms, axor, parents, revolute, g = reg._kernel_arrays(chain)
    q = np.zeros((3, 2))
    with pytest.raises(ValueError, match="out has"):
        reg._rnea.inertial_regressor(np.zeros((3, 2, 19)), q, q, q, terms, axor, parents, revolute, g, 3, 2, 20)
    with pytest.raises(ValueError, match="parents must precede"):
        bad = np.array([-1, 1], dtype=np.int64)
        reg._rnea.inertial_regressor(np.zeros((3, 2, 20)), q, q, q, terms, axor, bad, revolute, g, 3, 2, 20)


def test_wrong_shapes_are_refused():
    chain = build_chain(load_description(os.path.join(os.path.dirname(__file__), "..", "robots", "planar2r.yaml")))
    with pytest.raises(ValueError, match="shape"):
        reg.regressor(chain, np.zeros((4, 3)), np.zeros((4, 3)), np.zeros((4, 3)))


def test_smooth_coulomb_column_is_tanh_and_tends_to_sign():
    chain = build_chain(load_description(os.path.join(os.path.dirname(__file__), "..", "robots", "planar2r.yaml")))
    chain = chain.with_extras((("coulomb",), ("coulomb",)))
    q, qd, qdd = _states(chain, 200, 4)
    col = chain.layout.names.index("Fc2")
    sharp = reg.regressor(chain, q, qd, qdd)[:, 1, col]
    assert np.array_equal(sharp, np.sign(qd[:, 1]))
    smooth = reg.regressor(chain.with_coulomb_smoothing(0.05), q, qd, qdd)[:, 1, col]
    assert np.allclose(smooth, np.tanh(qd[:, 1] / 0.05), rtol=0, atol=1e-15)
    nearly = reg.regressor(chain.with_coulomb_smoothing(1e-9), q, qd, qdd)[:, 1, col]
    moving = np.abs(qd[:, 1]) > 1e-6
    assert np.abs(nearly - sharp)[moving].max() < 1e-12
    with pytest.raises(ValueError, match=">= 0"):
        chain.with_coulomb_smoothing(-1.0)


def _columns_agree(chain, seed: int, backend: str = "auto") -> None:
    """regressor_columns (rows of chosen columns, joint-major, written into a larger buffer) equals
    the regressor's columns, transposed; the rows and samples it was not asked for stay untouched."""
    rng = np.random.default_rng(seed)
    q, qd, qdd = reg.random_states(chain, 33, rng)
    Y = reg.regressor(chain, q, qd, qdd, backend=backend)
    cols = rng.permutation(Y.shape[2])[: max(1, 2 * Y.shape[2] // 3)]  # any order, a third left out
    out = np.full((chain.dof, len(cols) + 3, 40), np.nan)
    assert reg.regressor_columns(chain, q, qd, qdd, cols, out=out, backend=backend) is out
    assert np.array_equal(out[:, : len(cols), :33], Y[:, :, cols].transpose(1, 2, 0))
    assert np.isnan(out[:, len(cols):]).all() and np.isnan(out[:, :, 33:]).all()
    assert np.array_equal(reg.regressor_columns(chain, q, qd, qdd, cols, backend=backend), Y[:, :, cols].transpose(1, 2, 0))


@needs_kernel
def test_columns_equal_the_regressor_on_every_robot_with_every_extra(robot_path):
    chain = build_chain(load_description(robot_path))
    _columns_agree(chain, 3)
    _columns_agree(chain.with_extras(tuple(ALL_EXTRAS for _ in range(chain.n))).with_coulomb_smoothing(0.02), 4)
    _columns_agree(chain, 5, backend="numpy")


@needs_kernel
def test_columns_on_a_tree_a_floating_base_and_mimic_joints(tmp_path):
    from test_floating_base import biped
    from test_mimic import gripper_arm

    from minparam_cli.robot import DeriveOptions, load_chain

    _columns_agree(_tree_with_prismatic(tmp_path), 6)
    _, floating = load_chain(biped(tmp_path, 2, True), DeriveOptions())
    assert floating.layout.n_inertial < 10 * floating.n  # massless virtual links: the column map skips them
    _columns_agree(floating, 7)
    _, mimic = load_chain(gripper_arm(tmp_path), DeriveOptions())
    assert mimic.coupling is not None  # the copying route
    _columns_agree(mimic, 8)


@needs_kernel
def test_columns_kernel_refuses_a_buffer_too_small_for_its_strides():
    chain = build_chain(load_description(os.path.join(os.path.dirname(__file__), "..", "robots", "planar2r.yaml")))
    terms, axor, parents, revolute, g = reg._kernel_arrays(chain)
    q = np.zeros((3, 2))
    dest = np.arange(20, dtype=np.int64)
    with pytest.raises(ValueError, match="too small"):
        reg._rnea.inertial_columns(np.zeros((2, 19, 3)), q, q, q, terms, axor, parents, revolute, g, dest, 3, 2, 57, 3)
    with pytest.raises(ValueError, match="too small"):  # rows closer than N samples would overlap
        reg._rnea.inertial_columns(np.zeros((2, 20, 3)), q, q, q, terms, axor, parents, revolute, g, dest, 3, 2, 60, 2)
    with pytest.raises(ValueError, match="dest has"):
        reg._rnea.inertial_columns(np.zeros((2, 20, 3)), q, q, q, terms, axor, parents, revolute, g, dest[:19], 3, 2, 60, 3)
    with pytest.raises(ValueError, match="shape"):
        reg.regressor_columns(chain, q, q, q, [0, 1], out=np.zeros((2, 1, 3)))
    with pytest.raises(ValueError, match="columns must lie"):
        reg.regressor_columns(chain, q, q, q, [20])


@needs_kernel
def test_every_lane_width_gives_the_same_numbers_bit_for_bit(robot_path):
    """The kernel computes 1, 2 or 4 samples at a time (the widest the processor has is used); each
    lane does the scalar arithmetic in the same order, so every width gives identical numbers,
    also for sample counts that leave lanes empty."""
    widths = reg._rnea.lane_widths()
    assert widths[0] == 1
    chain = build_chain(load_description(robot_path))
    terms, axor, parents, revolute, g = reg._kernel_arrays(chain)
    n = chain.n
    dest = np.arange(10 * n, dtype=np.int64)
    dest[::3] = -1  # some columns not asked for
    for N in (1, 3, 4, 7, 33):
        q, qd, qdd = (np.ascontiguousarray(x) for x in _states(chain, N, N))
        ref = None
        for lanes in widths:
            Y = np.zeros((N, n, 10 * n))
            reg._rnea.inertial_regressor(Y, q, qd, qdd, terms, axor, parents, revolute, g, N, n, 10 * n, lanes)
            cols = np.full((n, 10 * n, N), np.nan)
            reg._rnea.inertial_columns(cols, q, qd, qdd, terms, axor, parents, revolute, g, dest, N, n, 10 * n * N, N, lanes)
            if ref is None:
                ref = (Y, cols)
            assert np.array_equal(Y, ref[0]) and np.array_equal(cols, ref[1], equal_nan=True)
        kept = dest >= 0
        assert np.array_equal(ref[1][:, dest[kept]], ref[0][:, :, kept].transpose(1, 2, 0))
    with pytest.raises(ValueError, match="no kernel 3 samples wide"):
        reg._rnea.inertial_regressor(np.zeros((1, n, 10 * n)), q[:1], qd[:1], qdd[:1], terms, axor, parents, revolute, g, 1, n, 10 * n, 3)


def test_version_names_the_regressor_backend(monkeypatch, capsys):
    """`minparam --version` says whether the compiled kernel is there, and its widest lane width."""
    import sys

    from minparam_cli import __version__
    from minparam_cli.cli.app import main
    from minparam_cli.dynamics import backend

    def version() -> str:
        monkeypatch.setattr(sys, "argv", ["minparam", "--version"])
        assert main() == 0
        return capsys.readouterr().out.strip()

    if reg._rnea is not None:
        widest = max(reg._rnea.lane_widths())
        assert version() == f"minparam {__version__} (regressor: compiled kernel, {backend.LANES[widest]})"
    import minparam_cli.dynamics

    monkeypatch.setitem(sys.modules, "minparam_cli.dynamics._rnea", None)  # as an install without a C compiler
    monkeypatch.delattr(minparam_cli.dynamics, "_rnea", raising=False)
    assert version() == f"minparam {__version__} (regressor: {backend.NO_KERNEL})"
    assert "numpy" in backend.NO_KERNEL and "C compiler" in backend.NO_KERNEL
