"""What a controller decides each tick (:class:`ControlStep`) and what a controller is (:class:`Controller`).

Every controller, the NMPCs, the forward pursuit and the planned path's tracker, answers a measurement with a
:class:`ControlStep`; the guard passes it on, slowed or turned into a stop. Nothing here optimises: the
controllers that do not (pursuit, tracker, guard) need nothing of the OCPs or the solvers.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from ..model.plant import Command, Measurement
from ..model.state import Pose

__all__ = ["ControlStep", "Controller"]


def _none() -> np.ndarray:
    return np.zeros((0, 0))


@dataclass(frozen=True, kw_only=True)
class ControlStep:
    """What one controller step decided.

    ``rear_speed``/``front_steer`` are the vehicle command; ``trailer_speed``/``virtual_steer``
    the same motion in the trailer's virtual inputs (the paper's U_0, or Eqs. (18) and (56) of
    the command of the full model). ``ok`` is False when the controller failed (a solver that failed or gave a
    non-finite answer, a path left too far); the command is then a stop (zero speed, steer held) and ``status``
    says why. ``stop`` is True when the stage is over (the NMPC's optimal speed is zero, the path's end is
    reached). An NMPC also gives its ``cost``, the time of its solve ``solve_ms`` and its prediction over the
    horizon (``predicted_states``, ``predicted_inputs``: rows per step, parking frame); the others give none
    (NaN, empty).
    """

    trailer_speed: float
    virtual_steer: float
    rear_speed: float
    front_steer: float
    ok: bool
    stop: bool
    status: str = ""
    cost: float = math.nan
    solve_ms: float = math.nan
    predicted_states: np.ndarray = field(default_factory=_none)
    predicted_inputs: np.ndarray = field(default_factory=_none)

    @property
    def command(self) -> Command:
        return Command(self.rear_speed, self.front_steer)


class Controller(Protocol):
    """Who acts each tick: a command for the measurement, towards ``goal``, given the commands still in flight."""

    def act(self, measurement: Measurement, goal: Pose, in_flight: Sequence[Command] = ()) -> ControlStep: ...
