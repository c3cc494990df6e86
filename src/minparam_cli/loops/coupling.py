"""A closed chain as the coordinates every command reads: the actuated joints, with the passive
ones following through the loops.  ``ClosedCoupling`` is a ``chain.Coupling`` whose G depends on
the state: the regressor's rows are G(q)ᵀ·Y_tree at the tree state the loops give
(q from Newton on the closure, q̇ = G q̇_a, q̈ = G q̈_a + g), and ``random_states`` samples the
manifold, so ``derive_qr``, ``simulate``, ``identify`` and ``excite`` work on the actuated torques."""

from __future__ import annotations

import random
import threading
import weakref
from dataclasses import dataclass, field, replace

import numpy as np

from minparam_cli.chain import Chain, Coupling
from minparam_cli.errors import ComputationError
from minparam_cli.loops.model import CLOSED_RTOL, ClosedModel, closed_model
from minparam_cli.loops.sample import manifold_states


RECENT = 4  # closures a ClosedCoupling keeps per thread
# per thread, per coupling, its last RECENT closures (actuated q, tree q, error, tangent map): excite's criterion
# asks for the same states again and again (``ClosedCoupling._close``); outside the (pickled, frozen)
# coupling itself.  Only the same states are reused: a state near a recent one is closed from the reference
# as any other, since where the reference lies far from the motion the two can end in different assembly
# modes (the planar 3-RRR: docs/methods/closed_chains.md)
_RECENT = threading.local()


class LoopsNotClosed(ComputationError):
    """States at which the loops cannot be closed (outside the workspace or past a singularity)."""


@dataclass(frozen=True, eq=False)
class ClosedCoupling(Coupling):
    """The loops of ``model`` as a coupling: ``coordinates`` the actuated joints, ``G`` the tangent map
    at the reference (what a reader of a constant G sees), the state's own G in every computation."""

    model: ClosedModel | None = field(default=None, repr=False)

    def _close(self, q: np.ndarray):
        """``model.close_from_reference(q)`` and, where every state closed, ``model.tangent_map`` there (else
        None); for the same q as a recent call, copies of that call's."""
        model = self.model
        assert model is not None
        table = getattr(_RECENT, "table", None)
        if table is None:
            table = _RECENT.table = weakref.WeakKeyDictionary()
        recent = table.setdefault(self, [])
        for q0, qt0, err0, maps0 in recent:
            if q0.shape == q.shape and np.array_equal(q0, q):
                return qt0.copy(), err0.copy(), None if maps0 is None else (maps0[0].copy(), maps0[1].copy())
        qt, err = model.close_from_reference(q)
        maps = model.tangent_map(qt) if np.all(err < CLOSED_RTOL * model.chain.length_scale) else None
        recent.insert(0, (q.copy(), qt.copy(), err.copy(), None if maps is None else (maps[0].copy(), maps[1].copy())))
        del recent[RECENT:]
        return qt, err, maps

    def tree_states(self, q, qd, qdd):
        """(q, q̇, q̈) of every tree joint (N, n) and G (N, n, f) from the actuated ones (N, f)."""
        model = self.model
        assert model is not None
        q, qd, qdd = (np.atleast_2d(np.asarray(x, dtype=float)) for x in (q, qd, qdd))
        qt, err, maps = self._close(q)
        bad = np.flatnonzero(~(err < CLOSED_RTOL * model.chain.length_scale))
        if bad.size:
            raise LoopsNotClosed(f"{model.chain.source}: the loops cannot be closed at {bad.size} of {len(q)} states "
                                   f"(first: actuated joints at {np.round(q[bad[0]], 4).tolist()}): outside the workspace "
                                   "or past a singularity of the loops")
        G, pinv = maps
        qdt = np.einsum("snf,sf->sn", G, qd)
        g = model.drift(qt, qdt, pinv)
        return qt, qdt, np.einsum("snf,sf->sn", G, qdd) + g, G

    def joint_states(self, q, qd, qdd):
        return self.tree_states(q, qd, qdd)[:3]

    def coordinate_rows(self, q, qd, qdd, joint_rows):
        qt, qdt, qddt, G = self.tree_states(q, qd, qdd)
        Y = joint_rows(*(np.ascontiguousarray(x) for x in (qt, qdt, qddt)))
        return np.einsum("snf,snp->sfp", G, Y)

    @property
    def limited_passive(self) -> tuple[str, ...]:
        """Names of the passive joints with limits (``excite`` keeps them inside, ``limit_margins``)."""
        assert self.model is not None
        return tuple(self.model.chain.joint_names[j] for j in _limited(self.model))

    def limit_margins(self, q) -> tuple[np.ndarray, np.ndarray]:
        """Distances (N, 2k) of the limited passive joints from their lower and upper limits at the actuated
        positions ``q`` (N, f), and their derivatives (N, 2k, f) (rows of G)."""
        model = self.model
        assert model is not None
        qt, err, maps = self._close(np.atleast_2d(np.asarray(q, dtype=float)))
        joints = _limited(model)
        lo = np.array([model.chain.limits[j][0] for j in joints])  # type: ignore[index]  # _limited: not None
        hi = np.array([model.chain.limits[j][1] for j in joints])  # type: ignore[index]
        G = maps[0] if maps is not None else model.tangent(qt)[0]
        values = np.concatenate([qt[:, joints] - lo, hi - qt[:, joints]], axis=1)
        values[~(err < CLOSED_RTOL * model.chain.length_scale)] = -1.0  # not closed: as bad as a broken limit
        return values, np.concatenate([G[:, joints, :], -G[:, joints, :]], axis=1)

    def random_states(self, samples: int, rng):
        """Actuated (q, q̇, q̈) of ``samples`` states on the manifold (``loops/sample.py``)."""
        assert self.model is not None
        seed = rng.getrandbits(63) if isinstance(rng, random.Random) else int(rng.integers(2**63))
        q, qd, qdd, _ = manifold_states(self.model, samples, seed)
        a = list(self.model.actuated)
        return q[:, a], qd[:, a], qdd[:, a]


def closed_chain(desc, chain: Chain) -> Chain:
    """``chain`` (the spanning tree) with its loops as the coupling: the actuated joints are its coordinates."""
    model = closed_model(desc, chain)
    G, _ = model.tangent(model.reference[None, :])
    return replace(chain, coupling=ClosedCoupling(model.actuated, G[0], np.zeros(chain.n), model))


def with_loops(desc, chain: Chain) -> Chain:
    """``chain`` itself for a tree; for a closed chain, its spanning tree with the loops as the coupling."""
    return chain if desc.loops is None else closed_chain(desc, chain)


def _limited(model: ClosedModel) -> list[int]:
    return [j for j in model.passive if model.chain.limits and model.chain.limits[j] is not None]
