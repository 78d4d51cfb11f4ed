"""The parking maneuver as one closed loop: ``plant.sense -> stage.act -> plant.apply``.

Stages alternate from reverse (Fig. 7): a reverse stage runs its NMPC until the optimal
speed is zero; if the trailer is not parked, a forward stage repositions and another
reverse stage follows, up to ``max_stages``. Every stage starts and ends at standstill: the
car brakes to a stop, then the steer is set to what the next stage wants before it moves
(those samples are recorded and their time counts). Success is judged on the true state.

A process (:class:`~.stages.Process`) chooses the stages: the staged one alternates them as above;
the planned one (:mod:`.planned`, the default with the full-model NMPC) plans a path among the
obstacles, tracks it under a guard that stops the car near the scene, and plans again when it must.
Obstacles and an area (a :class:`~hitchpark.model.scene.Scene`) are also checked at the end, on the
whole true motion of the real car (:func:`~hitchpark.model.collision.swept_clearance`): a maneuver that
came closer to them than ``success.min_clearance_m`` (or touched them, or left the area) fails with
the outcome ``collision``.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from ..checks import InputError, check_instance, check_text
from ..control.nmpc import FullNMPC, TrailerNMPC, make_nmpc
from ..control.step import ControlStep
from ..model.collision import MAX_STEP_M, swept_contact
from ..model.inverse import virtual_steer_from_front
from ..model.kinematics import trailer_speed_from_rear_speed
from ..model.plant import Command, Measurement, Plant, PlantSettings
from ..model.scene import Scene
from ..model.simulate import STATE_COLUMNS, Trajectory, state_columns
from ..model.state import Pose, State, check_goal, check_state, clamp
from ..model.vehicle import VehicleTrailer, check_vehicle
from .planned import PlannedProcess
from .result import (
    MANEUVER_COLUMNS,
    ManeuverResult,
    Outcome,
    PlanRecord,
    StageResult,
    pose_errors,
)
from .settings import ManeuverSettings
from .stages import Ending, Process, Stage, StagedProcess, StageEnd, make_stages

__all__ = ["SETTLE_TOLERANCE", "Clock", "park"]


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

#: The columns a row records besides the true state (the rest follow from it, ``state_columns``).
_ROW_COLUMNS = tuple(c for c in MANEUVER_COLUMNS if c not in STATE_COLUMNS)


@dataclass
class _Loop:
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
        return True

    def out_of_time(self) -> bool:
        if self.plant.t >= self.max_time - 1e-9:
            self.outcome = Outcome.TIMEOUT
            return True
        return False

    def brake(self, stage: int) -> bool:
        """Stop the car (commands in flight still act); False on a jackknife or timeout."""
        while not self.plant.stopped():
            if self.out_of_time() or not self.step(stage, self.plant.sense(), Command(0.0, self.last.front_steer)):
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
            if not self.step(stage, self.plant.sense(), Command(0.0, steer)):
                return False
        return True

    def final_row(self, stage: int) -> None:
        """The final state and a stop, steer held."""
        m = self.plant.sense()
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
            ("stage", stage),
            ("trailer_speed", 0.0),
            ("virtual_steer", float(virtual_steer_from_front(vehicle, before[3], self.plant.front_steer))),
            ("cost", math.nan),
            ("solve_ms", math.nan),
        ):
            row[name].append(value)

    def trajectory(self) -> Trajectory:
        cols: dict[str, Any] = {**self.rows, **state_columns(self.plant.vehicle, np.array(self.states))}
        return Trajectory({c: cols[c] for c in MANEUVER_COLUMNS})


def _run_stage(loop: _Loop, index: int, stage: Stage) -> StageEnd:
    """Drive one stage to its end at standstill; how it ended (the loop's outcome set on a jackknife or timeout)."""
    kind, controller = stage.kind, stage.controller
    want = stage.begin(loop.plant.sense(), loop.goal)
    if want is not None and not loop.settle(index, want):
        return StageEnd(kind, controller, loop.outcome.value if loop.outcome else "settle")
    for step in range(stage.max_steps):
        if loop.out_of_time():
            return StageEnd(kind, controller, Outcome.TIMEOUT.value)
        m = loop.plant.sense()
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
    else:
        loop.outcome = Outcome.STALLED
        reason = Outcome.STALLED.value
    if not loop.brake(index):
        return StageEnd(kind, controller, loop.outcome.value if loop.outcome else reason)
    return StageEnd(kind, controller, reason)


def direction_segments_of(stages: list[StageResult]) -> int:
    """Direction segments driven: stages in a row of the same kind count once (the success limit counts these)."""
    return sum(1 for i, st in enumerate(stages) if i == 0 or st.kind != stages[i - 1].kind)


def _errors_deg(goal: Pose, state: np.ndarray) -> tuple[float, float, float]:
    """Distance [m], orientation error [deg] and hitch [deg] of ``state`` at ``goal``."""
    dist, orient = pose_errors(goal, state)
    return dist, math.degrees(orient), math.degrees(state[3])


#: The NMPC's predictions keep this much more than the guard asks [m]: the guard then never stops a plan
#: the solver kept clear to its tolerance.
CLEARANCE_SPARE_M = 0.01


def predicted_clearance_m(settings: ManeuverSettings) -> float:
    """How far the planned process's NMPC keeps its predicted bodies from the scene [m] (the obstacle OCP,
    :meth:`~hitchpark.control.nmpc.FullNMPC.keep_clear`): what the guard asks, and :data:`CLEARANCE_SPARE_M`."""
    return settings.success.min_clearance_m + settings.process.guard_margin_m + CLEARANCE_SPARE_M


def make_process(
    vehicle: VehicleTrailer,
    settings: ManeuverSettings,
    scene: Scene,
    nmpc: TrailerNMPC | FullNMPC | None,
    delay: int,
) -> Process:
    """The process ``settings.process`` names (``auto``: planned with the full NMPC, staged with the paper's)."""
    nmpc = nmpc or make_nmpc(vehicle, settings.nmpc)
    planned = settings.process.resolved(settings.nmpc.kind) == "planned"
    if isinstance(nmpc, FullNMPC):
        # The planned process keeps the NMPC's predictions as clear of the scene as its guard asks (the
        # obstacle OCP); the staged one does not see the scene.
        nmpc.keep_clear(scene if planned else Scene(), predicted_clearance_m(settings))
    if planned:
        return PlannedProcess(vehicle, settings, scene, nmpc, delay)
    return StagedProcess(make_stages(vehicle, settings, nmpc), hand_over=settings.nmpc.kind != "paper")


def park(
    vehicle: VehicleTrailer,
    start: State,
    goal: Pose | None = None,
    settings: ManeuverSettings | None = None,
    name: str = "",
    controller: TrailerNMPC | FullNMPC | None = None,
    plant: PlantSettings | None = None,
    scene: Scene | None = None,
    clock: Clock | None = None,
) -> ManeuverResult:
    """Park the trailer at ``goal`` from ``start``: reverse, and forward and reverse again as needed (Fig. 7).

    Parameters
    ----------
    vehicle : VehicleTrailer
        The controller's model of the combination (L_H > 0).
    start : State
        True start trailer-axle pose and hitch angle (world frame); the car stands, wheels straight.
    goal : Pose
        Goal trailer-axle pose (default: the origin, heading +x).
    settings : ManeuverSettings
        NMPC, forward stage and success settings; ``settings.nmpc.kind`` picks the process.
    controller : TrailerNMPC or FullNMPC, optional
        A ready reverse controller to reuse (built for ``vehicle`` and ``settings.nmpc``); building one
        compiles the NLP, so batch runs pass their own. It serves any goal.
    plant : PlantSettings
        The car driven (default: the realistic car, :class:`PlantSettings`); its lengths may differ
        from ``vehicle``'s.
    scene : Scene
        Obstacles and an area, world frame (default: none). The planned process avoids them; the staged
        one does not see them. Checked on the true motion at the end, against
        ``settings.success.min_clearance_m`` (outcome ``collision`` if closer).
    clock : Clock, optional
        Paces the loop (``hitchpark realtime``: a wall-clock tick); default: as fast as it runs.

    Returns
    -------
    ManeuverResult
        ``success``, ``reason`` (an :class:`Outcome` value) and ``detail``, the stages, the trajectory
        and the scene.
    """
    check_vehicle(vehicle).require_hitch_offset()
    check_state(vehicle, start)
    goal = check_goal(goal)
    settings = ManeuverSettings() if settings is None else settings
    check_instance("settings", settings, ManeuverSettings, "hitchpark.maneuver.ManeuverSettings(...)")
    plant = PlantSettings() if plant is None else plant
    check_instance("plant", plant, PlantSettings, "hitchpark.PlantSettings(...)")
    check_text("name", name, max_length=200)
    scene = Scene() if scene is None else scene
    check_instance("scene", scene, Scene, "hitchpark.model.Scene(obstacles, area)")
    if clock is not None and not all(callable(getattr(clock, m, None)) for m in ("tick", "restart")):
        raise InputError(f"clock must have tick() and restart() methods, got {type(clock).__name__}")
    if controller is not None:
        check_instance("controller", controller, (TrailerNMPC, FullNMPC))
    if controller is not None and (controller.vehicle, controller.settings) != (vehicle, settings.nmpc):
        raise InputError("controller was built for another vehicle or NMPC settings than this maneuver")
    crit = settings.success
    car = Plant(plant, vehicle, start, settings.nmpc.dt)
    loop = _Loop(
        car,
        goal,
        plant.delay_steps,
        crit.max_time,
        vehicle.max_steer_rate,
        vehicle.max_accel,
        clock=clock,
    )
    process = make_process(vehicle, settings, scene, controller, plant.delay_steps)
    stages: list[StageResult] = []
    next_stage = process.first(car.sense(), goal)
    if clock is not None:
        clock.restart()
    while not isinstance(next_stage, Ending):
        stage = next_stage
        index, first = len(stages), len(loop.states)
        ended = _run_stage(loop, index, stage)
        state = car.state.as_array()
        dist, orient = pose_errors(goal, state)
        stages.append(
            StageResult(
                stage.kind,
                len(loop.states) - first,
                dist,
                math.degrees(orient),
                math.degrees(state[3]),
                first,
                len(loop.states),
                ended.reason[:200],
                stage.controller,
            )
        )
        if loop.outcome is not None:
            break
        verdict = process.next(car.sense(), goal, ended) if ended.failed else None
        if clock is not None:
            clock.restart()
        if isinstance(verdict, Ending):
            next_stage = verdict
            break
        parked = dist <= crit.distance and abs(orient) <= crit.orientation and abs(state[3]) <= crit.hitch
        if stage.kind == "reverse" and parked:
            loop.outcome = Outcome.PARKED
            break
        next_stage = verdict if verdict is not None else process.next(car.sense(), goal, ended)
        if clock is not None:
            clock.restart()
        if (
            not isinstance(next_stage, Ending)
            and next_stage.kind != stage.kind
            and direction_segments_of(stages) >= crit.max_stages
        ):
            loop.outcome = Outcome.MAX_STAGES
            break
    if not stages:  # the process ended before any stage (no path from the start): one row, standing
        stages.append(StageResult("reverse", 0, *_errors_deg(goal, car.state.as_array()), 0, 0, "not started", ""))
    if isinstance(next_stage, Ending) and loop.outcome is None:
        loop.outcome, loop.detail = next_stage.outcome, next_stage.detail
    loop.final_row(len(stages) - 1)
    traj = loop.trajectory()
    real = car.vehicle
    within_limits = (
        np.max(np.abs(traj["front_steer"])) <= real.max_steer + 1e-12
        and np.max(np.abs(traj["hitch"])) <= real.max_hitch
    )
    outcome = loop.outcome
    assert outcome is not None  # every way out of the loop sets it
    success = outcome is Outcome.PARKED and bool(within_limits) and car.t <= crit.max_time + 1e-9
    if outcome is Outcome.PARKED and not success:
        outcome = Outcome.LIMITS_EXCEEDED
    detail = loop.detail
    swept = None
    if not scene.is_empty:
        least, row, contact = swept_contact(real, scene, traj.states())
        swept = least, row
        if least == 0.0 or least < crit.min_clearance_m:
            near = f": {contact.describe()} near t = {traj['t'][row]:.1f} s" if contact is not None else ""
            own = f"; its own outcome: {outcome.value}" + (f" ({detail})" if detail else "")
            detail = f"clearance {least:.3g} m, less than min_clearance_m {crit.min_clearance_m:g} m{near}{own}"
            if least == 0.0:
                within = f"{100 * MAX_STEP_M / 2:g} cm"
                detail = f"clearance 0 (touching, leaving the area, or passing within {within}){near}{own}"
            success, outcome = False, Outcome.COLLISION
    plans = tuple(PlanRecord.of(p) for p in process.plans)
    result = ManeuverResult(
        vehicle, start, goal, settings, success, outcome.value, tuple(stages), traj, name, plant, detail, scene, plans
    )
    if swept is not None:
        result.__dict__["swept"] = swept  # the cached property's value: computed once per maneuver
    return result
