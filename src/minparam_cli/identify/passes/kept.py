"""What identify's streaming pass keeps beside the factors: the evenly thinned samples of the
diagnosis (``_Thinned``) and the motion of the data (``Motion``)."""

from __future__ import annotations

import numpy as np

from minparam_cli.measured.records import Block


class _Thinned:
    """Keeps every stride-th sample, doubling the stride whenever more than ``cap`` are held."""

    def __init__(self, cap: int):
        self.cap, self.stride, self.seen = cap, 1, 0
        self.blocks: list[Block] = []

    def add(self, b: Block) -> None:
        # the samples held are those of index i % stride == 0 (ceil(seen / stride) of them): the
        # stride after this block is known before anything is copied, so a chunk of samples
        # is never copied whole only to be halved again and again
        total = self.seen + len(b)
        stride = self.stride
        while -(-total // stride) > self.cap:
            stride *= 2
        if stride != self.stride and self.blocks:
            merged = Block.concat(self.blocks)
            self.blocks = [merged.take(slice(0, None, stride // self.stride))]
        self.stride = stride
        idx = np.flatnonzero((self.seen + np.arange(len(b))) % stride == 0)
        self.seen = total
        if len(idx):
            self.blocks.append(b.take(idx))

    def block(self) -> Block | None:
        return Block.concat(self.blocks) if self.blocks else None


class Motion:
    """Range of every joint's position over the fit data (names the joints an excitation missed), and
    per part the samples in which every joint stands still (a test block that mostly stands measures
    standstill, where the model has no static friction)."""

    def __init__(self, n: int):
        self.lo, self.hi = np.full(n, np.inf), np.full(n, -np.inf)
        self.still: dict[str, list[int]] = {}

    def count_still(self, part: str, b: Block, speed: float) -> None:
        c = self.still.setdefault(part, [0, 0])
        c[0] += int(np.all(np.abs(b.dq) < speed, axis=1).sum())
        c[1] += len(b)

    def still_share(self, part: str) -> float | None:
        still, total = self.still.get(part, (0, 0))
        return still / total if total else None

    def add(self, b: Block) -> None:
        self.lo = np.minimum(self.lo, b.q.min(axis=0))
        self.hi = np.maximum(self.hi, b.q.max(axis=0))

    @property
    def range(self) -> np.ndarray:
        return np.where(self.hi >= self.lo, self.hi - self.lo, 0.0)
