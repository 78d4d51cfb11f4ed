"""The planned process: plan a path among the obstacles, track it, and plan again when it cannot be followed.

From the measured start, :func:`~hitchpark.planning.plan` finds a path on the full model that
keeps ``success.min_clearance_m + process.plan_margin_m`` from the scene and ends at the goal (among
obstacles, failing that within half the planner's expansions, on the goal line ``process.handover_m`` to
``process.approach_m`` out, heading along it, a straight reverse along the line following). The direction
segments become stages between standstills: the full NMPC tracks the last reverse segment to the goal
(``process.nmpc_tracking``, its reference :class:`~hitchpark.ocp.reference.PathReference`), a
:class:`~hitchpark.control.path_tracking.PathTracker` drives the others. (Without ``nmpc_tracking`` the
tracker drives the last one too, until ``process.handover_m`` is left, and the NMPC parks the rest; the
path then ends on the goal line first, the NMPC parking best from a straight approach.) Among obstacles
every stage is guarded (:class:`~hitchpark.control.guard.Guard`).

When the NMPC ends unparked near the goal, the car pulls forward straight along the goal line (as far
as keeps clear) and reverses again. When a stage cannot go on (the car strayed from the path, a body
came too close, the NMPC failed) or no correction is possible, the car stops and the process plans
again from where it stands, at most ``process.max_replans`` times. A plan that finds nothing ends the
maneuver as ``no_path``, the car standing. In an empty scene the staged process (Fig. 7) takes over
instead: it repositions forward along the goal line and reverses again, which parks from anywhere in
open space.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import replace

import numpy as np

from ..control.guard import Guard
from ..control.nmpc import FullNMPC, TrailerNMPC
from ..control.path_tracking import PathTracker, direction_segments
from ..model.plant import Measurement
from ..model.scene import Scene
from ..model.state import Pose, from_goal_frame, to_goal_frame
from ..model.vehicle import VehicleTrailer
from ..ocp.reference import PathReference
from ..planning import Plan, PlannerSettings, plan, prepare
from .result import Outcome
from .settings import ManeuverSettings
from .stages import (
    Ending,
    GuardedStage,
    ReverseStage,
    Stage,
    StagedProcess,
    StageEnd,
    TrackingStage,
    make_stages,
)

__all__ = [
    "ON_LINE_ANGLE",
    "ON_LINE_M",
    "PlannedProcess",
    "planner_settings",
    "prepare_scene",
    "straight_approach",
]

#: A correction (the NMPC ended unparked near the goal) pulls forward to this far beyond ``handover_m`` [m]
#: when pure pursuit tracks the approach; to ``handover_m`` when the NMPC does (measured over 100 starts:
#: as many park, the median path 1.3 m shorter; 2.5 m out parks fewer).
CORRECTION_M = 3.0

#: Corrections at most per maneuver.
MAX_CORRECTIONS = 2

#: A start within these of the goal line (lateral offset [m]; heading error and hitch [rad]), ahead of
#: the goal and within the approach, reverses straight along it without a plan.
ON_LINE_M = 0.1
ON_LINE_ANGLE = math.radians(2.0)


def straight_approach(goal: Pose, length: float, step: float) -> np.ndarray:
    """Configurations (x_t, y_t, yaw_t, hitch = 0) on the goal line from the goal out to ``length`` ahead of it."""
    s = np.linspace(0.0, length, max(2, int(np.ceil(length / step)) + 1))
    x, y, yaw = from_goal_frame(goal, s, np.zeros_like(s), np.zeros_like(s))
    return np.column_stack([x, y, yaw, np.zeros_like(s)])


def planner_settings(settings: ManeuverSettings) -> PlannerSettings:
    """The planner's settings in the planned process: its paths keep ``success.min_clearance_m +
    process.plan_margin_m`` (or the planner's own, if more). A start nearer the scene than that is planned from
    keeping its own clearance, down to ``success.min_clearance_m`` (nearer than the guard's clearance, the guard
    lets a stage keep what it begins with, :meth:`~hitchpark.control.guard.Guard.begin`). Its forward runs keep
    within the tracker's steer cap."""
    clearance = max(settings.planner.min_clearance_m, settings.success.min_clearance_m + settings.process.plan_margin_m)
    slack = max(0.0, clearance - settings.success.min_clearance_m)
    return replace(
        settings.planner,
        min_clearance_m=clearance,
        start_slack_m=slack,
        forward_length_tolerance=settings.tracking.length_tolerance,
    )


def prepare_scene(vehicle: VehicleTrailer, goal: Pose, scene: Scene, settings: ManeuverSettings) -> None:
    """Build (or load) what the planned process's plans to ``goal`` among ``scene`` use before their clocks start:
    the goal tree and the compiled rollouts (:func:`~hitchpark.planning.prepare`); nothing in open space."""
    if not scene.is_empty:
        prepare(vehicle, goal, scene, planner_settings(settings))


class PlannedProcess:
    """See the module text. ``plans`` holds every plan made, in order (their times add up to the planning time)."""

    def __init__(
        self,
        vehicle: VehicleTrailer,
        settings: ManeuverSettings,
        scene: Scene,
        nmpc: TrailerNMPC | FullNMPC,
        delay: int,
    ):
        self.vehicle, self.settings, self.scene, self.nmpc = vehicle, settings, scene, nmpc
        self.planner = planner_settings(settings)
        self.tracking = settings.tracking
        self.guard = None
        if not scene.is_empty:
            # Among obstacles the planner may turn the trailer up to its obstacle_virtual_limit: the tracker
            # must be allowed as much to follow.
            limit = max(settings.tracking.virtual_limit, self.planner.obstacle_virtual_limit)
            self.tracking = replace(settings.tracking, virtual_limit=limit)
            self.guard = Guard(
                vehicle,
                scene,
                settings.success.min_clearance_m,
                settings.process.guard_margin_m,
                settings.nmpc.dt,
                delay,
            )
        self.plans: list[Plan] = []
        self.rounds = 0  # times it planned (each may have made two plans, see _plan)
        self.corrections = 0
        self.standing_stops = 0  # guard stops of a stage before it moved
        self.queue: deque[Stage] = deque()
        self.fallback: StagedProcess | None = None

    def first(self, measurement: Measurement, goal: Pose) -> Stage | Ending:
        return self._plan(measurement, goal)

    def next(self, measurement: Measurement, goal: Pose, ended: StageEnd) -> Stage | Ending:
        if self.fallback is not None:
            return self.fallback.next(measurement, goal, ended)
        if ended.failed and ended.controller == "nmpc" and ended.step == 0 and not ended.status.startswith("guard:"):
            return Ending(Outcome.SOLVER, ended.status)  # the NMPC cannot even start: stop, as the staged process does
        if not ended.failed and self.queue:
            return self.queue.popleft()
        if not ended.failed:
            # The NMPC ended the path unparked, near the goal: a plan from there would hand it the same start.
            # Pull forward straight along the goal line and reverse again, if that keeps clear; in open
            # space the 3-stage process takes over otherwise.
            correction = self._correction(measurement, goal)
            if correction:
                self.queue = deque(correction)
                return self.queue.popleft()
            if self.scene.is_empty:
                return self._fall_back(measurement, goal, ended)
        if self.rounds > self.settings.process.max_replans:
            why = ended.reason if ended.failed else "the path ended unparked"
            return Ending(Outcome.NO_PATH, f"gave up after {self.rounds - 1} replans; last: {why}")
        if ended.failed and ended.step == 0 and ended.status.startswith("guard:"):
            # Stopped before it moved: the straight approach (no plan, no round counted) would be handed the same
            # stop again and again.
            self.standing_stops += 1
            if self.standing_stops > self.settings.process.max_replans:
                why = f"the guard stopped the car {self.standing_stops} times before it moved"
                return Ending(Outcome.NO_PATH, f"gave up: {why}; last: {ended.reason}")
        return self._plan(measurement, goal)

    def _fall_back(self, measurement: Measurement, goal: Pose, ended: StageEnd | None = None) -> Stage | Ending:
        self.fallback = StagedProcess(make_stages(self.vehicle, self.settings, self.nmpc), hand_over=True)
        if ended is None:
            return self.fallback.first(measurement, goal)
        return self.fallback.next(measurement, goal, ended)

    def _plan(self, measurement: Measurement, goal: Pose) -> Stage | Ending:
        approach = self._approach(goal)
        s = measurement.state
        gx, gy, gyaw = (float(v) for v in to_goal_frame(goal, s.x, s.y, s.yaw))
        if (
            0.0 <= gx <= approach
            and abs(gy) <= ON_LINE_M
            and abs(gyaw) <= ON_LINE_ANGLE
            and abs(s.hitch) <= ON_LINE_ANGLE
        ):
            # Already on the straight approach: reverse along the goal line, no plan needed.
            self.queue = deque(self._stages(None, s.as_array()[None, :], goal))
            return self.queue.popleft()
        self.rounds += 1
        # Tracked by the NMPC, to the goal itself; among obstacles, if that fails within half the planner's
        # expansions (``max_expansions``), to the goal line ``handover_m`` to ``approach`` out (the loading
        # dock was found so, its approach a sub-goal). Tracked by pure pursuit, the NMPC parks best from a
        # straight approach: to that stretch of the goal line first, within 60% of the expansions, then to
        # the goal. In open space the search heads for the goal (its opening then finds more single reverse
        # runs); among obstacles for the near end of that stretch.
        near = min(self.settings.process.handover_m, approach)
        budget = self.planner.max_expansions
        aim = Pose(*from_goal_frame(goal, near, 0.0, 0.0))
        line = (goal, near, approach, 0.6) if self.scene.is_empty else (aim, 0.0, approach - near, 0.6)
        if approach <= 0.0 or (self._tracked and self.scene.is_empty):
            todo = [(goal, 0.0, 0.0, 1.0)]
        elif self._tracked:
            todo = [(goal, 0.0, 0.0, 0.5), line]
        else:
            todo = [line, (goal, 0.0, 0.0, 0.4)]
        spent = 0
        for i, (target, first, last, share) in enumerate(todo):
            limit = round(share * budget) if i < len(todo) - 1 else budget - spent
            found = plan(
                self.vehicle,
                measurement.state,
                target,
                self.scene,
                replace(self.planner, goal_line_from_m=first, goal_line_m=last, max_expansions=max(limit, 1)),
            )
            self.plans.append(found)
            spent += found.expanded
            if found.found:
                break
        if not found.found:
            if self.scene.is_empty:
                return self._fall_back(measurement, goal)
            outcome = Outcome.PLANNER_TIMEOUT if found.status == "planner_timeout" else Outcome.NO_PATH
            return Ending(outcome, f"planner: {found.status}: {found.detail}")
        self.queue = deque(self._stages(found.path["direction"], found.states, goal, found.path["front_steer"]))
        return self.queue.popleft()

    def _correction(self, measurement: Measurement, goal: Pose) -> list[Stage]:
        """Forward along the goal line to ``handover_m`` out (``handover_m + CORRECTION_M`` if pure pursuit
        tracks the approach; less if that is not clear), then the straight approach; none if the car is not
        near the line, or no such line keeps clear."""
        s = measurement.state
        gx, gy, gyaw = (float(v) for v in to_goal_frame(goal, s.x, s.y, s.yaw))
        self.corrections += 1
        if self.corrections > MAX_CORRECTIONS or gx < -0.5 or abs(gy) > 0.5 or abs(gyaw) > math.radians(15.0):
            return []
        extras = (0.0, -1.0, -2.0) if self._tracked else (CORRECTION_M, 2.0, 1.0, 0.0)
        for extra in extras:  # as far out as keeps clear
            out = self.settings.process.handover_m + extra
            line = straight_approach(goal, out, 0.1)
            if out >= max(gx, 0.0) + 1.0 and (self.guard is None or self.guard.clear(line)):
                break
        else:
            return []
        ahead = line[to_goal_frame(goal, line[:, 0], line[:, 1], line[:, 2])[0] > max(gx, 0.0) + 0.05]
        forward = PathTracker(
            self.vehicle, self.tracking, self.settings.nmpc.dt, np.vstack([s.as_array()[None, :], ahead]), 1
        )
        return [self._guarded(TrackingStage(forward)), *self._stages(None, line[-1:], goal)]

    @property
    def _tracked(self) -> bool:
        """Whether the NMPC tracks the last reverse segment (the full model's NMPC, ``process.nmpc_tracking``)."""
        return self.settings.process.nmpc_tracking and isinstance(self.nmpc, FullNMPC)

    def _approach(self, goal: Pose) -> float:
        """Length of the straight final approach [m]: ``process.approach_m``, halved until it keeps clear."""
        length = self.settings.process.approach_m
        while length > 0.25:
            if self.guard is None:
                return length
            line = straight_approach(goal, length, self.settings.tracking.speed * self.settings.nmpc.dt)
            if self.guard.clear(line):
                return length
            length /= 2
        return 0.0

    def _stages(
        self, direction: np.ndarray | None, configs: np.ndarray, goal: Pose, steer: np.ndarray | None = None
    ) -> list[Stage]:
        """The stages that drive a path (its ``direction`` and ``configs``; None: the path is ``configs[0]``
        alone) and the straight approach after it: one per direction segment, the NMPC at the end.

        The path ends at the approach's start (refined) or within the planner's goal tolerance of it; the
        last reverse segment goes on along the goal line to the goal itself. The NMPC tracks it all (its reference the
        planned part and its own line, ``steer`` the plan's front steer at each row); without
        ``nmpc_tracking`` a tracker pursues it and hands over to the NMPC ``process.handover_m`` before the goal.
        """
        steer = np.zeros(len(configs)) if steer is None else steer
        segments = []
        segment_steers: list[np.ndarray] = []
        if direction is not None:
            segments = [(configs[a : b + 1], int(direction[a + 1])) for a, b in direction_segments(direction)]
            segment_steers = [steer[a : b + 1] for a, b in direction_segments(direction)]
        end = to_goal_frame(goal, configs[-1, 0], configs[-1, 1], configs[-1, 2])[0]
        line = straight_approach(goal, max(float(end), 0.0), 0.1)[::-1]  # from abreast of the path's end to the goal
        # The NMPC's reference: the planned part of the last segment and its front steer (it makes its own
        # line to the goal, closing the gap to it gradually).
        if segments and segments[-1][1] < 0:
            planned, planned_steer = segments[-1][0], steer[len(configs) - len(segments[-1][0]) :]
            segments[-1] = (np.vstack([segments[-1][0], line]), -1)
        else:
            planned, planned_steer = configs[-1:], steer[-1:]
            segments.append((np.vstack([configs[-1:], line]), -1))
        stages: list[Stage] = []
        track = self._tracked
        for i, (part, d) in enumerate(segments):
            last = i == len(segments) - 1
            if last and track:
                break
            until = self.settings.process.handover_m if last else 0.0
            steers = segment_steers[i] if i < len(segment_steers) and len(segment_steers[i]) == len(part) else None
            tracker = PathTracker(self.vehicle, self.tracking, self.settings.nmpc.dt, part, d, until, steers)
            if tracker.stop_at > 0.0:
                stages.append(self._guarded(TrackingStage(tracker)))
        reference = None
        if track:
            s = self.settings.nmpc
            assert s.prediction_dt is not None and s.horizon is not None
            speed = self.tracking.speed
            reference = PathReference(
                planned, goal, speed, self.vehicle.max_accel, s.prediction_dt, s.horizon, planned_steer
            )
        stages.append(self._guarded(ReverseStage(self.nmpc, reference, self.tracking.max_deviation_m)))
        return stages

    def _guarded(self, stage: Stage) -> Stage:
        return stage if self.guard is None else GuardedStage(stage, self.guard)
