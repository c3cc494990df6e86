"""Up-front work estimate of Krutikov's recursion (``dynamics/projection.py``): the matrices it
will multiply, counted on the maps' nonzero patterns."""

from __future__ import annotations

import numpy as np

from minparam_cli.dynamics.projection_terms import Y_SIZE, ProjectionGeometry


class _Support:
    """Bit masks of one map's nonzero pattern: for input entry i, the outputs it reaches, per y."""

    def __init__(self, M: np.ndarray, size: int):
        d = M.shape[1]
        nz = np.asarray(M != 0).reshape(size, d, d)  # [y, out, in]
        weights = 1 << np.arange(d, dtype=np.int64)
        self.size = size
        self.reach = [[int((nz[y, :, i] * weights).sum()) for i in range(d)] for y in range(size)]
        self.cache: dict[int, tuple[int, ...]] = {}

    def apply(self, pattern: int) -> tuple[int, ...]:
        """Output pattern per y of one input pattern (0: that output is zero and dropped)."""
        out = self.cache.get(pattern)
        if out is None:
            bits = [i for i in range(pattern.bit_length()) if pattern >> i & 1]
            out = tuple(_or(reach[i] for i in bits) for reach in self.reach)
            self.cache[pattern] = out
        return out


def _or(masks) -> int:
    m = 0
    for x in masks:
        m |= x
    return m


def recursion_work(geom: ProjectionGeometry) -> int:
    """Matrices the kinetic recursion multiplies, counted on the maps' nonzero patterns.

    The recursion of ``energy_blocks`` drops every zero matrix; a matrix is zero
    for the structure of the maps (right angles, axes along the frame axes) or by
    cancellation.  Walking the same tree on bit patterns of nonzero entries, with
    multiplicities, counts every matrix the recursion can produce (cancellations
    aside: an upper bound), in time proportional to the number of distinct
    patterns, not of matrices.  The time of ``derive_projection`` grows with it.
    """
    chain = geom.chain
    n = chain.n
    sup = [{k: _Support(geom.maps[c][k], Y_SIZE[chain.types[c]]) for k in ("AA", "DA", "AD", "DD")} for c in range(n)]
    kids = [chain.children(k) for k in range(-1, n)]  # kids[k + 1]
    total = 0

    def step(c: int, name: str, patterns: dict[int, int]) -> dict[int, int]:
        nonlocal total
        out: dict[int, int] = {}
        s = sup[c][name]
        for p, count in patterns.items():
            total += count * s.size
            for q in s.apply(p):
                if q:
                    out[q] = out.get(q, 0) + count
        return out

    def walk(kind: str, k: int, patterns: dict[int, int]) -> None:
        for c in kids[k + 1]:
            if kind == "N":
                walk("G", c, step(c, "DD", patterns))
                walk("M", c, step(c, "DA", patterns))
                walk("N", c, step(c, "AA", patterns))
            elif kind == "M":
                walk("G", c, step(c, "AD", patterns))
                walk("M", c, step(c, "AA", patterns))
            else:
                walk("G", c, step(c, "AA", patterns))

    walk("N", -1, {int(sum(1 << i for i in (0, 5, 10, 15))): 1})  # the identity, flattened 4x4
    return total
