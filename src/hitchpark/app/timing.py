"""Timing solver routes on recorded NMPC problems, for ``hitchpark bench``: each route warmed up, then the
routes' calls interleaved round by round so that a slow spell of the machine falls on all of them, each
call's wall and CPU time kept (:func:`time_interleaved`)."""

from __future__ import annotations

import gc
import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np

from ..control.nmpc import NLPProblem
from ..solvers.registry import takes_duals

__all__ = ["ROUNDS", "TimedCalls", "time_interleaved", "time_route"]


#: The routes (and the horizons) take turns in this many rounds, each solving its next share of the problems.
ROUNDS = 8


class TimedCalls(NamedTuple):
    """One solver's calls, in its problems' order: wall and CPU ms, each answer (None where it failed) and
    the iterations it reported (NaN where it reports none)."""

    wall: np.ndarray
    cpu: np.ndarray
    answers: list[Any]
    iterations: np.ndarray


@dataclass
class _Timing:
    """One solver's calls on its problems: wall and CPU seconds, answers and iterations, in the problems' order."""

    solver: Any
    problems: Sequence[NLPProblem]
    budget_s: float = math.inf
    wall: list[float] = field(default_factory=list)
    cpu: list[float] = field(default_factory=list)
    answers: list[Any] = field(default_factory=list)
    iterations: list[float] = field(default_factory=list)

    def warm_up(self) -> None:
        """Load caches and libraries before timing."""
        start = time.perf_counter()
        for problem in self.problems[: min(20, len(self.problems))]:
            self.solver(**problem.inputs(takes_duals(self.solver)))
            if time.perf_counter() - start > self.budget_s / 10:
                break

    def run(self, problems: Sequence[NLPProblem]) -> None:
        """Time ``problems`` one call each, until ``budget_s`` seconds of calls are spent in all."""
        spent = sum(self.wall)
        duals = takes_duals(self.solver)  # the multipliers the controller started from, as it gave them
        for problem in problems:
            if spent > self.budget_s:
                return
            inputs = problem.inputs(duals)
            t0, c0 = time.perf_counter(), time.process_time()
            answer = self.solver(**inputs)
            stats = self.solver.stats()
            ok = bool(stats["success"])
            wall = time.perf_counter() - t0
            self.cpu.append(time.process_time() - c0)
            self.wall.append(wall)
            spent += wall
            self.answers.append(np.asarray(answer["x"]).ravel() if ok else None)
            self.iterations.append(float(stats.get("iter_count", math.nan)))

    def result(self) -> TimedCalls:
        return TimedCalls(1e3 * np.array(self.wall), 1e3 * np.array(self.cpu), self.answers, np.array(self.iterations))


def time_interleaved(
    jobs: Mapping[str, tuple[Any, Sequence[NLPProblem], float]], rounds: int = ROUNDS
) -> dict[str, TimedCalls]:
    """The calls (:class:`TimedCalls`) of each job ``(solver, problems, budget_s)``: its problems in order,
    one call each, until ``budget_s`` seconds of calls are spent (a route far slower than the rest is not
    run to the end).

    The jobs take turns: in each of ``rounds`` rounds every job solves its next ``1/rounds`` share of its
    problems, so that a machine whose speed drifts over minutes slows every job alike and the ratios
    between them are of one time.
    """
    timings = {key: _Timing(solver, problems, budget) for key, (solver, problems, budget) in jobs.items()}
    for timing in timings.values():
        timing.warm_up()
    gc.collect()
    for r in range(rounds):
        for timing in timings.values():
            n = len(timing.problems)
            timing.run(timing.problems[n * r // rounds : n * (r + 1) // rounds])
    return {key: timing.result() for key, timing in timings.items()}


def time_route(solver: Any, problems: Sequence[NLPProblem], budget_s: float = math.inf) -> TimedCalls:
    """The calls of one solver alone."""
    return time_interleaved({"": (solver, problems, budget_s)}, rounds=1)[""]
