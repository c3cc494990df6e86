"""Weakly identifiable parameters and the geometry that keeps them.

A kept column whose residual is below ``WEAK_RTOL`` of the largest column
(``result.scan_margin``) is identifiable, but only just: typically because the
file's geometry is a few microradians or millimetres away from a special one
(π/2 written 1.57079; a joint origin 1.6 mm off the previous axis).  Such a
parameter is named with its margin and, when one is found, the relation
responsible.

Candidates are the relations that do not depend on the joint angles:

* the angle between a joint's axis and its parent's axis (or gravity, for a
  joint on the base) near 0 or 90°;
* the distance between a joint's axis and its parent's axis near 0
  (intersecting or coaxial axes).

Each candidate between RANK_RTOL and ``NEAR`` (rad, or fraction of the robot's
size) is made exact on a copy of the chain, by the smallest change: the
joint's fixed frame turned (about the common normal) or moved (along it), so
every frame after it follows rigidly.  The base set of that copy (QR route,
same samples and seed) is computed; a weak parameter that is no longer kept
there is explained by that candidate.
"""

from __future__ import annotations

from typing import Any

from minparam_cli.base.near_special import near_special_relations
from minparam_cli.base.result import WEAK_RTOL, BaseSet
from minparam_cli.chain import Chain

# at most this many candidates are tried (closest to special first): each costs one QR base set
MAX_CANDIDATES = 16


def weak_parameters(chain: Chain, base: BaseSet, explain: bool = True, samples: int = 100, seed: int = 0) -> list[dict]:
    """One dict per weakly identifiable parameter: name, margin, and the geometry found responsible."""
    weak = [(int(c), float(r)) for c, r in base.rank_margin.get("weak", [])]
    names = base.standard_names
    out: list[dict[str, Any]] = [{"parameter": names[c], "margin": r, "bound": WEAK_RTOL, "geometry": []} for c, r in weak]
    if not explain or not weak:
        return out
    from minparam_cli.base.qr import derive_qr

    # a relation at joint j changes how the links after j move: only those on the path to a weak link
    links = {c // 10 for c, _ in weak if c < chain.layout.n_inertial} | {chain.layout.extra_columns[c - chain.layout.n_inertial][0] for c, _ in weak if c >= chain.layout.n_inertial}
    upstream = set().union(*(chain.ancestors(k) for k in links)) if links else set()
    candidates = sorted((c for c in near_special_relations(chain) if c["joint"] in upstream), key=lambda c: c["delta"])
    for cand in candidates[:MAX_CANDIDATES]:
        kept = set(derive_qr(cand["chain"], samples=samples, seed=seed).kept)
        for entry, (c, _) in zip(out, weak, strict=True):
            if c not in kept:
                entry["geometry"].append(cand["text"])
    return out
