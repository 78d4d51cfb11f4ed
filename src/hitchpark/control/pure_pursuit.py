"""Forward repositioning (Section 5): pure pursuit of the vehicle along the line out of the space.

The path is the straight line through the goal along the goal heading (Fig. 6),
driven forward (out of the space). Pure pursuit steers the vehicle's rear axle
towards the point of the line one look-ahead distance away:
delta_f = atan(2 L sin(alpha) / l_d), alpha the bearing of that point seen from the
vehicle heading. The trailer is ignored by the controller (it follows, stably,
in forward motion). The stage ends when the hitch angle is under a threshold and
the trailer axle is farther than a threshold from the goal along the line.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..model.kinematics import rear_axle_pose
from ..model.vehicle import VehicleTrailer
from .nmpc import Pose, to_goal_frame

__all__ = ["PurePursuitSettings", "forward_done", "pure_pursuit_steer"]


@dataclass(frozen=True)
class PurePursuitSettings:
    """Forward-stage settings (the paper gives none; the defaults are justified in the README).

    Parameters
    ----------
    lookahead : float
        Look-ahead distance l_d [m] from the rear axle.
    speed : float
        Rear-axle speed [m/s], > 0 (forward).
    hitch_threshold : float
        The stage may end once |hitch| < this [rad].
    distance_threshold : float
        ... and the trailer axle is more than this ahead of the goal along the goal heading [m].
    orientation_threshold : float
        ... and the trailer heading is within this of the goal heading [rad]. Not in the
        paper: without it the stage can end while the hitch angle passes through zero
        in mid-turn, leaving the next reverse stage misaligned (see the README).
    max_distance : float
        Give up (stalled) after driving this far forward [m].
    """

    lookahead: float = 3.0
    speed: float = 1.0
    hitch_threshold: float = math.radians(1.0)
    distance_threshold: float = 8.0
    orientation_threshold: float = math.radians(1.0)
    max_distance: float = 40.0

    def __post_init__(self) -> None:
        for name in (
            "lookahead",
            "speed",
            "hitch_threshold",
            "distance_threshold",
            "orientation_threshold",
            "max_distance",
        ):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v) or v <= 0:
                raise ValueError(f"forward.{name} must be a finite number > 0, got {v!r}")


def pure_pursuit_steer(vehicle: VehicleTrailer, goal: Pose, settings: PurePursuitSettings, state: np.ndarray) -> float:
    """Front steer [rad] that pursues the goal line forward, clipped to the steer limit."""
    x_r, y_r, yaw_v = rear_axle_pose(vehicle, *state)
    _, gy, gyaw = to_goal_frame(goal, x_r, y_r, yaw_v)
    ld = settings.lookahead
    # Look-ahead point on the line y = 0, ld from the rear axle, ahead of it; the foot of the
    # perpendicular if the line is farther than ld.
    dx = math.sqrt(max(ld * ld - gy * gy, 0.0))
    alpha = math.atan2(-gy, dx) - float(gyaw)
    alpha = (alpha + math.pi) % (2 * math.pi) - math.pi
    steer = math.atan(2.0 * vehicle.wheelbase * math.sin(alpha) / ld)
    return float(np.clip(steer, -vehicle.max_steer, vehicle.max_steer))


def forward_done(goal: Pose, settings: PurePursuitSettings, state: np.ndarray) -> bool:
    """Section 5's two conditions (small hitch angle, far enough out of the space), plus alignment."""
    gx, _, gyaw = to_goal_frame(goal, state[0], state[1], state[2])
    return (
        abs(state[3]) < settings.hitch_threshold
        and float(gx) > settings.distance_threshold
        and abs(float(gyaw)) < settings.orientation_threshold
    )
