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
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..checks import MAX_SPEED, Real, check_fields, checked
from ..model.inverse import virtual_steer_from_front
from ..model.kinematics import rear_axle_pose, trailer_speed_from_rear_speed
from ..model.plant import Command, Measurement
from ..model.state import Pose, clamp, to_goal_frame, wrap_angle
from ..model.vehicle import VehicleTrailer
from .step import ControlStep

__all__ = [
    "ForwardPursuit",
    "PurePursuitSettings",
    "command_step",
    "forward_done",
    "forward_steer_limit",
    "pure_pursuit_steer",
    "pursuit_steer",
]


@dataclass(frozen=True)
class PurePursuitSettings:
    """Forward-stage settings (the paper gives none; docs/explanation/model.md justifies the defaults).

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
        in mid-turn, leaving the next reverse stage misaligned (docs/explanation/model.md).
    max_distance : float
        Give up (stalled) after driving this far forward [m].
    length_tolerance : float
        Relative error of L_H and L_T the forward steer cap must survive (0.2: the real lengths may be
        up to 20% longer than the model's), in [0, 1). Used with rate limits (the full process); the
        paper's process caps with the nominal lengths.
    """

    lookahead: float = checked(3.0, Real(0.0, 50.0, low_open=True, unit="m"))
    speed: float = checked(1.0, Real(0.0, MAX_SPEED, low_open=True, unit="m/s"))
    hitch_threshold: float = checked(math.radians(1.0), Real(0.0, math.pi / 2, low_open=True, unit="rad"))
    distance_threshold: float = checked(8.0, Real(0.0, 1000.0, low_open=True, unit="m"))
    orientation_threshold: float = checked(math.radians(1.0), Real(0.0, math.pi, low_open=True, unit="rad"))
    max_distance: float = checked(100.0, Real(0.0, 10_000.0, low_open=True, unit="m"))
    length_tolerance: float = checked(0.2, Real(0.0, 1.0, high_open=True))

    def __post_init__(self) -> None:
        check_fields(self, "forward.")


def forward_steer_limit(
    vehicle: VehicleTrailer, margin: float = math.radians(1.0), length_tolerance: float = 0.0
) -> float:
    """Largest forward steer [rad] whose steady hitch angle stays ``margin`` inside ``max_hitch``.

    Driving forward with a held steer delta, the hitch angle settles where the
    trailer turns as fast as the vehicle (Eq. 21 = Eq. 24):
    tan(delta) = sin(h) / (L_T / L + (L_H / L) cos(h)). At h = max_hitch - margin, with
    |delta| no larger than this, the hitch rate points back inwards, so a forward
    stage can never jackknife. Within ``max_steer``. Longer L_H and L_T than the model's give a
    larger steady hitch angle for the same steer, so the cap assumes both ``length_tolerance``
    (relative) longer: robust to a tape-measure error of that size.
    """
    h = max(vehicle.max_hitch - margin, 0.5 * vehicle.max_hitch)
    grow = 1.0 + length_tolerance
    L, L_H, L_T = vehicle.wheelbase, grow * vehicle.hitch_offset, grow * vehicle.trailer_length
    return min(vehicle.max_steer, math.atan(math.sin(h) / (L_T / L + L_H / L * math.cos(h))))


def pure_pursuit_steer(
    vehicle: VehicleTrailer, goal: Pose, settings: PurePursuitSettings, state: np.ndarray, limit: float | None = None
) -> float:
    """Front steer [rad] that pursues the goal line forward, within ``limit`` (default :func:`forward_steer_limit`)."""
    x_r, y_r, yaw_v = rear_axle_pose(vehicle, *state)
    _, gy, gyaw = to_goal_frame(goal, x_r, y_r, yaw_v)
    ld = settings.lookahead
    # Look-ahead point on the line y = 0, ld from the rear axle, ahead of it; the foot of the
    # perpendicular if the line is farther than ld.
    dx = math.sqrt(max(ld * ld - gy * gy, 0.0))
    distance = math.hypot(dx, float(gy))
    alpha = float(wrap_angle(math.atan2(-gy, dx) - float(gyaw)))
    limit = forward_steer_limit(vehicle) if limit is None else limit
    return pursuit_steer(vehicle.wheelbase, alpha, distance, limit)


def pursuit_steer(length: float, alpha: float, distance: float, limit: float) -> float:
    """The pure-pursuit law: atan(2 l sin(alpha) / l_d) within +-``limit`` [rad].

    ``length``: from the steered axle to the one that pursues (the wheelbase; for the trailer in
    reverse, L_T to its virtual axle at the hitch); ``alpha``: the bearing of the look-ahead point from
    the heading of travel; ``distance``: to that point. A point behind (``|alpha| > pi/2``) gets full lock
    towards it, where sin(alpha) would fade to zero and drive straight on.
    """
    if abs(alpha) > math.pi / 2:
        return math.copysign(limit, alpha)
    return clamp(math.atan(2.0 * length * math.sin(alpha) / distance), -limit, limit)


def forward_done(goal: Pose, settings: PurePursuitSettings, state: np.ndarray) -> bool:
    """Section 5's two conditions (small hitch angle, far enough out of the space), plus alignment."""
    gx, _, gyaw = to_goal_frame(goal, state[0], state[1], state[2])
    return (
        abs(state[3]) < settings.hitch_threshold
        and float(gx) > settings.distance_threshold
        and abs(float(gyaw)) < settings.orientation_threshold
    )


class ForwardPursuit:
    """The forward repositioning controller: pure pursuit of the goal line (Section 5).

    With ``rate_limited`` (the full process) the loop moves its commands within the vehicle's
    steer-rate and acceleration limits, its steer cap survives ``settings.length_tolerance`` of
    length error, and it asks to start with the pursuit's steer, set while standing still.
    Without (the paper's process) the pursuit steer and the speed act at once, capped with the
    nominal lengths.
    """

    def __init__(self, vehicle: VehicleTrailer, settings: PurePursuitSettings, dt: float, rate_limited: bool):
        self.vehicle, self.settings, self.dt, self.rate_limited = vehicle, settings, dt, rate_limited
        self.limit = forward_steer_limit(vehicle, length_tolerance=settings.length_tolerance if rate_limited else 0.0)

    @property
    def max_steps(self) -> int:
        """Steps of the forward distance budget at the pursuit speed."""
        return math.ceil(self.settings.max_distance / (self.settings.speed * self.dt) - 1e-9)

    def reset(self, front_steer: float = 0.0) -> None:
        """Nothing to forget: each command follows from the measurement alone."""

    def initial_steer(self, measurement: Measurement, goal: Pose) -> float | None:
        if not self.rate_limited:
            return None
        return pure_pursuit_steer(self.vehicle, goal, self.settings, measurement.state.as_array(), self.limit)

    def act(self, measurement: Measurement, goal: Pose, in_flight: Sequence[Command] = ()) -> ControlStep:
        state = measurement.state.as_array()
        v = self.vehicle
        done = forward_done(goal, self.settings, state)
        steer = pure_pursuit_steer(v, goal, self.settings, state, self.limit)
        speed = 0.0 if done else self.settings.speed
        return command_step(v, float(state[3]), speed, steer, ok=True, stop=done, status="repositioned" if done else "")


def command_step(
    vehicle: VehicleTrailer, hitch: float, speed: float, steer: float, ok: bool, stop: bool, status: str
) -> ControlStep:
    """A command of a controller that does not optimise, as a :class:`~.step.ControlStep` (no cost, no solve, no
    prediction), with the trailer's view of it: Eqs. (18) and (56)."""
    return ControlStep(
        trailer_speed=float(trailer_speed_from_rear_speed(vehicle, hitch, speed, steer)),  # Eq. (18)
        virtual_steer=float(virtual_steer_from_front(vehicle, hitch, steer)),  # Eq. (56)
        rear_speed=speed,
        front_steer=steer,
        ok=ok,
        stop=stop,
        status=status,
    )
