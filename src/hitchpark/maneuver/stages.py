"""Stages of a maneuver: a small protocol, and the processes that make them.

A stage is a controller with a direction: it may ask for a steer to start with (set while
standing still), it acts on each measurement, and it says when it is done. A process is
the pair of stages a maneuver alternates between (reverse, forward, reverse, ... as in
Fig. 7), registered by the NMPC kind that drives it.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Protocol

from ..control.nmpc import FullNMPC, NMPCStep, TrailerNMPC, make_nmpc
from ..control.pure_pursuit import ForwardPursuit
from ..model.plant import Command, Measurement
from ..model.state import Pose
from ..model.vehicle import VehicleTrailer
from .result import ManeuverSettings

__all__ = ["PROCESSES", "Stage", "StagePair", "make_stages"]


class Stage(Protocol):
    """One direction of travel under one controller."""

    kind: str  # "reverse" or "forward"

    @property
    def rate_limited(self) -> bool:
        """Whether the commanded steer must move no faster than the vehicle's ``max_steer_rate``."""
        ...

    @property
    def max_steps(self) -> int:
        """A stage that has not ended after this many steps ends as stalled."""
        ...

    def begin(self, measurement: Measurement, goal: Pose) -> float | None:
        """Start afresh at standstill; return the steer to set before moving (None: move at once)."""
        ...

    def act(self, measurement: Measurement, goal: Pose, in_flight: Sequence[Command]) -> NMPCStep:
        """The command for the next sample; ``stop`` when the stage is over, ``ok`` False on failure."""
        ...


class ReverseStage:
    """Reverse under an NMPC (the paper's or the full model's) until its optimal speed is zero."""

    kind = "reverse"

    def __init__(self, nmpc: TrailerNMPC | FullNMPC):
        self.nmpc = nmpc

    @property
    def rate_limited(self) -> bool:
        return self.nmpc.settings.kind != "paper"  # the paper's NMPC commands Eq. (45) at once

    @property
    def max_steps(self) -> int:
        return self.nmpc.settings.max_steps

    def begin(self, measurement: Measurement, goal: Pose) -> float | None:
        self.nmpc.reset(measurement.front_steer)
        return self.nmpc.initial_steer(measurement, goal)

    def act(self, measurement: Measurement, goal: Pose, in_flight: Sequence[Command]) -> NMPCStep:
        return self.nmpc.act(measurement, goal, in_flight)


class ForwardStage:
    """Forward repositioning by pure pursuit (Section 5) until it is far enough out and straight."""

    kind = "forward"

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

    def act(self, measurement: Measurement, goal: Pose, in_flight: Sequence[Command]) -> NMPCStep:
        return self.pursuit.act(measurement, goal, in_flight)


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
