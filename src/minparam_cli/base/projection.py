"""Base parameters by Krutikov's method of projections (paper 000), without random samples.

1. Z, the coordinates of every parameter's influence coefficient on the
   Lagrangian in the basis B of the theorem, comes from the forward recursion
   of ``dynamics/projection.py`` in blocks, never as a dense matrix.
2. The blocks are reduced as they arrive.  Rows whose deepest joint is t are
   Ψ_t (a fixed matrix) times at most 11 numbers, so a basis of the span of
   those numbers, mapped by Ψ_t, spans the same rows: exactly (integer
   arithmetic) in exact mode, or with the same Gram matrix Zᵀ Z (QR of the
   stacked blocks) in floating point.
3. Keep rule, as on the QR route (Gautier & Khalil 1990): scan the columns in
   the standard order, keep a column unless it is a combination of the kept
   columns before it.  These are the pivot columns of the echelon form of Z.
4. Y = Z̄⁺ Z with Z̄ the kept columns: base = kept + β · dependent.  In exact
   mode β comes from the reduced echelon form, as fractions.

Exact mode (``chain.exact`` is not None: rational lengths, right angles) runs
the recursion and the elimination in integers, lengths rescaled by their
common denominator; the answer is certified, with no tolerance.  Otherwise
the recursion runs in float64 and the rank margin is reported as on the QR
route.  This module never calls the QR route: the two check each other.
"""

from __future__ import annotations

import time
from fractions import Fraction
from typing import Callable

import numpy as np

from minparam_cli.base.echelon import ExactRowSpace, FloatRowSpace, integer_rref
from minparam_cli.base.result import (
    RANK_RTOL,
    SMALL_RTOL,
    BaseSet,
    beta_from_unit_columns,
    physical_scales,
    regrouping_matrix,
    scan_in_order,
    scan_margin,
    small_columns_that_regroup,
)
from minparam_cli.chain import REVOLUTE, Chain
from minparam_cli.dynamics.projection import KINETIC, KINETIC_DIM, POTENTIAL_DIM, energy_blocks
from minparam_cli.dynamics.projection_rows import basis_dimension, produced_rows, row_maps
from minparam_cli.dynamics.projection_work import recursion_work
from minparam_cli.dynamics.projection_terms import (
    FLOAT_EXACT_LIMIT,
    InexactFloat,
    ProjectionGeometry,
    exact_geometry,
    float_geometry,
)
from minparam_cli.errors import ComputationError, UnsupportedError

# Two up-front guards, both computed before any row of Z (docs/methods/projection.md, "Cost"):
# * MAX_ROWS bounds the rows of Z, from the joint types alone (dim B, the paper's count).
#   Memory stays ~100 MB whatever the size (the recursion is chunked), but the progress
#   counters and the basis grow with it.
# * MAX_WORK bounds the time: the matrices the recursion multiplies, counted on the
#   nonzero patterns of the joint maps (dynamics.projection_work.recursion_work), which sees
#   what the row count cannot: right angles and axes along frame axes make most products
#   zero (g1: 1.1e9 rows, 7.7e7 matrices, 5 s), generic angles do not (icub_reduced:
#   1.1e9 rows, 1.5e9 matrices, over 300 s).  Measured on the 2-core development VM,
#   15-180 ns per matrix on the robots that take over a second; 4e8 matrices is about a
#   minute at 150 ns, so that is the limit (PROJECTION_TIME_LIMIT_S).
MAX_ROWS = 4 * 10**9
MAX_WORK = 4 * 10**8
SECONDS_PER_MATRIX = 150e-9
PROJECTION_TIME_LIMIT_S = 60
# float mode: beta is accurate to ~1e-13 relative; keep 12 significant digits (as the QR route)

Progress = Callable[[int, int], None]


def projection_cost(chain: Chain) -> dict:
    """Up-front size of the computation: rows of Z the recursion will produce, and dim B."""
    kin, pot = produced_rows(chain)
    return {"rows": kin + pot, "kinetic_rows": kin, "potential_rows": pot, "basis_rows": basis_dimension(chain)}


def derive_projection(chain: Chain, progress: Progress | None = None) -> BaseSet:
    """Base parameter set of ``chain`` by the method of projections (``--method projection``)."""
    if chain.floating_base:
        raise UnsupportedError("the method of projections does not handle a floating base yet; use --method qr", chain.source)
    if chain.coupling is not None:
        raise UnsupportedError("the method of projections does not handle mimic joints yet; use --method qr (or --mimic fixed)", chain.source)
    if any(kind.startswith("motor_") for _, kind in chain.layout.extra_columns):
        raise UnsupportedError("the method of projections does not handle motor-side columns (transmission) yet; use --method qr", chain.source)
    t0 = time.perf_counter()
    cost = projection_cost(chain)
    if cost["rows"] > MAX_ROWS:
        raise ComputationError(
            f"{chain.source}: the method of projections would produce {cost['rows']:,} rows of Z for "
            f"{chain.n} joints (limit {MAX_ROWS:,}, about 11 revolute joints); use --method qr"
        )
    geom = exact_geometry(chain) if chain.exact is not None else float_geometry(chain)
    work = recursion_work(geom)
    if work > MAX_WORK:
        raise ComputationError(
            f"{chain.source}: the method of projections would multiply {work:.2g} matrices for {chain.n} joints "
            f"(limit {MAX_WORK:.0e}, about {PROJECTION_TIME_LIMIT_S} s; estimated {work * SECONDS_PER_MATRIX:.0f} s); use --method qr"
        )
    cost["work"] = work
    if chain.exact is not None:
        try:
            stream = _stream(geom, progress, cost["rows"])
        except InexactFloat:
            geom = exact_geometry(chain, python_ints=True)
            stream = _stream(geom, progress, cost["rows"])
        result = _exact_result(geom, stream)
    else:
        stream = _stream(geom, progress, cost["rows"])
        result = _float_result(geom, stream)
    kept, K, unident, margin, K_exact = result
    extra = {
        "basis_rows": cost["basis_rows"],
        "rows": cost["rows"],
        "nonzero_rows": stream["nonzero_rows"],
        "matrices_bound": cost["work"],
        "exact": geom.exact,
        "arithmetic": _arithmetic(geom),
    }
    if geom.exact:
        extra["length_unit_m"] = str(Fraction(1) / geom.length_scale)
    return BaseSet(
        standard_names=chain.layout.names,
        kept=tuple(kept),
        K=K,
        unidentifiable=tuple(unident),
        method="projection",
        rank_margin=margin,
        exact=geom.exact,
        elapsed_s=time.perf_counter() - t0,
        extra=extra,
        K_exact=K_exact,
    )


def _arithmetic(geom: ProjectionGeometry) -> str:
    if not geom.exact:
        return "float64"
    return "integers (float64, proven below 2**53)" if geom.dtype is np.float64 else "integers (Python)"


# --- step 1-2: stream the blocks of Z into per-node row spaces ------------------


def _stream(geom: ProjectionGeometry, progress: Progress | None, total: int) -> dict:
    n = geom.chain.n
    space = ExactRowSpace if geom.exact else FloatRowSpace
    kin = [space(KINETIC_DIM) for _ in range(n)]
    pot = [space(POTENTIAL_DIM) for _ in range(n)]
    maps = [row_maps(geom, t) for t in range(n)]
    counters = [[_NonzeroCounter(m, geom) for m in pair] for pair in maps]
    done = nonzero = 0
    step = max(total // 200, 1)
    next_report = 0
    if progress is not None:
        progress(0, total)
    for block in energy_blocks(geom):
        if block.rows:
            is_kin = block.kind == KINETIC
            (kin if is_kin else pot)[block.node].add(block.coords)
            nonzero += counters[block.node][0 if is_kin else 1].count(block.coords)
        done += block.rows + block.skipped
        if progress is not None and done >= next_report:
            progress(min(done, total), total)
            next_report = done + step
    if progress is not None:
        progress(total, total)
    return {"kin": kin, "pot": pot, "maps": maps, "nonzero_rows": nonzero}


class _NonzeroCounter:
    """Counts rows of Ψ @ coords with a nonzero entry (a diagnostic: the rows of Z that matter)."""

    def __init__(self, psi: np.ndarray, geom: ProjectionGeometry):
        psi = np.asarray(psi, dtype=np.float64)
        rows = np.flatnonzero(np.any(psi != 0, axis=1))
        self.psi = psi[rows]
        self.rowsum = float(np.abs(self.psi).sum(axis=1).max()) if rows.size else 0.0
        self.exact = geom.exact

    def count(self, coords: np.ndarray) -> int:
        if not self.psi.shape[0] or not coords.shape[1]:
            return 0
        c = np.asarray(coords, dtype=np.float64)
        z = self.psi @ c
        bound = float(np.abs(c).max()) * self.rowsum
        tol = 0.0 if (self.exact and bound < FLOAT_EXACT_LIMIT) else 64 * np.finfo(float).eps * bound
        return int(np.count_nonzero(np.any(np.abs(z) > tol, axis=0)))


def _extra_unit_rows(chain: Chain) -> list[int]:
    """Columns with a row of Z of their own: Coulomb, viscous, and the offset of a revolute joint."""
    cols = []
    for c, (j, kind) in enumerate(chain.layout.extra_columns):
        if kind in ("coulomb", "viscous") or (kind == "offset" and chain.types[j] == REVOLUTE):
            cols.append(chain.layout.n_inertial + c)
    return cols


# --- step 3-4, exact ---------------------------------------------------------


def _int_matrix(psi: np.ndarray) -> list[list[int]]:
    return [[int(v) for v in row] for row in psi]


def _exact_result(geom: ProjectionGeometry, stream: dict):
    chain = geom.chain
    P = chain.layout.size
    rows: list[list[int]] = []
    for t in range(chain.n):
        for space, psi in ((stream["kin"][t], stream["maps"][t][0]), (stream["pot"][t], stream["maps"][t][1])):
            psi_i = _int_matrix(psi)
            for b in space.rows:
                rows.append([sum(p * x for p, x in zip(prow, b, strict=True) if x) for prow in psi_i])
    for col in _extra_unit_rows(chain):
        rows.append([1 if c == col else 0 for c in range(P)])
    rows = [r for r in rows if any(r)]
    pivots, reduced = integer_rref(rows)
    nonzero_col = [any(r[c] for r in reduced) for c in range(P)]
    unident = [c for c in range(P) if not nonzero_col[c]]
    # relations in the rescaled units, then back to SI: beta_k = beta'_k * s_d / s_k
    s = geom.column_scales()
    K_exact = []
    for p, r in zip(pivots, reduced, strict=True):
        row = [Fraction(0)] * P
        row[p] = Fraction(1)
        for d in range(P):
            if d != p and d not in pivots and r[d]:
                row[d] = Fraction(r[d], r[p]) * s[d] / s[p]
        K_exact.append(tuple(row))
    K = np.array([[float(x) for x in row] for row in K_exact]).reshape(len(pivots), P)
    margin = {"criterion": "exact rational elimination", "tolerance": 0}
    return pivots, K, unident, margin, tuple(K_exact)


# --- step 3-4, floating point ------------------------------------------------------


def _float_result(geom: ProjectionGeometry, stream: dict):
    chain = geom.chain
    P = chain.layout.size
    blocks = []
    for t in range(chain.n):
        psi_k, psi_p = stream["maps"][t]
        blocks.append(stream["kin"][t].R @ (np.asarray(psi_k, dtype=float).T / geom.kinetic_scale))
        blocks.append(stream["pot"][t].R @ np.asarray(psi_p, dtype=float).T)
    for col in _extra_unit_rows(chain):
        e = np.zeros((1, P))
        e[0, col] = 1.0
        blocks.append(e)
    Zs = np.concatenate(blocks, axis=0)  # same Gram matrix as Z: same dependencies, same least squares
    rows_z = max(int(stream["nonzero_rows"]), 1)
    norms = np.linalg.norm(Zs, axis=0)
    # rows are energies; the columns in physical units, lengths in units of the robot's size (as on the QR route)
    size = norms * physical_scales(chain.layout, chain.types, chain.length_scale)[0]
    largest = size.max() if P else 0.0
    effect = size > RANK_RTOL * largest if largest > 0 else np.zeros(P, dtype=bool)
    # columns below the cut but above rounding: never kept, they regroup or have no effect (as on QR)
    small = (size > SMALL_RTOL * largest) & ~effect if largest > 0 else np.zeros(P, dtype=bool)
    Zn = np.zeros_like(Zs)
    Zn[:, effect | small] = Zs[:, effect | small] / norms[effect | small]
    rel = np.where(effect | small, size / largest if largest > 0 else 0.0, 0.0)
    kept, r = scan_in_order(Zn, rel)  # the keep rule of both routes (result.scan_in_order)
    acts = effect.copy()
    noise = small_columns_that_regroup(Zn, kept, [int(c) for c in np.flatnonzero(small)])
    acts[list(noise)] = True
    unident = [i for i in range(P) if not acts[i]]
    dropped = [i for i in range(P) if i not in set(kept)]
    if dropped and kept:
        beta_n, *_ = np.linalg.lstsq(Zn[:, kept], np.where(acts[dropped], Zn[:, dropped], 0.0), rcond=None)
        beta = beta_from_unit_columns(beta_n, norms, acts, kept, dropped, noise)
    else:
        beta = np.zeros((len(kept), len(dropped)))
    K = regrouping_matrix(kept, beta, dropped, P)
    criterion = "distance from the kept columns before it / largest column of Z, columns in physical units (lengths in units of the robot's size), scan order, full-size columns first"
    margin = scan_margin(r, kept, dropped, effect, criterion, RANK_RTOL, rows_z)
    return kept, K, unident, margin, None


__all__ = ["MAX_ROWS", "MAX_WORK", "derive_projection", "projection_cost"]
