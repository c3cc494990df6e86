"""The GIL-free triangular solve and QR (identify.estimate.nogil_lapack) against the wrappers they
replace: the same BLAS/LAPACK routines, so the same bits, on every shape the factor updates and the
diagnosis pass them (square, tall, wide, a floored diagonal, no rows); and the fallback when scipy's
table of pointers cannot be read."""

from __future__ import annotations

import ctypes

import numpy as np
import pytest
from scipy.linalg.blas import dtrsm

from minparam_cli.identify.estimate import nogil_lapack
from minparam_cli.identify.estimate.nogil_lapack import qr_r, solve_right_upper


def _triangular(rng, c, floored=()):
    R = np.linalg.qr(rng.standard_normal((3 * c + 5, c)), mode="r")
    for i in floored:
        R[i, i] = 1e-30  # a column the data had not excited: the preconditioner's floored diagonal
    return R


@pytest.mark.parametrize("N,c", [(4096, 61), (1000, 25), (7, 12), (1, 1), (0, 5)])
def test_solve_is_scipys_dtrsm(N, c):
    rng = np.random.default_rng(N + c)
    P = _triangular(rng, c, floored=(c // 2,) if c > 2 else ())
    A = rng.standard_normal((N, c))
    for order in ("C", "F"):
        A_ = np.asarray(A, order=order)
        got = solve_right_upper(P, A_)
        assert got.flags.f_contiguous and got.shape == (N, c)
        assert np.array_equal(got, dtrsm(1.0, P, A_, side=1, lower=0))
        assert np.array_equal(A_, A)  # the input is not overwritten


@pytest.mark.parametrize("shapes", [[(0, 61), (4096, 61)], [(61, 61), (4096, 61)], [(30, 61)], [(1, 5)],
                                    [(180, 180), (2048, 180)], [(3, 4), (2, 4)]])
def test_qr_r_is_numpys(shapes):
    rng = np.random.default_rng(sum(m for m, _ in shapes))
    blocks = [rng.standard_normal(s) for s in shapes]
    expected = np.linalg.qr(np.vstack(blocks), mode="r")
    got = qr_r(*blocks)
    assert got.shape == expected.shape
    assert np.array_equal(got, expected)


def test_routines_release_the_gil():
    """ctypes releases the GIL for a CFUNCTYPE call, keeps it for a PYFUNCTYPE one: the routines are the first."""
    for module, name in (("cython_blas", "dtrsm"), ("cython_lapack", "dgeqrf")):
        f = nogil_lapack._routine(module, name)
        assert f is not None, f"scipy.linalg.{module} exports no {name}"
        assert not f._flags_ & ctypes._FUNCFLAG_PYTHONAPI


def test_without_scipys_pointers_the_wrappers_give_the_same(monkeypatch):
    rng = np.random.default_rng(3)
    P, A = _triangular(rng, 9), rng.standard_normal((50, 9))
    B, R = rng.standard_normal((4, 9)), rng.standard_normal((40, 9))
    fast = solve_right_upper(P, A), qr_r(B, R)
    monkeypatch.setattr(nogil_lapack, "_routine", lambda module, name: None)
    slow = solve_right_upper(P, A), qr_r(B, R)
    assert all(np.array_equal(x, y) for x, y in zip(fast, slow, strict=True))


def test_an_unexpected_signature_falls_back_to_the_wrappers(monkeypatch):
    """A scipy whose exported routines have other C types (say 64-bit integers) is not called through
    prototypes written for these: the wrappers are used, with the same results."""
    rng = np.random.default_rng(5)
    P, A, B = _triangular(rng, 6), rng.standard_normal((30, 6)), rng.standard_normal((20, 6))
    monkeypatch.setitem(nogil_lapack.SIGNATURES, "dtrsm", nogil_lapack.SIGNATURES["dtrsm"].replace("int *", "long *"))
    monkeypatch.setitem(nogil_lapack.SIGNATURES, "dgeqrf", "void (void)")
    nogil_lapack._routine.cache_clear()
    try:
        assert nogil_lapack._routine("cython_blas", "dtrsm") is None
        assert nogil_lapack._routine("cython_lapack", "dgeqrf") is None
        assert np.array_equal(solve_right_upper(P, A), dtrsm(1.0, P, A, side=1, lower=0))
        assert np.array_equal(qr_r(B), np.linalg.qr(B, mode="r"))
    finally:
        nogil_lapack._routine.cache_clear()


def test_shape_mismatch_is_refused():
    with pytest.raises(ValueError, match="columns"):
        solve_right_upper(np.eye(3), np.ones((4, 2)))


def test_blocks_of_other_widths_are_refused_as_numpy_does():
    with pytest.raises(ValueError, match="do not stack"):
        qr_r(np.zeros((0, 4)), np.ones((6, 1)))
