"""``hitchpark realtime``: the closed loop on a fixed wall-clock tick, the software-in-the-loop test.

The paper ran its NMPC at 10 Hz on a dSPACE MicroAutoBox against the car (Section 6.2). Here the
controller runs against the simulated plant in wall-clock time: each command must be ready within
its tick (100 ms, or 100/K ms with ``speed_up`` K); the plant then moves one sample and the next tick
begins when the period is over. A tick whose work (sense, the controller's step, the guard) took
longer than the period is an overrun; the loop does not wait for it to catch up but starts the next
tick at once, as a real-time task would.

Planning happens standing still, between stages (the car holds a stop meanwhile); it is reported as
``standstill_planning_s`` and is not the work of a tick. Python's full garbage collection is kept out of
the ticks too: each (re)start of the clock, standing still, collects and then freezes what lives
(``gc.freeze``), so that no collection during the ticks walks through the solvers, plans and scene
again; at 10 ms ticks one such collection had taken 20-27 ms of a tick among obstacles.
"""

from __future__ import annotations

import gc
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..checks import check_range
from ..maneuver import ManeuverResult, park
from ..maneuver.scenario import Scenario

__all__ = ["RealtimeResult", "WallClock", "run_realtime"]


class WallClock:
    """A :class:`~hitchpark.maneuver.process.Clock` holding each tick to ``period_s`` of wall-clock time.

    Its :meth:`restart` freezes the objects alive for Python's garbage collector (see the top); whoever
    drives a loop with it calls ``gc.unfreeze()`` after the run, as :func:`run_realtime` does.
    """

    def __init__(self, period_s: float):
        self.period_s = period_s
        self.work_s: list[float] = []
        self.overruns = 0
        self._begin: float | None = None

    def restart(self) -> None:
        """A stage begins, standing still: collect the garbage now and freeze what is left (see the top)."""
        gc.collect()
        gc.freeze()
        self._begin = time.perf_counter()

    def tick(self) -> None:
        now = time.perf_counter()
        begin = now if self._begin is None else self._begin
        work = now - begin
        self.work_s.append(work)
        if work > self.period_s:
            self.overruns += 1
            self._begin = now  # late: the next tick starts at once
        else:
            deadline = begin + self.period_s
            while (left := deadline - time.perf_counter()) > 0:
                time.sleep(left)
            self._begin = deadline

    @property
    def ticks(self) -> int:
        return len(self.work_s)


@dataclass(frozen=True)
class RealtimeResult:
    """Ticks, overruns and the work per tick [ms] of one real-time run, and the maneuver it drove."""

    scenario: str
    period_ms: float
    ticks: int
    overruns: int
    tick_ms: dict[str, float]
    standstill_planning_s: float
    wall_s: float
    maneuver: ManeuverResult

    def to_dict(self) -> dict[str, Any]:
        return {
            "scenario": self.scenario,
            "period_ms": self.period_ms,
            "ticks": self.ticks,
            "overruns": self.overruns,
            "tick_ms": dict(self.tick_ms),
            "standstill_planning_s": self.standstill_planning_s,
            "wall_s": self.wall_s,
            "parked": self.maneuver.success,
            "reason": self.maneuver.reason,
            "maneuver_s": float(self.maneuver.trajectory["t"][-1]),
        }


def run_realtime(
    scenario: Scenario, speed_up: float = 1.0, progress: Callable[[str], None] = lambda _: None
) -> RealtimeResult:
    """Park ``scenario`` with its controller on a wall-clock tick of ``dt / speed_up``."""
    speed_up = check_range("--speed-up", speed_up, 1.0, 1000.0, unit="(the tick is dt/K)")
    period = scenario.settings.nmpc.dt / speed_up
    progress(f"{scenario.name}: the controller on a {1e3 * period:g} ms tick against the plant in wall-clock time")
    clock = WallClock(period)
    t0 = time.perf_counter()
    try:
        result = park(
            scenario.vehicle,
            scenario.start,
            scenario.goal,
            scenario.settings,
            name=scenario.name,
            plant=scenario.plant,
            scene=scenario.scene,
            clock=clock,
        )
    finally:
        gc.unfreeze()  # the caller's objects collectable again
    wall = time.perf_counter() - t0
    work = 1e3 * np.array(clock.work_s) if clock.work_s else np.zeros(1)
    stats = {"median": float(np.median(work)), "p99": float(np.percentile(work, 99)), "max": float(np.max(work))}
    return RealtimeResult(
        scenario.name, 1e3 * period, clock.ticks, clock.overruns, stats, result.planning_s, wall, result
    )
