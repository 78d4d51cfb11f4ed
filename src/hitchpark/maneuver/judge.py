"""Judging a maneuver: each stage's record, whether the car is parked, and the verdict on the whole motion.

A maneuver ends, in this order of rank: on the loop's own outcome (a jackknife, the time limit, a stage that
stalled), parked (after a reverse stage, within the success tolerances: checked before the process is asked
what comes next, so no plan is made for a car that is parked), at the limit of direction segments, or as the
process ends it (no path, too many replans). The verdict then checks the whole true motion: the steer and
hitch limits of the real car, the time, and among obstacles the least clearance of its bodies.
"""

from __future__ import annotations

import math

import numpy as np

from ..model.collision import MAX_STEP_M, swept_contact
from ..model.scene import Scene
from ..model.simulate import Trajectory
from ..model.state import Pose
from .loop import ClosedLoop
from .result import Outcome, StageResult, pose_errors
from .settings import SuccessCriteria
from .stages import Stage, StageEnd

__all__ = ["is_parked", "not_started", "stage_result", "verdict"]


def stage_result(stage: Stage, ended: StageEnd, loop: ClosedLoop, first: int) -> StageResult:
    """The record of ``stage``, which began at row ``first`` and ended so, with the errors where the car stands."""
    state = loop.plant.state.as_array()
    dist, orient = pose_errors(loop.goal, state)
    return StageResult(
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


def not_started(goal: Pose, state: np.ndarray) -> StageResult:
    """The one row of a maneuver the process ended before any stage (no path from the start): standing."""
    dist, orient = pose_errors(goal, state)
    return StageResult("reverse", 0, dist, math.degrees(orient), math.degrees(state[3]), 0, 0, "not started", "")


def is_parked(loop: ClosedLoop, criteria: SuccessCriteria) -> bool:
    """Whether the car stands within the success tolerances of distance, orientation and hitch."""
    state = loop.plant.state.as_array()
    dist, orient = pose_errors(loop.goal, state)
    return dist <= criteria.distance and abs(orient) <= criteria.orientation and abs(state[3]) <= criteria.hitch


def verdict(
    loop: ClosedLoop, trajectory: Trajectory, scene: Scene, criteria: SuccessCriteria
) -> tuple[bool, Outcome, str, tuple[float, int] | None]:
    """Success, outcome and detail of the whole maneuver, and (among obstacles) the least clearance of the true
    motion with its row.

    Parked is a success only within the real car's steer and hitch limits and the time limit (else
    ``limits_exceeded``); whatever the outcome, a motion that came nearer the scene than ``min_clearance_m`` is
    a ``collision``.
    """
    real = loop.plant.vehicle
    within_limits = (
        np.max(np.abs(trajectory["front_steer"])) <= real.max_steer + 1e-12
        and np.max(np.abs(trajectory["hitch"])) <= real.max_hitch
    )
    outcome = loop.outcome
    assert outcome is not None  # every way out of the loop sets it
    success = outcome is Outcome.PARKED and bool(within_limits) and loop.plant.t <= criteria.max_time + 1e-9
    if outcome is Outcome.PARKED and not success:
        outcome = Outcome.LIMITS_EXCEEDED
    detail = loop.detail
    if scene.is_empty:
        return success, outcome, detail, None
    least, row, contact = swept_contact(real, scene, trajectory.states())
    if least == 0.0 or least < criteria.min_clearance_m:
        near = f": {contact.describe()} near t = {trajectory['t'][row]:.1f} s" if contact is not None else ""
        own = f"; its own outcome: {outcome.value}" + (f" ({detail})" if detail else "")
        detail = f"clearance {least:.3g} m, less than min_clearance_m {criteria.min_clearance_m:g} m{near}{own}"
        if least == 0.0:
            within = f"{100 * MAX_STEP_M / 2:g} cm"
            detail = f"clearance 0 (touching, leaving the area, or passing within {within}){near}{own}"
        success, outcome = False, Outcome.COLLISION
    return success, outcome, detail, (least, row)
