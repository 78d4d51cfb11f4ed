"""Forward repositioning (Section 5): pure pursuit of the vehicle along the line out of the space.

The path is the straight line through the goal along the goal heading (Fig. 6),
driven forward (out of the space). Pure pursuit steers the vehicle's rear axle
towards the point of the line one look-ahead distance away:
delta_f = atan(2 L sin(alpha) / l_d), alpha the bearing of that point seen from the
vehicle heading. The trailer is ignored by the controller (it follows, stably,
in forward motion); its steer is capped so that the hitch angle cannot reach the
jackknife limit going forward (:func:`forward_steer_limit`). The stage ends when
the hitch angle is under a threshold and the trailer axle is farther than a
threshold from the goal along the line.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..checks import check_range
from ..model.geometry import Pose, to_goal_frame, wrap_angle
from ..model.kinematics import rear_axle_pose
from ..model.vehicle import VehicleTrailer

__all__ = ["PurePursuitSettings", "forward_done", "forward_steer_limit", "pure_pursuit_steer"]


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
    max_distance: float = 100.0

    def __post_init__(self) -> None:
        for name in (
            "lookahead",
            "speed",
            "hitch_threshold",
            "distance_threshold",
            "orientation_threshold",
            "max_distance",
        ):
            object.__setattr__(self, name, check_range(f"forward.{name}", getattr(self, name), 0.0, low_open=True))


def forward_steer_limit(vehicle: VehicleTrailer, margin: float = math.radians(1.0)) -> float:
    """Largest forward steer [rad] whose steady hitch angle stays ``margin`` inside ``max_hitch``.

    Driving forward with a held steer delta, the hitch angle settles where the
    trailer turns as fast as the vehicle (Eq. 21 = Eq. 24):
    tan(delta) = sin(h) / (L_T / L + (L_H / L) cos(h)). At h = max_hitch - margin, with
    |delta| no larger than this, the hitch rate points back inwards, so a forward
    stage can never jackknife. Within ``max_steer``.
    """
    h = max(vehicle.max_hitch - margin, 0.5 * vehicle.max_hitch)
    L, L_H, L_T = vehicle.wheelbase, vehicle.hitch_offset, vehicle.trailer_length
    return min(vehicle.max_steer, math.atan(math.sin(h) / (L_T / L + L_H / L * math.cos(h))))


def pure_pursuit_steer(vehicle: VehicleTrailer, goal: Pose, settings: PurePursuitSettings, state: np.ndarray) -> float:
    """Front steer [rad] that pursues the goal line forward, within :func:`forward_steer_limit`."""
    x_r, y_r, yaw_v = rear_axle_pose(vehicle, *state)
    _, gy, gyaw = to_goal_frame(goal, x_r, y_r, yaw_v)
    ld = settings.lookahead
    # Look-ahead point on the line y = 0, ld from the rear axle, ahead of it; the foot of the
    # perpendicular if the line is farther than ld.
    dx = math.sqrt(max(ld * ld - gy * gy, 0.0))
    distance = math.hypot(dx, float(gy))
    alpha = float(wrap_angle(math.atan2(-gy, dx) - float(gyaw)))
    limit = forward_steer_limit(vehicle)
    if abs(alpha) > math.pi / 2:
        # The point is behind the vehicle (it faces away from the line's direction): full lock towards it,
        # where sin(alpha) would fade to zero and drive straight on.
        return math.copysign(limit, alpha)
    steer = math.atan(2.0 * vehicle.wheelbase * math.sin(alpha) / distance)
    return float(np.clip(steer, -limit, limit))


def forward_done(goal: Pose, settings: PurePursuitSettings, state: np.ndarray) -> bool:
    """Section 5's two conditions (small hitch angle, far enough out of the space), plus alignment."""
    gx, _, gyaw = to_goal_frame(goal, state[0], state[1], state[2])
    return (
        abs(state[3]) < settings.hitch_threshold
        and float(gx) > settings.distance_threshold
        and abs(float(gyaw)) < settings.orientation_threshold
    )
