"""Two LAPACK/BLAS routines called without holding Python's GIL: the triangular solve of the factor
update, and the R of a QR factorisation.

scipy's ``scipy.linalg.blas.dtrsm`` (an f2py wrapper) and numpy's ``linalg.qr`` keep the GIL for
the whole computation, so identify's other threads (the CSV reader, the regressor kernel, the
diagnosis's second factorisation) stop whenever one of them runs.  Here the same routines, from the
BLAS and LAPACK scipy ships, are taken from ``scipy.linalg.cython_blas`` / ``cython_lapack`` (the
tables of function pointers scipy exports for compiled callers; numba finds its BLAS the same way)
and called through ctypes, which releases the GIL for a foreign call.  Where a pointer cannot be
had, scipy's and numpy's wrappers are used instead (the same results, with the GIL held).
"""

from __future__ import annotations

import ctypes
from functools import lru_cache

import numpy as np

from minparam_cli.runtime import await_preload

_INT = ctypes.POINTER(ctypes.c_int)
_DBL = ctypes.POINTER(ctypes.c_double)
_CHR = ctypes.c_char_p
# the C signatures the ctypes prototypes below assume (scipy's capsule names them, its double typedef
# read as double): another signature (a future scipy, a 64-bit integer build) falls back to the wrappers
SIGNATURES = {
    "dtrsm": "void (char *, char *, char *, char *, int *, int *, double *, double *, int *, double *, int *)",
    "dgeqrf": "void (int *, int *, double *, int *, double *, double *, int *, int *)",
}
_ARGS = {"dtrsm": (_CHR, _CHR, _CHR, _CHR, _INT, _INT, _DBL, _DBL, _INT, _DBL, _INT),
         "dgeqrf": (_INT, _INT, _DBL, _INT, _DBL, _DBL, _INT, _INT)}
INT_MAX = 2**31 - 1


@lru_cache(maxsize=None)
def _routine(module: str, name: str):
    """``name`` from scipy.linalg.<module>'s table of pointers as a ctypes function, or None."""
    await_preload()  # scipy imported on one thread at a time (runtime.preload)
    try:
        import importlib

        capsule = importlib.import_module(f"scipy.linalg.{module}").__pyx_capi__[name]
        # prototypes of our own: setting restype on ctypes.pythonapi's would change them for the process
        get_name = ctypes.PYFUNCTYPE(ctypes.c_char_p, ctypes.py_object)(("PyCapsule_GetName", ctypes.pythonapi))
        get_pointer = ctypes.PYFUNCTYPE(ctypes.c_void_p, ctypes.py_object, ctypes.c_char_p)(
            ("PyCapsule_GetPointer", ctypes.pythonapi))
        signature = get_name(capsule)
        address = get_pointer(capsule, signature)
    except (ImportError, AttributeError, KeyError, ValueError, TypeError):
        return None
    if not address or _plain(signature.decode("ascii", "replace")) != SIGNATURES[name]:
        return None
    return ctypes.CFUNCTYPE(None, *_ARGS[name])(address)


def _plain(signature: str) -> str:
    """A capsule's signature with Cython's typedef of double (``__pyx_t_5scipy_6linalg_11cython_blas_d``) as double."""
    import re

    return re.sub(r"__pyx_t_\w+?_d\b", "double", signature)


def _int(v: int):
    return ctypes.byref(ctypes.c_int(v))


def _ptr(a: np.ndarray):
    return a.ctypes.data_as(_DBL)


def solve_right_upper(P: np.ndarray, A: np.ndarray) -> np.ndarray:
    """A P⁻¹ for an upper triangular P (c x c) and A (N x c): a new Fortran-ordered array."""
    f = _routine("cython_blas", "dtrsm")
    N, c = A.shape
    if P.shape != (c, c):
        raise ValueError(f"solve_right_upper: P is {P.shape}, A has {c} columns")
    if f is None or N > INT_MAX:
        from scipy.linalg.blas import dtrsm

        return dtrsm(1.0, P, A, side=1, lower=0)
    B = np.array(A, dtype=np.float64, order="F")  # the solve overwrites it
    if N and c:
        Pf = np.asfortranarray(P, dtype=np.float64)
        f(b"R", b"U", b"N", b"N", _int(N), _int(c), ctypes.byref(ctypes.c_double(1.0)), _ptr(Pf), _int(c), _ptr(B), _int(N))
    return B


def qr_r(*blocks: np.ndarray) -> np.ndarray:
    """R (min(m, c) x c, upper triangular) of the QR factorisation of the blocks stacked (m rows, c
    columns), as ``numpy.linalg.qr(numpy.vstack(blocks), mode="r")``: the same bits with one BLAS
    thread (the command line's setting; numpy and scipy ship their own OpenBLAS builds, whose
    threaded blocking may round differently in the last bit)."""
    f = _routine("cython_lapack", "dgeqrf")
    c = blocks[0].shape[1]
    if any(b.ndim != 2 or b.shape[1] != c for b in blocks):
        raise ValueError(f"qr_r: blocks of {[b.shape for b in blocks]} columns do not stack")
    m = sum(len(b) for b in blocks)
    if f is None or not m or not c or m > INT_MAX:
        return np.linalg.qr(np.vstack(blocks), mode="r")  # type: ignore[return-value]  # numpy stubs: qr() gives QRResult for every mode; mode="r" returns R
    M = np.empty((m, c), order="F")
    r = 0
    for b in blocks:
        M[r : r + len(b)] = b
        r += len(b)
    k = min(m, c)
    tau = np.empty(k)
    info = ctypes.c_int(0)
    query = np.empty(1)
    f(_int(m), _int(c), _ptr(M), _int(m), _ptr(tau), _ptr(query), _int(-1), ctypes.byref(info))
    work = np.empty(max(1, int(query[0])))
    f(_int(m), _int(c), _ptr(M), _int(m), _ptr(tau), _ptr(work), _int(len(work)), ctypes.byref(info))
    if info.value != 0:  # an argument LAPACK refused: never with the shapes built here
        raise ValueError(f"dgeqrf: argument {-info.value} refused")
    return np.triu(M[:k])
