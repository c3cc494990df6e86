"""identify at scale: the fast factor update, the single streaming pass, the compressed diagnosis.

Each shortcut is checked against the direct computation it replaces.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from minparam_cli.identify import stage

from minparam_cli.identify.estimate import accumulate
from minparam_cli.identify.passes.stream import stream
from minparam_cli.identify.estimate.accumulate import Accumulator
from minparam_cli.identify.diagnosis.compressed import Compressed
from minparam_cli.measured.blocks import time_span
from minparam_cli.identify.passes.design import Design, Term
from minparam_cli.identify.diagnosis.diagnose import _basis, diagnose
from minparam_cli.dynamics.effects import EFFECT_IDS
from minparam_cli.identify.estimate.fit import independent_columns, solve
from minparam_cli.identify.passes.roles import plan
from minparam_cli.identify.diagnosis.scoring import score
from minparam_cli.identify.passes.slots import final_maps, slot_sources


def _rows(rng, N, n=3):
    """Rows with the awkward cases: an exactly dependent column, one that is zero until half-way,
    one that is zero for a joint throughout, and columns of very different scales."""
    t = np.arange(N) / 100.0
    X = rng.standard_normal((N, n, 6)) * np.array([1.0, 1e3, 1e-3, 1.0, 1.0, 1.0])
    X[:, :, 0] += np.sin(t)[:, None]
    X[:, :, 3] = X[:, :, 0] - 2.0 * X[:, :, 2]  # dependent
    X[: N // 2, :, 4] = 0.0  # unseen, then seen
    X[:, 1, 5] = 0.0  # structurally zero on joint 2
    y = X @ np.array([1.0, 2e-3, 5.0, 0.0, -1.0, 0.5]) + 0.01 * rng.standard_normal((N, n))
    return X, y


def _accumulate(X, y, block, fast=True, monkeypatch=None):
    if not fast:
        monkeypatch.setattr(accumulate, "_fast", lambda R, A, segments=None: None)
    acc = Accumulator(X.shape[1], X.shape[2])
    for s in range(0, len(y), block):
        acc.add(X[s : s + block], y[s : s + block])
    return acc


def test_fast_update_equals_householder(monkeypatch):
    X, y = _rows(np.random.default_rng(5), 20_000)
    fast = _accumulate(X, y, 1000)
    calls = {"fast": 0}
    real = accumulate._fast

    def counting(R, A, segments=None):
        out = real(R, A, segments)
        calls["fast"] += out is not None
        return out

    monkeypatch.setattr(accumulate, "_fast", counting)
    _accumulate(X, y, 1000)
    assert calls["fast"] > 30  # the fast path did the work
    slow = _accumulate(X, y, 1000, fast=False, monkeypatch=monkeypatch)
    for Rf, Rs in zip(fast.R, slow.R, strict=True):
        Gf, Gs = Rf.T @ Rf, Rs.T @ Rs
        scale = np.sqrt(np.outer(np.diag(Gs), np.diag(Gs))) + 1e-300
        assert np.max(np.abs(Gf - Gs) / scale) < 1e-12
    assert independent_columns(fast) == independent_columns(slow) == [0, 1, 2, 4, 5]
    names = tuple(f"c{i}" for i in range(6))
    a, b = solve(fast, names), solve(slow, names)
    assert np.allclose(a.theta, b.theta, rtol=1e-10) and np.allclose(a.std_percent, b.std_percent, rtol=1e-8)
    assert fast.R[1][:, 5].tolist() == [0.0] * len(fast.R[1])


@pytest.mark.parametrize("fast", [True, False])
def test_segment_grams_from_the_update_equal_the_rows_grams(monkeypatch, fast):
    """add_columns with segments returns each segment's A_jᵀA_j over the joint's active columns: on
    the fast path as Pᵀ(B_sᵀB_s)P from the products the update forms, on Householder's directly;
    the factor is the one add_columns gives without segments."""
    X, y = _rows(np.random.default_rng(9), 6000)
    rows = np.concatenate([X, y[:, :, None]], axis=2)
    plain = _accumulate(X, y, 1500)
    if not fast:
        monkeypatch.setattr(accumulate, "_fast", lambda R, A, segments=None: None)
    acc = Accumulator(X.shape[1], X.shape[2])
    for s0 in range(0, 6000, 1500):
        cols = np.ascontiguousarray(rows[s0 : s0 + 1500].transpose(1, 2, 0))
        segments = [(0, 400), (400, 401), (401, 1500)]
        out = acc.add_columns(cols, segments)
        for j, (active, grams) in enumerate(out):
            for (a, b), G in zip(segments, grams, strict=True):
                A = rows[s0 + a : s0 + b, j][:, active]
                ref = A.T @ A
                scale = np.sqrt(np.outer(np.diag(ref), np.diag(ref))) + 1e-300
                assert np.max(np.abs(G - ref) / scale) < 1e-9
            assert 5 not in active or j != 1  # joint 2's zero column is never factored
    for Ra, Rb in zip(acc.R, plain.R, strict=True):
        assert np.allclose(Ra.T @ Ra, Rb.T @ Rb, rtol=1e-10, atol=1e-10 * np.abs(Rb.T @ Rb).max())


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_rows_are_named(bad):
    """(A dq of 1e200 in a file, whose square overflows in the row: tests/test_identify_reading.py.)"""
    X, y = _rows(np.random.default_rng(2), 3000)
    acc = _accumulate(X[:2000], y[:2000], 1000)
    X[2500, 2, 1] = bad
    cols = np.ascontiguousarray(np.concatenate([X[2000:], y[2000:, :, None]], axis=2).transpose(1, 2, 0))
    with pytest.raises(accumulate.NonFiniteRows, match="joint 3"):
        acc.add_columns(cols, [(0, 1000)])


def _panda_sample(tmp_path: Path, samples: int = 12_000) -> Path:
    from minparam_cli.chain import build_chain
    from minparam_cli.describe import load_description
    from minparam_cli.dynamics.regressor import regressor
    from minparam_cli.dynamics.inertia import random_inertia

    chain = build_chain(load_description(Path("robots/panda.yaml")))
    rng = np.random.default_rng(1)
    phi = random_inertia(chain.n, chain.length_scale, rng).phi
    w = 2 * np.pi * 0.1 * np.arange(1, 6)
    a, b = rng.uniform(-0.3, 0.3, (2, chain.n, 5))
    t = np.arange(samples) / 200.0
    wt = np.outer(t, w)
    q = (np.sin(wt) / w) @ a.T - (np.cos(wt) / w) @ b.T
    dq = np.cos(wt) @ a.T + np.sin(wt) @ b.T
    ddq = (-np.sin(wt) * w) @ a.T + (np.cos(wt) * w) @ b.T
    tau = regressor(chain, q, dq, ddq) @ phi + 0.3 * np.sign(dq) + 0.5 * dq + 0.05 * np.sin(q) + 0.01 * rng.standard_normal(q.shape)
    n = chain.n
    header = ",".join(["t"] + [f"{k}{j}" for k in ("q", "dq", "ddq", "tau") for j in range(1, n + 1)])
    path = tmp_path / "panda.csv"
    np.savetxt(path, np.hstack([t[:, None], q, dq, ddq, tau]), delimiter=",", header=header, comments="", fmt="%.12g")
    return path


@pytest.fixture(scope="module")
def panda_setup(tmp_path_factory):
    from minparam_cli.base.qr import derive_qr
    from minparam_cli.robot import DeriveOptions, load_chain

    path = _panda_sample(tmp_path_factory.mktemp("scale"))
    _, chain = load_chain(Path("robots/panda.yaml"), DeriveOptions())
    base = derive_qr(chain, seed=0)
    opts = stage.IdentifyOptions()
    sources = plan(path, None, (), opts.split, time_span(path, opts.data))
    slots = slot_sources(EFFECT_IDS)
    acc, thin, _, _, design = stream(Design(chain, base.kept, base.base_names), sources, chain.n, opts.data, opts.diagnosis_cap, keep=True, slots=slots)
    fit0 = solve(acc["fit"].restrict(list(range(design.p))), design.names)
    theta = np.zeros(design.p)
    theta[list(fit0.columns)] = fit0.theta
    return replace(design, theta_model=theta), acc, thin, sources, slots, opts


# a term of every slotted effect (and of coulomb and gain, combinations of slots and base columns)
_SLOTTED_TERMS = (Term("asymmetric_coulomb", (0, 2, 3, 5, 6)), Term("coulomb", (1,)), Term("offset", (4,)),
                  Term("gain", (0, 1, 2, 3, 4, 5, 6)), Term("viscous", (4,)))


@pytest.mark.parametrize("smoothing", [0.0, 0.05])
def test_slot_rows_map_to_the_final_designs_rows(panda_setup, smoothing):
    """Row by row, [X_j | S_j | τ_j] M_j = [final design's columns on joint j | τ_j], with samples standing
    exactly still (q̇ = 0, where sign q̇ = 0) on some joints, with and without a smooth Coulomb law."""
    from minparam_cli.identify.passes.slots import block_rows
    from minparam_cli.measured.records import Block

    design, _, thin, _, slots, _ = panda_setup
    design = replace(design, chain=replace(design.chain, coulomb_smoothing=smoothing))
    b = thin["fit"].block().take(slice(0, 600))
    dq = b.dq.copy()
    dq[100:160, 4] = 0.0
    dq[300:420, 1] = 0.0
    dq[::7, 0] = 0.0
    b = Block(b.t, b.q, dq, b.ddq, b.tau)
    final = design
    for term in _SLOTTED_TERMS:
        final = final.with_term(term)
    maps = final_maps(final, slots)
    assert maps is not None
    rows = block_rows(design, slots, b)
    want = block_rows(final, (), b)
    for j, M in enumerate(maps):
        got = rows[j].T @ M
        assert np.allclose(got, want[j].T, rtol=1e-13, atol=1e-13 * np.abs(want[j]).max()), j


def test_final_fit_from_the_slots_equals_a_second_pass(panda_setup):
    design, acc, _, sources, slots, opts = panda_setup
    final = design
    for term in _SLOTTED_TERMS:
        final = final.with_term(term)
    maps = final_maps(final, slots)
    assert maps is not None
    again, _, _, _, _ = stream(final, sources, design.chain.n, opts.data, opts.diagnosis_cap, keep=False)
    for part in ("fit", "selection", "test1"):
        a = solve(acc[part].transform(maps), final.names)
        b = solve(again[part], final.names)
        assert a.columns == b.columns
        assert np.allclose(a.theta, b.theta, rtol=1e-8, atol=1e-10 * np.max(np.abs(b.theta)))
    for extra in (Term("cogging", (1,), 5.0), Term("stribeck", (2,), 0.05), Term("load_coulomb", (0,)), Term("spring", (1,)),
                  Term("drift", (3,)), Term("rotor_inertia", (6,)), Term("gravity_error", (5,))):
        assert final_maps(final.with_term(extra), slots) is None  # no slot: a second pass


def test_compressed_scores_equal_direct_least_squares(panda_setup):
    design, _, thin, _, _, _ = panda_setup
    train, hold = thin["fit"].block(), thin["selection"].block()
    model = design.with_term(Term("gain", (0, 1, 2, 3, 4, 5, 6)))  # rank deficient: gain on every joint rescales θ
    data = Compressed.of(model, train, hold, EFFECT_IDS)
    sel = data.selection(model)
    sigma = data.joint_sigma(sel)
    Xw, yw = data.stack(sel, sigma)
    Q, back = _basis(Xw, data.N * data.n)
    theta = back @ (Q.T @ yw)
    Xhw, yhw = data.stack(sel, sigma, hold=True)
    rh0 = yhw - Xhw @ theta
    cands = [Term("viscous", (0, 1, 2, 3, 4, 5, 6)), Term("coulomb", (2,)), Term("cogging", (3,), 7.0), Term("spring", (1,)),
             Term("stribeck", (0, 1, 2, 3, 4, 5, 6), 0.1), Term("rotor_inertia", (0,)), Term("gravity_error", (1,))]
    got = score(data, sel, sigma, Q, back, yw - Xw @ theta, rh0, cands)
    y, yh = train.tau, hold.tau
    for k, term in enumerate(cands):
        full = model.with_term(term)
        X, Xh = full.columns(train), full.columns(hold)
        Xs = (X / sigma[None, :, None]).reshape(-1, full.p)
        th, *_ = np.linalg.lstsq(Xs, (y / sigma).reshape(-1), rcond=None)
        rssh = np.sum(((yh - Xh @ th) / sigma) ** 2)
        rss = np.sum(((y - X @ th) / sigma) ** 2)
        assert got.rssh1[k] == pytest.approx(rssh, rel=1e-9) and got.rss1[k] == pytest.approx(rss, rel=1e-9)
    # a spring K·(q − q₀) adds q2 and 1; sin q2, cos q2 (gravity_error) are in the gravity columns of joint 2;
    # the rotor inertia of joint 1 regroups with Izz1
    assert got.m.tolist() == [7, 1, 2, 2, 7, 0, 0]


def test_diagnosis_finds_the_hidden_effects_and_drift_has_one_origin(panda_setup):
    design, _, thin, _, _, _ = panda_setup
    d = diagnose(design, thin["fit"].block(), thin["selection"].block(), stage.DiagnosisOptions())
    assert {(t.effect, t.joints) for t in d.design.terms} >= {("viscous", tuple(range(7)))}
    hold = thin["selection"].block()
    drift = Design(design.chain, design.kept, design.base_names, terms=(Term("drift", (0,)),), t0=design.t0).columns(hold)[:, 0, -1]
    assert np.array_equal(drift, hold.t - design.t0)  # the held-out part measures drift from the record's start too


def test_background_parsing_gives_the_same_chunks_and_errors(tmp_path, monkeypatch):
    from minparam_cli.errors import DataError
    from minparam_cli.measured import tables
    from minparam_cli.measured.blocks import load_all
    from minparam_cli.measured.records import DataOptions, DataReport

    rng = np.random.default_rng(2)
    N = 3000
    t = np.arange(N) / 100.0
    q, dq, tau = rng.standard_normal((3, N, 2))
    q[10, 1] = np.nan
    path = tmp_path / "d.csv"
    header = "t,q1,q2,dq1,dq2,ddq1,ddq2,tau1,tau2"
    np.savetxt(path, np.hstack([t[:, None], q, dq, dq, tau]), delimiter=",", header=header, comments="")
    opts = DataOptions(chunk_rows=700)
    runs = []
    for limit in (1 << 40, 0):  # sequential, then in the second process
        monkeypatch.setattr(tables, "BACKGROUND_BYTES", limit)
        rep = DataReport(str(path))
        runs.append((load_all(path, 2, opts, rep), rep.as_dict()))
    (a, ra), (b, rb) = runs
    assert ra == rb and all(np.array_equal(getattr(a, k), getattr(b, k)) for k in ("t", "q", "dq", "ddq", "tau"))
    lines = path.read_text().splitlines()
    lines[2001] = lines[2001].replace(",", ",x", 1)  # a bad value in the third chunk
    path.write_text("\n".join(lines) + "\n")
    messages = []
    for limit in (1 << 40, 0):
        monkeypatch.setattr(tables, "BACKGROUND_BYTES", limit)
        with pytest.raises(DataError) as err:
            load_all(path, 2, opts)
        messages.append(str(err.value))
    assert messages[0] == messages[1]
    assert messages[0].endswith(f"non-numeric value {lines[2001].split(',')[1]!r} on line 2002, column 2 (q1)")



def test_compressed_factors_do_not_depend_on_the_worker_count(panda_setup, monkeypatch):
    from minparam_cli import runtime

    design, _, thin, _, _, _ = panda_setup
    train, hold = thin["fit"].block(), thin["selection"].block()
    factors = {}
    for count in (1, 3, 7):
        monkeypatch.setattr(runtime, "workers", lambda cap, count=count: min(cap, count))
        data = Compressed.of(design, train, hold, EFFECT_IDS)
        factors[count] = data.T + data.Th
    for count in (3, 7):
        assert all(np.array_equal(a, b) for a, b in zip(factors[1], factors[count], strict=True))


def test_workers_are_the_machines_and_bounded():
    import os

    from minparam_cli.runtime import workers

    cpus = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
    assert workers(1) == 1 and workers(0) == 1 and workers(10_000) == cpus and workers(2) == min(2, cpus)


@pytest.mark.parametrize("nudge, replaced, near_zero", [(0.0, True, False), (1e-10, True, False), (1e-3, False, False),
                                                       (1e-10, True, True)])
def test_a_simpler_term_spanning_the_same_columns_replaces_the_larger_one_whatever_the_rounding(
        panda_setup, monkeypatch, nudge, replaced, near_zero):
    """Asymmetric Coulomb beside an offset spans what Coulomb and the offset span (wherever q̇ ≠ 0), so the
    two models score the same up to rounding. The tie goes to the simpler model, whatever the sign of the
    rounding (``nudge``: added to the simpler model's score; on the real Panda recording the choice had
    followed the sign of a rounding error, ΔBIC_eff -0.0, which moved with the slots); a simpler model that
    scores worse (1e-3 relative) does not replace the larger one.  ``near_zero``: every score shifted so
    that the current model's is 0 (an unweighted score in N·m² can be), where a tolerance relative to the
    score alone would vanish."""
    from minparam_cli.identify.diagnosis import simplify as simplify_module
    from minparam_cli.identify.diagnosis.steps import Diagnosis

    design, _, thin, _, _, _ = panda_setup
    train, hold = thin["fit"].block(), thin["selection"].block()
    assert np.all(train.dq != 0) and np.all(hold.dq != 0)  # the spans are equal exactly
    joints = tuple(range(design.chain.dof))
    model = design.with_term(Term("asymmetric_coulomb", joints)).with_term(Term("offset", joints))
    real = simplify_module.selection_score

    data = Compressed.of(model, train, hold, EFFECT_IDS)
    shift = real(data, model, data.joint_sigma(data.selection(model), True), float(data.Nh * data.n))[0] if near_zero else 0.0

    def nudged(data, d, sigma, n_eff):
        score, *rest = real(data, d, sigma, n_eff)
        score -= shift
        if any(t.effect == "coulomb" for t in d.terms):
            score += nudge if nudge < 1e-6 else nudge * abs(score)
        return (score, *rest)

    monkeypatch.setattr(simplify_module, "selection_score", nudged)
    out = Diagnosis(design=model)
    simplify_module.simplify(out, data, True, lambda d, sigma: float(data.Nh * data.n))
    effects = [t.effect for t in out.design.terms]
    if replaced:
        assert "coulomb" in effects and "asymmetric_coulomb" not in effects, effects
        step = out.steps[0].statistic
        assert step["replaces"] == "asymmetric_coulomb (joints 1,2,3,4,5,6,7)"
        assert abs(step["delta_bic_eff"]) < 1e-6  # a tie, not evidence
    else:
        assert "asymmetric_coulomb" in effects and "coulomb" not in effects, effects
