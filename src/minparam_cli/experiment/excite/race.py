"""Racing the starts of the design (successive halving): every start runs to the first stage of
RACE_STAGES (40 iterations of SLSQP), then only the better half (by the criterion at that iteration;
ties: the earlier start) goes on; at the next stage (100) the better half of those goes on, and so on
to the last iteration.  The others stop where they are.  A start whose SLSQP ends by itself before a
stage (or at it) leaves the race: its end point still counts, and it takes no place among the half that
goes on.

SLSQP's iterations cost about the same at every stage, so with the default 4 starts of 150
iterations the race runs 4·40 + 2·60 + 1·50 = 330 iterations instead of 600.  A start that goes on is not
restarted: each start's SLSQP runs in its own thread and waits in its iteration callback until it is
told to go on, with its quasi-Newton matrix and line search intact, so the finalists take exactly the
iterates of an uninterrupted run.  One thread runs at a time (the others wait on an event), so the
design stays on one core and its result is deterministic.

Measured on six robots (Panda, PUMA 560, UR5, TX40, iiwa 14, Stanford arm; seeds 0-3; every start run
to 150 iterations), the start that ends best among the two best after 40 iterations was also the
better of the two after 100 in all 24 cases (after 80, in 23); docs/commands/excite.md has the table.
An observation, not a guarantee.
"""

from __future__ import annotations

import threading
from typing import Any, Callable

RACE_STAGES = (40, 100)  # the iterations after which the better half of the starts still running goes on


class Start:
    """One start's SLSQP run, advanced to a given iteration at a time (``advance``).  ``solve(callback)``
    runs the optimiser with ``callback(intermediate_result)`` called after each iteration and returns
    its result."""

    def __init__(self, solve: Callable[[Callable], Any], step: Callable[[], None] | None = None,
                 recoverable: tuple[type[BaseException], ...] = (), start: tuple[Any, float] | None = None):
        self._solve = solve
        self._step_hook = step
        # errors of the optimiser's function at a trial point (a step out of a closed chain's workspace) that end
        # the run at its last iterate instead of the design: its result is then that iterate, with the error's text
        # (before the first iterate: ``start``, the (x, value) the run started from, when given)
        self._recoverable = recoverable
        self._start = start
        self._last: Any = None
        self.iterations = 0
        # the criterion at the last iteration (inf before the first): SLSQP's value at the point its last
        # iteration reached, and once the run has ended by itself, its result's
        self.value = float("inf")
        # the race ended the run (not the optimiser's own test or iteration limit); a run stopped at the very
        # iteration at which SLSQP would have ended by itself counts as stopped (scipy reports status 99 for both)
        self.stopped = False
        self.result: Any = None
        self._error: BaseException | None = None
        self._target: float = 0
        self._stop = False
        self._done = False
        self._resume = threading.Event()
        self._paused = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def _run(self) -> None:
        try:
            try:
                self.result = self._solve(self._callback)
            except self._recoverable as e:
                if self._last is None and self._start is None:  # not one point to fall back on
                    raise
                from scipy.optimize import OptimizeResult

                x, fun = (self._last.x, self._last.fun) if self._last is not None else self._start  # type: ignore[misc]  # one is set
                self.result = OptimizeResult(x=x, fun=fun, nit=self.iterations, success=False, status=-1,
                                             message=f"ended at a trial point: {e}")
            if not self.stopped and self.result is not None and getattr(self.result, "fun", None) is not None:
                self.value = float(self.result.fun)
        except BaseException as e:  # noqa: BLE001  # handed to the caller's thread by advance
            self._error = e
        self._done = True
        self._paused.set()

    def _callback(self, intermediate_result) -> None:
        self.iterations += 1
        self._last = intermediate_result
        self.value = float(intermediate_result.fun)
        if self._step_hook is not None:
            self._step_hook()
        if self.iterations >= self._target:
            self._paused.set()
            self._resume.wait()
            self._resume.clear()
            if self._stop:
                self.stopped = True
                raise StopIteration  # SLSQP ends here and returns this iterate

    @property
    def ended(self) -> bool:
        """The run is over (its optimiser returned, or it failed)."""
        return self._done

    def advance(self, target: float) -> None:
        """Run to iteration ``target`` (inf: to the optimiser's own end) or the optimiser's end."""
        self._go(target, stop=False)

    def stop(self) -> None:
        """End the run at its current iterate (the optimiser returns it as its result)."""
        self._go(0, stop=True)

    def abandon(self) -> None:
        """Let the run end at its next iteration without waiting for it (the caller is leaving: an
        error or an interrupt), so that no thread stays blocked."""
        self._target, self._stop = 0, True
        self._resume.set()

    def _go(self, target: float, stop: bool) -> None:
        if self._done:
            return
        self._target, self._stop = target, stop
        self._paused.clear()
        if self._thread.ident is None:
            self._thread.start()
        else:
            self._resume.set()
        self._paused.wait()
        if self._error is not None:
            raise self._error


def race(runs: list[Start], max_iterations: int, raced: bool = True) -> list[bool]:
    """Run ``runs`` as the module docstring says (``raced=False``: every run to its end, one after the
    other); per start, whether it went on to the end."""
    alive = list(range(len(runs)))
    try:
        for stage in RACE_STAGES if raced else ():
            if len(alive) < 2 or stage >= max_iterations:
                break
            for i in alive:
                runs[i].advance(stage)
            alive = [i for i in alive if not runs[i].ended]  # one that ended by itself is out (its result counts)
            if len(alive) < 2:
                break
            keep, going = (len(alive) + 1) // 2, list[int]()
            for i in sorted(alive, key=lambda i: (runs[i].value, i)):
                if len(going) < keep:
                    # one iteration more: SLSQP calls back on its last iteration too, so a run that ended
                    # by itself exactly at the stage ends only now, and leaves its place to the next one
                    runs[i].advance(stage + 1)
                    if not (runs[i].ended and runs[i].iterations <= stage):
                        going.append(i)
                else:
                    runs[i].stop()
            alive = sorted(going)
        for i in alive:
            runs[i].advance(float("inf"))  # SLSQP's own iteration limit ends it
    except BaseException:
        for r in runs:
            r.abandon()
        raise
    return [i in alive for i in range(len(runs))]


def run_starts(solvers: list[Callable[[Callable], Any]], max_iterations: int, progress=None,
               raced: bool = True, recoverable: tuple[type[BaseException], ...] = (),
               starts: list[tuple[Any, float]] | None = None) -> tuple[list[Start], list[bool]]:
    """One ``Start`` per solver, raced (``race``; ``raced=False``: each to its end); ``progress(done, total)``
    after every iteration; ``recoverable`` and ``starts`` (each solver's (x, value) at its start): as ``Start``'s."""
    total = planned_iterations(len(solvers), max_iterations, raced)
    done = [0]

    def step() -> None:
        done[0] += 1
        if progress:
            progress(done[0], total)

    runs = [Start(solve, step, recoverable, None if starts is None else starts[i]) for i, solve in enumerate(solvers)]
    went_on = race(runs, max_iterations, raced)
    if progress:
        progress(total, total)
    return runs, went_on


def planned_iterations(starts: int, max_iterations: int, raced: bool = True) -> int:
    """The iterations ``race`` runs at most (the progress bar's total)."""
    total, done, alive = 0, 0, starts
    for stage in RACE_STAGES if raced else ():
        if alive < 2 or stage >= max_iterations:
            break
        total += alive * (stage - done)
        done, alive = stage, (alive + 1) // 2
    return total + alive * (max_iterations - done)
