"""The selection statistic under correlated residuals (docs/methods/selection.md) and the ripple naming."""

from __future__ import annotations

import math

import numpy as np
import pytest

from minparam_cli.dynamics.effects import MIN_PERIODS, periods_seen
from minparam_cli.identify.diagnosis.evidence import long_run_ratio, pieces


def _ar1(rho: float, n: int, rng) -> np.ndarray:
    e = rng.standard_normal(n)
    x = np.empty(n)
    x[0] = e[0] / math.sqrt(1 - rho**2)
    for k in range(1, n):
        x[k] = rho * x[k - 1] + e[k]
    return x


def test_white_noise_has_a_ratio_near_one_and_never_below():
    rng = np.random.default_rng(0)
    t = np.arange(20000) * 0.01
    r = long_run_ratio(rng.standard_normal((20000, 3)), t, horizon_s=0.3)
    assert 1.0 <= r < 1.1
    # anti-correlated residuals would make the evidence stronger than for independent samples: floored at 1
    alt = np.where(np.arange(2000) % 2 == 0, 1.0, -1.0)
    assert long_run_ratio(alt, t[:2000], horizon_s=0.3) == 1.0


@pytest.mark.parametrize("rho", [0.5, 0.8, 0.9])
def test_ar1_ratio_against_its_closed_form(rho):
    """An AR(1) residual's long-run variance ratio is (1 + ρ)/(1 − ρ); Bartlett's kernel over M lags
    gives 1 + 2 Σ (1 − l/(M+1)) ρ^l, which the estimate must match (independent computation)."""
    rng = np.random.default_rng(1)
    n, M = 200000, 60
    x = _ar1(rho, n, rng)
    t = np.arange(n) * 0.01
    expected = 1 + 2 * sum((1 - lag / (M + 1)) * rho**lag for lag in range(1, M + 1))
    assert long_run_ratio(x, t, horizon_s=M * 0.01) == pytest.approx(expected, rel=0.05)
    assert expected < (1 + rho) / (1 - rho)


def test_lags_never_cross_a_gap_or_a_file_boundary():
    """Two pieces of one constant-sign residual: joined, the lags across the gap would add correlation."""
    t = np.concatenate([np.arange(100) * 0.01, 50 + np.arange(100) * 0.01, np.arange(100) * 0.01])
    assert [(p.start, p.stop) for p in pieces(t)] == [(0, 100), (100, 200), (200, 300)]
    rng = np.random.default_rng(2)
    e = rng.standard_normal(300)
    whole = long_run_ratio(e, t, horizon_s=0.2)
    parts = [long_run_ratio(e[p], t[p], horizon_s=0.2) for p in pieces(t)]
    # the pooled ratio is the γ-weighted mean of the pieces' ratios (each floored at 1 only in the pool)
    gam = [float(np.sum(e[p] ** 2)) for p in pieces(t)]
    raw = [1 + 2 * sum((1 - lag / 21) * float(np.sum(e[p][:-lag] * e[p][lag:])) for lag in range(1, 21)) / g
           for p, g in zip(pieces(t), gam, strict=True)]
    assert whole == pytest.approx(max(sum(r * g for r, g in zip(raw, gam, strict=True)) / sum(gam), 1.0))
    assert len(parts) == 3


def test_periods_seen_and_the_cogging_name():
    # k = 2 over 1.5 rad: 0.48 of a period (the Panda's joint 4 in the issue) is no ripple
    assert periods_seen(1.5, 2) == pytest.approx(1.5 * 2 / (2 * math.pi))
    assert periods_seen(1.5, 2) < MIN_PERIODS <= periods_seen(1.5, 13)


def test_a_low_order_ripple_is_a_position_error_not_cogging():
    """The candidates of one joint: cogging only at orders whose periods the range covers 3 times."""
    from minparam_cli.base.qr import derive_qr
    from minparam_cli.identify.diagnosis.diagnose import candidates
    from minparam_cli.identify.passes.design import Design
    from minparam_cli.robot import DeriveOptions, load_chain
    from conftest import ROOT

    _, chain = load_chain(ROOT / "robots" / "planar2r.yaml", DeriveOptions())
    base = derive_qr(chain, seed=0)
    design = Design(chain, base.kept, base.base_names)
    span = np.array([1.0, 4.0])
    cands = candidates(design, ("cogging", "position_error"), span)
    for j in (0, 1):
        cog = sorted(t.hyper for t in cands if t.effect == "cogging" and t.joints == (j,))
        pos = sorted(t.hyper for t in cands if t.effect == "position_error" and t.joints == (j,))
        assert cog and pos and max(pos) < min(cog)
        assert all(periods_seen(span[j], k) >= MIN_PERIODS for k in cog)
        assert all(periods_seen(span[j], k) < MIN_PERIODS for k in pos)
        assert len(cog) + len(pos) == 59  # every order under one name or the other
