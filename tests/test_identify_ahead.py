"""identify's streaming pass on two threads (identify.ahead) and the sized-before-copy thinning of
the diagnosis samples: the same items, errors and samples as the one-thread code they replace."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from minparam_cli.errors import DataError
from minparam_cli.identify.passes.ahead import ahead
from minparam_cli.measured.records import Block
from minparam_cli.identify.passes.kept import _Thinned


def test_items_in_order_and_bounded():
    produced = []

    def gen():
        for i in range(50):
            produced.append(i)
            yield i

    seen = []
    for x in ahead(gen(), depth=2):
        seen.append(x)
        # the producer is never more than depth + 1 items ahead (queue + the one it holds)
        assert len(produced) - len(seen) <= 3
    assert seen == list(range(50))


def test_producer_error_raised_where_the_item_would_come():
    def gen():
        yield 1
        yield 2
        raise DataError("bad row on line 7")

    got = []
    with pytest.raises(DataError, match="line 7"):
        for x in ahead(gen()):
            got.append(x)
    assert got == [1, 2]


def test_consumer_stopping_early_closes_the_producer_and_its_thread():
    closed = threading.Event()

    def gen():
        try:
            for i in range(10_000):
                yield i
        finally:
            closed.set()

    before = threading.active_count()
    for x in ahead(gen()):
        if x == 3:
            break
    assert closed.is_set()  # the generator's finally ran (files, helper processes released)
    assert threading.active_count() == before


def test_consumer_error_stops_the_producer():
    closed = threading.Event()

    def gen():
        try:
            yield from range(10_000)
        finally:
            closed.set()

    with pytest.raises(KeyError):
        for x in ahead(gen()):
            if x == 5:
                raise KeyError("consumer")
    assert closed.is_set()


class _OldThinned:
    """The thinning as it was: copy, then halve while more than cap are held."""

    def __init__(self, cap):
        self.cap, self.stride, self.seen, self.blocks = cap, 1, 0, []

    def add(self, b):
        idx = np.flatnonzero((self.seen + np.arange(len(b))) % self.stride == 0)
        self.seen += len(b)
        if len(idx):
            self.blocks.append(b.take(idx))
        while sum(len(x) for x in self.blocks) > self.cap:
            merged = Block.concat(self.blocks)
            self.blocks = [merged.take(slice(0, None, 2))]
            self.stride *= 2


@pytest.mark.parametrize("seed", range(6))
def test_thinning_keeps_the_same_samples(seed):
    rng = np.random.default_rng(seed)
    cap = int(rng.integers(5, 400))
    new, old = _Thinned(cap), _OldThinned(cap)
    t0 = 0
    for _ in range(int(rng.integers(1, 30))):
        m = int(rng.integers(0, 700))
        t = np.arange(t0, t0 + m, dtype=float)
        t0 += m
        b = Block(t, *(rng.standard_normal((m, 2)) for _ in range(4)))
        new.add(b)
        old.add(b)
        assert new.stride == old.stride
    a = new.block()
    ref = Block.concat(old.blocks) if old.blocks else None
    if ref is None:
        assert a is None
        return
    assert len(a) <= cap
    for k in ("t", "q", "dq", "ddq", "tau"):
        assert np.array_equal(getattr(a, k), getattr(ref, k))


@pytest.mark.parametrize("shuffle", [False, True])
def test_block_grams_equal_the_grams_of_each_time_block(shuffle):
    """BlockGrams.add (runs of equal block index, one syrk per joint) against A_jᵀA_j of each
    block's rows computed directly; times in any order (runs of one block are summed)."""
    from minparam_cli.identify.assess.uncertainty import BlockGrams

    rng = np.random.default_rng(3)
    N, n, w = 5000, 3, 6
    t = np.sort(rng.uniform(0, 9.5, N))
    rows = rng.standard_normal((N, n, w))
    if shuffle:
        perm = rng.permutation(N)
        t, rows = t[perm], rows[perm]
    g = BlockGrams(1.0, max_blocks=1000)
    for s in range(0, N, 777):
        g.add(t[s : s + 777], rows[s : s + 777])
    k = np.floor((t - t[0]) / 1.0).astype(int)
    assert sorted(g.packed) == sorted(set(k.tolist()))
    for b in g.packed:
        G = g.gram(b)
        sel = rows[k == b]
        assert g.rows[b] == len(sel)
        for j in range(n):
            ref = sel[:, j].T @ sel[:, j]
            assert np.allclose(G[j], ref, rtol=1e-12, atol=1e-12 * np.abs(ref).max())


def test_the_producer_sees_the_callers_context_variables():
    """The Python API registers in-memory arrays in a context variable; the reading thread must see them."""
    import contextvars

    from minparam_cli.identify.passes.ahead import ahead

    var: contextvars.ContextVar[str] = contextvars.ContextVar("probe", default="unset")
    var.set("caller's")

    def gen():
        for _ in range(3):
            yield var.get()

    assert list(ahead(gen())) == ["caller's"] * 3


def test_block_grams_of_column_subsets_land_in_their_place():
    """add_parts with each joint's own columns (a run, or scattered) stores, packed, the Gram the
    full rows would give: zeros where a joint has no column."""
    from minparam_cli.identify.assess.uncertainty import BlockGrams

    rng = np.random.default_rng(4)
    w, N = 7, 300
    cols = [np.arange(w), np.array([2, 3, 4, 5, 6]), np.array([0, 3, 6])]
    rows = np.zeros((len(cols), w, N))
    for j, c in enumerate(cols):
        rows[j, c] = rng.standard_normal((len(c), N))
    t = np.linspace(0.0, 2.99, N)
    g = BlockGrams(1.0)
    segments = g.segments(t)
    assert [b for b, _, _ in segments] == [0, 1, 2]
    parts = [(c, [rows[j][c][:, s:e] @ rows[j][c][:, s:e].T for _, s, e in segments]) for j, c in enumerate(cols)]
    g.add_parts(segments, parts, w)
    for b, s, e in segments:
        G = g.gram(b)
        for j in range(len(cols)):
            A = rows[j][:, s:e]
            assert np.allclose(G[j], A @ A.T, rtol=1e-13, atol=1e-13)
        assert g.rows[b] == e - s
