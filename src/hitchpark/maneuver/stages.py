"""Stages of a maneuver and the processes that choose them: two small protocols.

A stage is a controller with a direction: it may ask for a steer to start with (set while
standing still), it acts on each measurement, and it says when it is done. A process says which
stage comes first and, each time one ends (at standstill), which comes next or how the maneuver
ends. The staged process alternates a reverse and a forward stage (Fig. 7), built for the NMPC kind
(:data:`PROCESSES`); the planned one (:mod:`.planned`) tracks a planned path.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Protocol

from ..checks import InputError
from ..control.guard import CLEARANCE_SPARE_M, Guard
from ..control.nmpc import FullNMPC, TrailerNMPC, make_nmpc
from ..control.path_tracking import PathTracker
from ..control.pure_pursuit import ForwardPursuit
from ..control.step import ControlStep
from ..model.plant import Command, Measurement
from ..model.state import Pose
from ..model.vehicle import VehicleTrailer
from ..ocp.reference import PathReference
from ..planning import Plan
from .result import Outcome
from .settings import ManeuverSettings

__all__ = [
    "PROCESSES",
    "Ending",
    "GuardedStage",
    "Process",
    "Stage",
    "StageEnd",
    "StagePair",
    "StagedProcess",
    "TrackingStage",
    "make_stages",
]


class Stage(Protocol):
    """One direction of travel under one controller."""

    kind: str  # "reverse" or "forward"
    controller: str  # what drives it: "nmpc", "pursuit" (Section 5) or "tracking" (a planned path)

    @property
    def rate_limited(self) -> bool:
        """Whether the commanded steer must move no faster than the vehicle's ``max_steer_rate``."""
        ...

    @property
    def max_steps(self) -> int:
        """A stage that has not ended after this many steps ends as stalled, unless it still makes its way
        (``hitchpark.maneuver.loop.run_stage``)."""
        ...

    def begin(self, measurement: Measurement, goal: Pose) -> float | None:
        """Start afresh at standstill; return the steer to set before moving (None: move at once)."""
        ...

    def act(self, measurement: Measurement, goal: Pose, in_flight: Sequence[Command]) -> ControlStep:
        """The command for the next sample; ``stop`` when the stage is over, ``ok`` False on failure."""
        ...


class ReverseStage:
    """Reverse under an NMPC (the paper's or the full model's) until its optimal speed is zero.

    With a ``reference`` (the full model's NMPC only) the NMPC tracks that path to the goal; the stage
    gives up (``ok`` False, the car stopped) when the trailer axle strays more than ``max_deviation_m``
    from it, so that the process can plan again.
    """

    kind = "reverse"
    controller = "nmpc"

    def __init__(
        self, nmpc: TrailerNMPC | FullNMPC, reference: PathReference | None = None, max_deviation_m: float = math.inf
    ):
        if reference is not None and not isinstance(nmpc, FullNMPC):
            raise InputError("only the full model's NMPC (nmpc.kind 'full') tracks a path")
        self.nmpc, self.reference, self.max_deviation_m = nmpc, reference, max_deviation_m

    @property
    def rate_limited(self) -> bool:
        return self.nmpc.settings.kind != "paper"  # the paper's NMPC commands Eq. (45) at once

    @property
    def max_steps(self) -> int:
        return self.nmpc.settings.max_steps

    def begin(self, measurement: Measurement, goal: Pose) -> float | None:
        self.nmpc.reset(measurement.front_steer)
        if isinstance(self.nmpc, FullNMPC):
            self.nmpc.follow(self.reference)
        return self.nmpc.initial_steer(measurement, goal)

    def act(self, measurement: Measurement, goal: Pose, in_flight: Sequence[Command]) -> ControlStep:
        step = self.nmpc.act(measurement, goal, in_flight)
        if self.reference is not None and self.reference.deviation > self.max_deviation_m:
            self.nmpc.reset(step.front_steer)
            why = f"deviated {self.reference.deviation:.2f} m from the planned path"
            return replace(step, trailer_speed=0.0, rear_speed=0.0, ok=False, stop=True, status=why)
        return step


class ForwardStage:
    """Forward repositioning by pure pursuit (Section 5) until it is far enough out and straight."""

    kind = "forward"
    controller = "pursuit"

    def __init__(self, pursuit: ForwardPursuit):
        self.pursuit = pursuit

    @property
    def rate_limited(self) -> bool:
        return self.pursuit.rate_limited

    @property
    def max_steps(self) -> int:
        return self.pursuit.max_steps

    def begin(self, measurement: Measurement, goal: Pose) -> float | None:
        self.pursuit.reset(measurement.front_steer)
        return self.pursuit.initial_steer(measurement, goal)

    def act(self, measurement: Measurement, goal: Pose, in_flight: Sequence[Command]) -> ControlStep:
        return self.pursuit.act(measurement, goal, in_flight)


class TrackingStage:
    """One direction segment of a planned path, tracked (:class:`~hitchpark.control.path_tracking.PathTracker`)."""

    rate_limited = True
    controller = "tracking"

    def __init__(self, tracker: PathTracker):
        self.tracker = tracker
        self.kind = "forward" if tracker.direction > 0 else "reverse"

    @property
    def max_steps(self) -> int:
        return self.tracker.max_steps

    def begin(self, measurement: Measurement, goal: Pose) -> float | None:
        self.tracker.reset(measurement.front_steer)
        return self.tracker.initial_steer(measurement, goal)

    def act(self, measurement: Measurement, goal: Pose, in_flight: Sequence[Command]) -> ControlStep:
        return self.tracker.act(measurement, goal, in_flight)


class GuardedStage:
    """A stage whose every command passes the :class:`~hitchpark.control.guard.Guard` first."""

    def __init__(self, stage: Stage, guard: Guard):
        self.stage, self.guard = stage, guard
        self.kind, self.controller = stage.kind, stage.controller
        self.most = math.inf  # the most the NMPC's predictions may be asked to keep this stage [m] (:meth:`_hold`)

    @property
    def rate_limited(self) -> bool:
        return self.stage.rate_limited

    @property
    def max_steps(self) -> int:
        return self.stage.max_steps

    def begin(self, measurement: Measurement, goal: Pose) -> float | None:
        need = self.guard.begin(measurement)
        nmpc = self._nmpc()
        if nmpc is not None:
            # Its predictions keep what the guard keeps this stage, and the spare (keep_clear's, or less).
            nmpc.ease_clearance(need + CLEARANCE_SPARE_M)
            if any(measurement.doubt):
                self._hold(nmpc, measurement, begins=True)
        return self.stage.begin(measurement, goal)

    def act(self, measurement: Measurement, goal: Pose, in_flight: Sequence[Command]) -> ControlStep:
        nmpc = self._nmpc()
        if nmpc is not None and any(measurement.doubt):
            self._hold(nmpc, measurement)
        return self.guard.check(measurement, goal, self.stage.act(measurement, goal, in_flight))

    def _nmpc(self) -> FullNMPC | None:
        """The full-model NMPC of a reverse stage (its predictions keep a clearance), else None."""
        if isinstance(self.stage, ReverseStage) and isinstance(self.stage.nmpc, FullNMPC):
            return self.stage.nmpc
        return None

    def _hold(self, nmpc: FullNMPC, measurement: Measurement, begins: bool = False) -> None:
        """With a doubtful estimate, the NMPC's predictions (the estimate's clearance) keep the guard's clearance
        plus what the doubt takes from it at the measured configuration, and the spare (else it plans what the
        guard stops), but never more than the stage began with (:attr:`most`; else a stage begun near the scene has
        no plan; ``begins``: the stage begins at ``measurement``). Called only with a doubt: with exact readings
        nothing changes."""
        now, gap = self.guard.doubt_gap(measurement)
        if begins:
            self.most = now - CLEARANCE_SPARE_M
        nmpc.hold_clearance(max(0.0, min(self.guard.stage_need + gap + CLEARANCE_SPARE_M, self.most)))


@dataclass(frozen=True)
class StageEnd:
    """How a stage ended: ``reason`` as recorded; ``failed`` with the controller's ``status`` and the
    step it failed at (0: before it moved)."""

    kind: str
    controller: str
    reason: str
    failed: bool = False
    status: str = ""
    step: int = 0


@dataclass(frozen=True)
class Ending:
    """The process's verdict that the maneuver ends, with its outcome and why."""

    outcome: Outcome
    detail: str = ""


class Process(Protocol):
    """Chooses the stages of a maneuver (see the module text); ``plans``: the paths it planned, in order."""

    plans: list[Plan]

    def first(self, measurement: Measurement, goal: Pose) -> Stage | Ending:
        """The first stage, at the start (standstill)."""
        ...

    def next(self, measurement: Measurement, goal: Pose, ended: StageEnd) -> Stage | Ending:
        """The stage after one that ``ended`` unparked, or the end of the maneuver."""
        ...


class StagedProcess:
    """Reverse, forward, reverse, ... (Fig. 7). A reverse stage's failure after it moved hands over to
    the forward stage when ``hand_over`` (the full process: it may have run into its limits, the next
    stage can reposition); any other failure ends the maneuver (outcome ``solver``)."""

    def __init__(self, stages: StagePair, hand_over: bool):
        self.reverse, self.forward = stages
        self.hand_over = hand_over
        self.plans: list[Plan] = []  # it plans nothing

    def first(self, measurement: Measurement, goal: Pose) -> Stage | Ending:
        return self.reverse

    def next(self, measurement: Measurement, goal: Pose, ended: StageEnd) -> Stage | Ending:
        if ended.failed and (ended.step == 0 or ended.kind != "reverse" or not self.hand_over):
            return Ending(Outcome.SOLVER, ended.status)
        return self.forward if ended.kind == "reverse" else self.reverse


#: A maneuver's stages: the reverse one and the forward one, alternated from reverse.
StagePair = tuple[Stage, Stage]

#: ``nmpc.kind -> builder``; a builder takes the vehicle, the settings and a ready NMPC.
PROCESSES: dict[str, Callable[[VehicleTrailer, ManeuverSettings, TrailerNMPC | FullNMPC], StagePair]] = {
    # The paper's 3-stage process: its NMPC, plain pure pursuit with commands acting at once.
    "paper": lambda v, s, nmpc: (
        ReverseStage(nmpc),
        ForwardStage(ForwardPursuit(v, s.forward, s.nmpc.dt, rate_limited=False)),
    ),
    # On a real car: the full-model NMPC, pure pursuit within the steer-rate and acceleration limits.
    "full": lambda v, s, nmpc: (
        ReverseStage(nmpc),
        ForwardStage(ForwardPursuit(v, s.forward, s.nmpc.dt, rate_limited=True)),
    ),
}


def make_stages(
    vehicle: VehicleTrailer, settings: ManeuverSettings, nmpc: TrailerNMPC | FullNMPC | None = None
) -> StagePair:
    """The stages of the process ``settings.nmpc.kind`` names, reusing ``nmpc`` if given."""
    return PROCESSES[settings.nmpc.kind](vehicle, settings, nmpc or make_nmpc(vehicle, settings.nmpc))
