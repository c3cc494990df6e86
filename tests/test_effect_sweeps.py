"""Effects computed for a whole grid at once (``Effect.sweep``, ``slots.sources_columns``): the same
numbers as one grid value at a time, and as the textbook formula to rounding."""

from __future__ import annotations

import numpy as np
import pytest

from minparam_cli.dynamics.effects import COGGING_GRID, EFFECTS, STRIBECK_GRID, Signals
from minparam_cli.identify.passes.slots import all_joints, sources_columns


def _signals(N=400, n=4, seed=0, span=3.2):
    rng = np.random.default_rng(seed)
    return Signals(t=np.arange(N) * 1e-3, q=rng.uniform(-span, span, (N, n)), dq=rng.standard_normal((N, n)),
                   ddq=rng.standard_normal((N, n)), tau_model=rng.standard_normal((N, n)))


def test_a_sweep_gives_the_columns_one_value_at_a_time_gives():
    s, n = _signals(), 4
    sources = ([("viscous", None)] + [("cogging", h) for h in COGGING_GRID] + [("stribeck", h) for h in STRIBECK_GRID]
               + [("position_error", h) for h in (3.0, 7.0, 2.5, 60.0)] + [("drift", None)]
               + [("cogging", h) for h in (60.0, 2.0, 3.0, 2.5, 64.0, 1.0, 65.0, -3.0, 0.0)])  # restarts, off-grid
    swept = sources_columns(sources, s, n)
    assert len(swept) == len(sources)
    for (e, h), cols in zip(sources, swept, strict=True):
        assert np.array_equal(cols, all_joints(e, s, n, h)), (e, h)


@pytest.mark.parametrize("effect", ["cogging", "position_error"])
@pytest.mark.parametrize("k", [2.0, 17.0, 60.0, 2.5, 64.0, 65.0, 200.0])
def test_ripple_columns_are_sin_and_cos_of_k_q(effect, k):
    s = _signals(span=np.pi)
    for j in range(s.q.shape[1]):
        q = s.q[:, j]
        cols = EFFECTS[effect].columns(s, j, k)
        # the phase k·q itself is only known to about k·|q|·eps
        assert np.allclose(cols, np.column_stack([np.sin(k * q), np.cos(k * q)]), rtol=0, atol=64 * k * np.pi * 2.3e-16)
