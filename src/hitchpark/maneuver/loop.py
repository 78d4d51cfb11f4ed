"""The closed loop of a maneuver: ``plant.sense -> stage.act -> plant.apply``, one stage at a time.

:class:`ClosedLoop` holds the running maneuver: the plant, the commands in flight (the known delay), the record
of every row, and how it ended. :func:`run_stage` drives one stage from standstill to standstill: the steer set
to what the stage wants, then sense, act, apply until the stage stops, fails or runs out of steps, then a brake.
The one place the controller's steer-rate and acceleration limits are enforced on what a stage asks is
:meth:`ClosedLoop.limited`.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from ..control.estimator import Estimator
from ..control.step import ControlStep
from ..model.inverse import virtual_steer_from_front
from ..model.kinematics import trailer_speed_from_rear_speed
from ..model.plant import Command, Measurement, Plant
from ..model.simulate import STATE_COLUMNS, Trajectory, state_columns
from ..model.state import Pose, clamp
from .predictions import predicted_path
from .result import MANEUVER_COLUMNS, Outcome
from .stages import Stage, StageEnd

__all__ = ["SETTLE_TOLERANCE", "STALL_TRAVEL_M", "STALL_WINDOW_S", "Clock", "ClosedLoop", "run_stage"]


class Clock(Protocol):
    """Paces the loop: ``tick`` as each command is ready, right before the plant applies it.

    The work of a tick runs from the previous tick (or ``restart``) to this one: the plant's previous
    step and the record as well as sensing, the controller's step and the guard. ``restart`` is called
    when the process has decided what comes next, standing still (planning is not the work of a tick).
    ``hitchpark realtime`` passes a clock that holds each tick to a wall-clock period and counts the
    ticks whose work overran it.
    """

    def tick(self) -> None: ...

    def restart(self) -> None: ...


#: A stage starts moving once the actual steer is this close to the steer it asked for [rad].
SETTLE_TOLERANCE = math.radians(0.5)

#: A stage that has used its steps (``Stage.max_steps``) goes on while the trailer still makes its way: it moved
#: at least :data:`STALL_TRAVEL_M` [m] (as sensed) over the last :data:`STALL_WINDOW_S` [s]. A car held to a crawl
#: by the guard then finishes; one that stands or creeps less ends stalled, and the maneuver's ``max_time`` bounds
#: them all. (Measured on ``garage_end``'s fault-plant start that ran out of 1500 steps 0.87 m short, still
#: reversing: docs/places.md.)
STALL_TRAVEL_M = 0.25
STALL_WINDOW_S = 10.0

#: The columns a row records besides the true state (the rest follow from it, ``state_columns``).
_ROW_COLUMNS = tuple(c for c in MANEUVER_COLUMNS if c not in STATE_COLUMNS)


@dataclass
class ClosedLoop:
    """The running maneuver: the plant, the record, what was issued, and where it ended."""

    plant: Plant
    goal: Pose
    delay: int
    max_time: float
    steer_rate: float  # the controller's steer-rate limit [rad/s]
    accel: float  # the controller's acceleration limit [m/s^2]
    states: list[np.ndarray] = field(default_factory=list)
    rows: dict[str, list[float]] = field(default_factory=lambda: {c: [] for c in _ROW_COLUMNS})
    issued: deque[Command] = field(default_factory=deque)
    last: Command = field(default_factory=lambda: Command(0.0, 0.0))
    outcome: Outcome | None = None
    detail: str = ""
    clock: Clock | None = None
    predictions: list[np.ndarray] | None = None  # one predicted path per row, when recorded (else None)
    extras: dict[str, list[float]] | None = None  # a controller's own columns (the knob assist's), NaN where none
    estimator: Estimator | None = None  # between the sensors and the controllers (None: the readings as they are)

    def sense(self) -> Measurement:
        """What the controllers see now: the plant's reading, through the estimator if there is one."""
        m = self.plant.sense()
        return m if self.estimator is None else self.estimator.update(m)

    def in_flight(self) -> tuple[Command, ...]:
        """The commands issued but not yet acted on: the known delay."""
        return tuple(self.issued)[len(self.issued) - self.delay :] if self.delay else ()

    def limited(self, command: Command) -> Command:
        """The command moved from the last one within the controller's steer-rate and acceleration limits.

        The one place these limits are enforced on what a stage asks: the full NMPC's plan already
        respects them (this is then a guard against solver tolerance), the forward pursuit relies on it.
        """
        steer_step, speed_step = self.steer_rate * self.plant.dt, self.accel * self.plant.dt
        last = self.last
        return Command(
            clamp(command.rear_speed, last.rear_speed - speed_step, last.rear_speed + speed_step),
            clamp(command.front_steer, last.front_steer - steer_step, last.front_steer + steer_step),
        )

    def step(self, stage: int, measurement: Measurement, command: Command, why: ControlStep | None = None) -> bool:
        """Apply one command and record the row; False (and the outcome) on a jackknife."""
        vehicle = self.plant.vehicle
        command = Command(command.rear_speed, clamp(command.front_steer, -vehicle.max_steer, vehicle.max_steer))
        before = self.plant.configuration
        if self.clock is not None:
            self.clock.tick()
        acting = self.plant.apply(command)
        if acting is None:
            self.outcome = Outcome.JACKKNIFE
            return False
        self.issued.append(command)
        if len(self.issued) > self.delay + 1:
            self.issued.popleft()
        self.last = command
        hitch = before[3]
        self.states.append(before)
        row = self.rows
        row["t"].append(measurement.t)
        row["rear_speed"].append(acting.rear_speed)
        row["front_steer"].append(acting.front_steer)
        row["rear_speed_cmd"].append(command.rear_speed)
        row["front_steer_cmd"].append(command.front_steer)
        row["hitch_measured"].append(measurement.state.hitch)
        row["hitch_doubt"].append(measurement.doubt[3])
        row["stage"].append(stage)
        if why is not None and why.command == command:  # the controller's own view: U_0, or Eqs. (18), (56)
            row["trailer_speed"].append(why.trailer_speed)
            row["virtual_steer"].append(why.virtual_steer)
        else:
            row["trailer_speed"].append(
                float(trailer_speed_from_rear_speed(vehicle, hitch, command.rear_speed, command.front_steer))
            )
            row["virtual_steer"].append(float(virtual_steer_from_front(vehicle, hitch, command.front_steer)))
        row["cost"].append(why.cost if why is not None else math.nan)
        row["solve_ms"].append(why.solve_ms if why is not None else math.nan)
        if self.predictions is not None:
            self.predictions.append(predicted_path(self.goal, why))
        if self.extras is not None:
            own = getattr(why, "columns", {})
            for name, values in self.extras.items():
                values.append(own.get(name, math.nan))
        return True

    def out_of_time(self) -> bool:
        if self.plant.t >= self.max_time - 1e-9:
            self.outcome = Outcome.TIMEOUT
            return True
        return False

    def brake(self, stage: int) -> bool:
        """Stop the car (commands in flight still act); False on a jackknife or timeout."""
        while not self.plant.stopped():
            if self.out_of_time() or not self.step(stage, self.sense(), Command(0.0, self.last.front_steer)):
                return False
        return True

    def settle(self, stage: int, target: float) -> bool:
        """Standing still, turn the wheels to ``target`` within the steer-rate limit; False on timeout."""
        limit = self.plant.vehicle.max_steer
        target = clamp(target, -limit, limit)
        rate = self.steer_rate * self.plant.dt
        while abs(self.plant.front_steer - target) > SETTLE_TOLERANCE or self.last.front_steer != target:
            if self.out_of_time():
                return False
            steer = self.last.front_steer + clamp(target - self.last.front_steer, -rate, rate)
            if not self.step(stage, self.sense(), Command(0.0, steer)):
                return False
        return True

    def final_row(self, stage: int) -> None:
        """The final state and a stop, steer held."""
        m = self.sense()
        vehicle = self.plant.vehicle
        before = self.plant.configuration
        self.states.append(before)
        row = self.rows
        for name, value in (
            ("t", self.plant.t),
            ("rear_speed", 0.0),
            ("front_steer", self.plant.front_steer),
            ("rear_speed_cmd", 0.0),
            ("front_steer_cmd", self.last.front_steer),
            ("hitch_measured", m.state.hitch),
            ("hitch_doubt", m.doubt[3]),
            ("stage", stage),
            ("trailer_speed", 0.0),
            ("virtual_steer", float(virtual_steer_from_front(vehicle, before[3], self.plant.front_steer))),
            ("cost", math.nan),
            ("solve_ms", math.nan),
        ):
            row[name].append(value)
        if self.predictions is not None:
            self.predictions.append(predicted_path(self.goal, None))
        for values in (self.extras or {}).values():
            values.append(math.nan)

    def trajectory(self) -> Trajectory:
        cols: dict[str, Any] = {**self.rows, **state_columns(self.plant.vehicle, np.array(self.states))}
        return Trajectory({c: cols[c] for c in MANEUVER_COLUMNS} | (self.extras or {}))


def _makes_way(where: deque[tuple[float, float]]) -> bool:
    """Whether the trailer moved :data:`STALL_TRAVEL_M` over the window ``where`` holds; not where it holds less
    than a window's time (a stage whose steps are fewer than a window's stalls at its steps, as it always did)."""
    if len(where) < (where.maxlen or 0):
        return False
    (x0, y0), (x1, y1) = where[0], where[-1]
    return math.hypot(x1 - x0, y1 - y0) >= STALL_TRAVEL_M


def run_stage(loop: ClosedLoop, index: int, stage: Stage) -> StageEnd:
    """Drive one stage to its end at standstill; how it ended (the loop's outcome set on a jackknife or timeout)."""
    kind, controller = stage.kind, stage.controller
    want = stage.begin(loop.sense(), loop.goal)
    if want is not None and not loop.settle(index, want):
        return StageEnd(kind, controller, loop.outcome.value if loop.outcome else "settle")
    window = max(1, round(STALL_WINDOW_S / loop.plant.dt))
    where: deque[tuple[float, float]] = deque(maxlen=window + 1)  # the sensed trailer axle, the last window's
    step = 0
    while True:
        if loop.out_of_time():
            return StageEnd(kind, controller, Outcome.TIMEOUT.value)
        m = loop.sense()
        where.append((m.state.x, m.state.y))
        if step >= stage.max_steps and not _makes_way(where):
            loop.outcome = Outcome.STALLED
            reason = Outcome.STALLED.value
            break
        u = stage.act(m, loop.goal, loop.in_flight())
        if not u.ok:  # stopped safely; the process says what comes next
            loop.brake(index)
            label = "solver" if controller in ("nmpc", "pursuit") else controller
            reason = u.status if u.status.startswith("guard:") else f"{label}: {u.status}"
            return StageEnd(kind, controller, reason, failed=True, status=u.status, step=step)
        if u.stop:
            reason = "stopped" if kind == "reverse" else "repositioned"
            break
        command = loop.limited(u.command) if stage.rate_limited else u.command
        if not loop.step(index, m, command, u):
            return StageEnd(kind, controller, Outcome.JACKKNIFE.value)
        step += 1
    if not loop.brake(index):
        return StageEnd(kind, controller, loop.outcome.value if loop.outcome else reason)
    return StageEnd(kind, controller, reason)
