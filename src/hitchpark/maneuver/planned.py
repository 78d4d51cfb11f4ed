"""The planned process: plan a path among the obstacles, track it, and plan again when it cannot be followed.

From the measured start, :func:`~hitchpark.control.planner.plan` finds a path on the full model that
keeps ``success.min_clearance_m + process.plan_margin_m`` from the scene, to a point
``process.approach_m`` out along the goal line; a straight reverse along the line to the goal follows
(the NMPC parks best from a straight approach, as after the paper's forward stage). The direction
segments become stages, each tracked by a :class:`~hitchpark.control.path_tracking.PathTracker`
between standstills; the reverse NMPC parks the last ``process.handover_m`` to the millimetre. Among
obstacles every stage is guarded (:class:`~hitchpark.control.guard.Guard`).

When a stage cannot go on (the car strayed from the path, a body came too close, the NMPC failed) or
the path ends unparked among obstacles, the car stops and the process plans again from where it
stands, at most ``process.max_replans`` times. A plan that finds nothing ends the maneuver as
``no_path``, the car standing. In an empty scene the staged process (Fig. 7) takes over instead when
no path is found or the NMPC ends the path unparked: it repositions forward along the goal line and
reverses again, which parks from anywhere in open space.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import replace

import numpy as np

from ..control.guard import Guard
from ..control.nmpc import FullNMPC, TrailerNMPC
from ..control.path_tracking import PathTracker, direction_segments
from ..control.planner import Plan, plan
from ..model.plant import Measurement
from ..model.scene import Scene
from ..model.state import Pose, from_goal_frame, to_goal_frame
from ..model.vehicle import VehicleTrailer
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

__all__ = ["ON_LINE_ANGLE", "ON_LINE_M", "PlannedProcess", "straight_approach"]

#: A start within these of the goal line (lateral offset [m]; heading error and hitch [rad]), ahead of
#: the goal and within the approach, reverses straight along it without a plan.
ON_LINE_M = 0.1
ON_LINE_ANGLE = math.radians(2.0)


def straight_approach(goal: Pose, length: float, step: float) -> np.ndarray:
    """Configurations (x_t, y_t, yaw_t, hitch = 0) on the goal line from the goal out to ``length`` ahead of it."""
    s = np.linspace(0.0, length, max(2, int(np.ceil(length / step)) + 1))
    x, y, yaw = from_goal_frame(goal, s, np.zeros_like(s), np.zeros_like(s))
    return np.column_stack([x, y, yaw, np.zeros_like(s)])


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
        clearance = settings.success.min_clearance_m + settings.process.plan_margin_m
        self.planner = replace(settings.planner, min_clearance_m=max(settings.planner.min_clearance_m, clearance))
        self.guard = None
        if not scene.is_empty:
            self.guard = Guard(
                vehicle,
                scene,
                settings.success.min_clearance_m,
                settings.process.guard_margin_m,
                settings.nmpc.dt,
                delay,
            )
        self.plans: list[Plan] = []
        self.queue: deque[Stage] = deque()
        self.fallback: StagedProcess | None = None

    def first(self, measurement: Measurement, goal: Pose) -> Stage | Ending:
        return self._plan(measurement, goal)

    def next(self, measurement: Measurement, goal: Pose, ended: StageEnd) -> Stage | Ending:
        if self.fallback is not None:
            return self.fallback.next(measurement, goal, ended)
        if ended.failed and ended.controller == "nmpc" and ended.step == 0:
            return Ending(Outcome.SOLVER, ended.status)  # the NMPC cannot even start: stop, as the staged process does
        if not ended.failed and self.queue:
            return self.queue.popleft()
        if not ended.failed and self.scene.is_empty:
            # The NMPC ended the path unparked (near the goal: a plan from there would hand it the same
            # start). In open space, reposition forward along the goal line and reverse again (Fig. 7).
            return self._fall_back(measurement, goal, ended)
        if len(self.plans) > self.settings.process.max_replans:
            why = f"{ended.reason}: {ended.status}" if ended.failed else "the path ended unparked"
            return Ending(Outcome.NO_PATH, f"gave up after {len(self.plans) - 1} replans; last: {why}")
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
            self.queue = deque(self._stages(None, s.as_array()[None, :], goal, gx))
            return self.queue.popleft()
        aim = Pose(*from_goal_frame(goal, approach, 0.0, 0.0))
        found = plan(self.vehicle, measurement.state, aim, self.scene, self.planner)
        self.plans.append(found)
        if not found.found:
            if self.scene.is_empty:
                return self._fall_back(measurement, goal)
            return Ending(Outcome.NO_PATH, f"planner: {found.status}: {found.detail}")
        self.queue = deque(self._stages(found.path["direction"], found.states, goal, approach))
        return self.queue.popleft()

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

    def _stages(self, direction: np.ndarray | None, configs: np.ndarray, goal: Pose, approach: float) -> list[Stage]:
        """The stages that drive a path (its ``direction`` and ``configs``; None: the path is ``configs[0]``
        alone) and the straight approach after it: one per direction segment, the NMPC at the end.

        The path ends within the planner's goal tolerance of the approach's start; the last reverse
        segment goes on along the goal line to the goal itself, its tracker pursuing the line, and hands
        over to the NMPC ``process.handover_m`` before the goal.
        """
        segments = []
        if direction is not None:
            segments = [(configs[a : b + 1], int(direction[a + 1])) for a, b in direction_segments(direction)]
        line = straight_approach(goal, approach, 0.1)[::-1]  # from the approach's start to the goal
        if segments and segments[-1][1] < 0:
            segments[-1] = (np.vstack([segments[-1][0], line]), -1)
        else:
            segments.append((np.vstack([configs[-1:], line]), -1))
        stages: list[Stage] = []
        for i, (part, d) in enumerate(segments):
            until = self.settings.process.handover_m if i == len(segments) - 1 else 0.0
            tracker = PathTracker(self.vehicle, self.settings.tracking, self.settings.nmpc.dt, part, d, until)
            if tracker.stop_at > 0.0:
                stages.append(self._guarded(TrackingStage(tracker)))
        stages.append(self._guarded(ReverseStage(self.nmpc)))
        return stages

    def _guarded(self, stage: Stage) -> Stage:
        return stage if self.guard is None else GuardedStage(stage, self.guard)
