"""excite's race of the starts (experiment/excite/race.py): a start paused between stages takes the
same iterates as an uninterrupted SLSQP run, a stopped one returns the iterate it stopped at, the
best half goes on, and an error inside a start's run reaches the caller."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import minimize, rosen, rosen_der

from minparam_cli.errors import ComputationError
from minparam_cli.experiment.excite import race

# a constrained Rosenbrock problem in 6 variables: SLSQP needs 24-27 iterations from these starts, so the race
# has one stage of 8 iterations here (two stages, 8 and 16, in the test that says so)
STAGE = 8
CONS = [{"type": "ineq", "fun": lambda x: 1.5 - np.sum(x**2), "jac": lambda x: -2 * x}]


@pytest.fixture(autouse=True)
def short_stage(monkeypatch):
    monkeypatch.setattr(race, "RACE_STAGES", (STAGE,))


def solve(x0, maxiter, callback=None):
    return minimize(lambda x: (rosen(x), rosen_der(x)), x0, jac=True, method="SLSQP", constraints=CONS,
                    callback=callback, options={"maxiter": maxiter, "ftol": 1e-12})


def starts(count, maxiter):
    rng = np.random.default_rng(3)
    x0s = [rng.uniform(-0.5, 0.5, 6) for _ in range(count)]
    return x0s, [race.Start(lambda cb, x0=x0: solve(x0, maxiter, cb)) for x0 in x0s]


def test_paused_run_takes_the_uninterrupted_iterates():
    (x0,), (run,) = starts(1, 60)
    for target in (3, 5, 11):
        run.advance(target)
        assert run.iterations == target and run.result is None
    run.advance(float("inf"))
    plain = solve(x0, 60)
    assert run.result.nit == plain.nit
    assert np.array_equal(run.result.x, plain.x)  # bit for bit: the quasi-Newton state survived the pauses


def test_stopped_run_returns_the_iterate_it_stopped_at():
    (x0,), (run,) = starts(1, 60)
    run.advance(12)
    run.stop()
    assert np.array_equal(run.result.x, solve(x0, 12).x)  # SLSQP's first 12 iterates do not depend on maxiter


def test_race_keeps_the_best_half_at_the_race_iteration():
    x0s, runs = starts(4, 70)
    finalists = race.race(runs, 70)
    values = []
    for x0 in x0s:  # the criterion of each start after RACE_ITERATIONS iterations, uninterrupted
        seen = []

        def record(intermediate_result):
            seen.append(intermediate_result.fun)  # noqa: B023  # called within this loop pass

        solve(x0, STAGE, record)
        values.append(seen[-1])
    best = set(np.argsort(values)[:2])
    assert finalists == [i in best for i in range(4)]
    for x0, run, final in zip(x0s, runs, finalists, strict=True):
        expected = solve(x0, 70 if final else STAGE)
        assert np.array_equal(run.result.x, expected.x)
    assert sum(r.iterations for r in runs) <= race.planned_iterations(4, 70)


def uninterrupted_values(x0, iterations):
    """The criterion after every iteration of an uninterrupted run."""
    seen = []
    solve(x0, iterations, lambda intermediate_result: seen.append(intermediate_result.fun))
    return seen


def test_two_stages_halve_twice(monkeypatch):
    """Stages 8 and 16 with 4 starts: the best two after 8 iterations go on, the better of those two after
    16 goes to the end; each run ends exactly where an uninterrupted run of its length ends."""
    monkeypatch.setattr(race, "RACE_STAGES", (8, 16))
    x0s, runs = starts(4, 70)
    finalists = race.race(runs, 70)
    at8 = [uninterrupted_values(x0, 8)[-1] for x0 in x0s]
    two = sorted(np.argsort(at8)[:2])
    at16 = {i: uninterrupted_values(x0s[i], 16)[-1] for i in two}
    winner = min(two, key=lambda i: (at16[i], i))
    assert finalists == [i == winner for i in range(4)]
    for i, (x0, run) in enumerate(zip(x0s, runs, strict=True)):
        length = 70 if i == winner else 16 if i in two else 8
        assert np.array_equal(run.result.x, solve(x0, length).x)
    assert sum(r.iterations for r in runs) <= race.planned_iterations(4, 70) == 4 * 8 + 2 * 8 + 1 * 54


def test_planned_iterations_follow_the_stages(monkeypatch):
    monkeypatch.setattr(race, "RACE_STAGES", (40, 100))
    assert race.planned_iterations(4, 150) == 4 * 40 + 2 * 60 + 50
    assert race.planned_iterations(8, 150) == 8 * 40 + 4 * 60 + 2 * 50
    assert race.planned_iterations(3, 80) == 3 * 40 + 2 * 40  # the second stage lies beyond the last iteration
    assert race.planned_iterations(2, 150) == 2 * 40 + 110
    assert race.planned_iterations(4, 150, raced=False) == race.planned_iterations(1, 150) * 4 == 600


def test_no_race_with_one_start_or_few_iterations():
    (x0,), runs = starts(1, 60)
    assert race.race(runs, 60) == [True] and np.array_equal(runs[0].result.x, solve(x0, 60).x)
    _, runs = starts(3, STAGE)
    assert race.race(runs, STAGE) == [True] * 3
    assert race.planned_iterations(3, STAGE) == 3 * STAGE


def test_error_inside_a_run_reaches_the_caller():
    def failing(callback):
        def fun(x):
            if fun.calls > 3:
                raise ComputationError("regressor failed")
            fun.calls += 1
            return rosen(x), rosen_der(x)

        fun.calls = 0
        return minimize(fun, np.zeros(4), jac=True, method="SLSQP", callback=callback)

    run = race.Start(failing)
    with pytest.raises(ComputationError, match="regressor failed"):
        run.advance(STAGE)


@pytest.mark.parametrize("robot", ["puma560.yaml", "planar3r.yaml"])  # the planar arm: the fast tier's case
def test_design_finalists_end_where_unraced_starts_end(monkeypatch, robot):
    """In excite's design (3 starts): the two starts that go on end exactly where the same starts end
    without the race, the third stops after the race's stage, and the record says so."""
    from minparam_cli.base.qr import derive_qr
    from minparam_cli.experiment.excite.design import ExciteOptions, chain_limits, design
    from minparam_cli.robot import DeriveOptions, load_chain

    _, chain = load_chain(f"robots/{robot}", DeriveOptions())
    base, limits, opts = derive_qr(chain), chain_limits(chain, 0.1), ExciteOptions(starts=3, max_iterations=30, harmonics=3, rate=20)
    raced = design(chain, base, opts, limits, np.random.default_rng(0))
    monkeypatch.setattr(race, "RACE_STAGES", ())  # no race
    plain = design(chain, base, opts, limits, np.random.default_rng(0))
    stopped = [i for i, s in enumerate(raced.starts) if s.message.startswith("stopped")]
    assert len(stopped) == 1 and raced.starts[stopped[0]].iterations == 8
    for i, (a, b) in enumerate(zip(raced.starts, plain.starts, strict=True)):
        assert a.start_criterion == b.start_criterion
        if i not in stopped:
            assert a.end_criterion == b.end_criterion and a.iterations == b.iterations == 30
    assert raced.best_start == plain.best_start and raced.best_start not in stopped  # 0-based, as the records
    assert raced.criterion == plain.criterion


def test_an_error_ends_every_other_run():
    """A start whose run fails ends the race; the starts paused behind it end too (no thread left blocked)."""
    _, runs = starts(2, 60)

    def failing(callback):
        def fun(x):
            raise ComputationError("regressor failed")

        return minimize(fun, np.zeros(4), method="SLSQP", callback=callback)

    runs.append(race.Start(failing))
    with pytest.raises(ComputationError, match="regressor failed"):
        race.race(runs, 60)
    for r in runs[:2]:
        r._thread.join(timeout=10)
        assert not r._thread.is_alive() and r.iterations == STAGE


@pytest.mark.parametrize("own_limit", [3, STAGE])
def test_a_run_that_ends_before_a_stage_leaves_the_race_to_the_others(own_limit):
    """A start whose SLSQP ends by itself before the stage or exactly at it (here: near the optimum, with its
    own limit of 3 or STAGE iterations) keeps its own ending (``stopped`` False) and its result's value, and
    takes no place among the half that goes on: of the three other starts, the better two go on."""
    x0s, runs = starts(3, 70)
    short = race.Start(lambda cb: solve(np.ones(6) * 0.5, own_limit, cb))
    finalists = race.race([short, *runs], 70)
    assert short.ended and not short.stopped and short.value == float(short.result.fun) and short.result.nit == own_limit
    assert finalists[0] is False and sum(finalists[1:]) == 2
    at8 = [uninterrupted_values(x0, STAGE)[-1] for x0 in x0s]
    assert finalists[1:] == [i in set(np.argsort(at8)[:2]) for i in range(3)]
    assert [r.stopped for r in runs] == [not f for f in finalists[1:]]


class TrialPointError(ComputationError):
    """Stands for LoopsNotClosed: the function fails at a trial point out of its domain."""


def _failing_after(calls_ok: int):
    def failing(callback):
        def fun(x):
            if fun.calls >= calls_ok:
                raise TrialPointError("the loops cannot be closed")
            fun.calls += 1
            return rosen(x), rosen_der(x)

        fun.calls = 0
        return minimize(fun, np.full(4, 0.3), jac=True, method="SLSQP", callback=callback, options={"maxiter": 60})

    return failing


def test_a_recoverable_error_ends_its_start_at_the_last_iterate_and_the_others_go_on():
    _, runs = starts(2, 60)
    seen = []
    plain = race.Start(_failing_after(10**9))  # the same run without the error, for its iterates
    own = plain._callback

    def spy(intermediate_result):  # scipy passes the OptimizeResult to a callback with this parameter name
        seen.append(np.copy(intermediate_result.x))
        own(intermediate_result)

    plain._callback = spy
    plain.advance(float("inf"))
    failing = race.Start(_failing_after(6), recoverable=(TrialPointError,))
    race.race([*runs, failing], 60)
    res = failing.result
    assert res.message.startswith("ended at a trial point: the loops cannot be closed") and not res.success
    assert 0 < failing.iterations == res.nit and np.array_equal(res.x, seen[failing.iterations - 1])
    assert all(r.ended for r in runs)


def test_a_recoverable_error_before_any_iterate_or_an_other_error_still_ends_the_design():
    with pytest.raises(TrialPointError):
        race.Start(_failing_after(0), recoverable=(TrialPointError,)).advance(STAGE)
    with pytest.raises(TrialPointError):
        race.Start(_failing_after(6), recoverable=(KeyError,)).advance(float("inf"))
