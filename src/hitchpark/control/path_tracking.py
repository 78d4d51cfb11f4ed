"""Tracking a planned path segment: pure pursuit of the car forward, of the trailer (virtual steer) in reverse.

A planned path (:mod:`~hitchpark.planning`) splits into direction segments; each is driven at
standstill-to-standstill by a :class:`PathTracker`:

- **Forward**, the car's rear axle pursues the car's rear-axle path (the path's trailer configurations
  mapped by Eqs. 25-28): delta_f = atan(2 L sin(alpha) / l_d), within the forward steer cap that
  cannot jackknife (:func:`~.pure_pursuit.forward_steer_limit`, robust to the length tolerance).
- **In reverse**, the trailer axle pursues the trailer path, driven backwards: the virtual steer
  delta_T = atan(-2 L_T sin(alpha) / l_d) (alpha the bearing of the look-ahead point from the
  backward heading), within +-``virtual_limit``, becomes the front steer by Eq. (45) (Section 3's
  inverse kinematics), within ``max_steer``. The same law as the planner's end-game, so a segment the
  planner drove is one this tracker can follow.

The speed follows ``speed`` and slows to stop at the segment's end (braking at half the vehicle's
``max_accel``); the loop moves the commands within the steer-rate and acceleration limits. The
tracker gives up (``ok`` False) when the tracked point is farther than ``max_deviation_m`` from the
path, or the hitch comes within ``hitch_margin`` of the jackknife limit: the process then stops the car
and plans again from where it stands.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..checks import MAX_SPEED, Real, check_fields, checked
from ..model.inverse import front_steer_from_virtual
from ..model.kinematics import rear_axle_pose
from ..model.plant import Command, Measurement
from ..model.state import Pose, clamp, wrap_angle
from ..model.vehicle import VehicleTrailer
from .pure_pursuit import command_step, forward_steer_limit, pursuit_steer
from .step import ControlStep

__all__ = ["PathTracker", "TrackingSettings", "direction_segments"]

#: The segment is over once the tracked point is this close to its end along the path [m].
END_TOLERANCE_M = 0.03

#: How far ahead along the path the closest point is searched for, each step [m].
SEARCH_AHEAD_M = 3.0


@dataclass(frozen=True)
class TrackingSettings:
    """How a planned path is tracked (:class:`PathTracker`).

    Parameters
    ----------
    speed : float
        Cruise speed of the rear axle [m/s] (parking speeds are about 1 m/s).
    lookahead_forward_m : float
        Look-ahead of the car's pure pursuit, from the rear axle [m].
    lookahead_reverse_m : float
        Look-ahead of the trailer's pure pursuit in reverse, from the trailer axle [m].
    virtual_limit : float
        Largest virtual steer in reverse [rad] (the planner's reverse primitives use the same bound).
    max_deviation_m : float
        Past this distance of the tracked point from the path, the tracker stops and the path is planned
        again [m].
    hitch_margin : float
        The tracker stops when |hitch| comes within this of ``max_hitch`` [rad].
    length_tolerance : float
        Relative length error the forward steer cap survives (as :class:`~.pure_pursuit.PurePursuitSettings`).
    """

    speed: float = checked(0.6, Real(0.0, MAX_SPEED, low_open=True, unit="m/s"))
    lookahead_forward_m: float = checked(2.5, Real(0.1, 50.0, unit="m"))
    lookahead_reverse_m: float = checked(2.5, Real(0.1, 50.0, unit="m"))
    virtual_limit: float = checked(0.5, Real(0.0, math.pi / 2, low_open=True, high_open=True, unit="rad"))
    max_deviation_m: float = checked(0.35, Real(0.0, 10.0, low_open=True, unit="m"))
    hitch_margin: float = checked(math.radians(2.0), Real(0.0, math.pi / 2, high_open=True, unit="rad"))
    length_tolerance: float = checked(0.2, Real(0.0, 1.0, high_open=True))

    def __post_init__(self) -> None:
        check_fields(self, "tracking.")


def direction_segments(direction: np.ndarray) -> list[tuple[int, int]]:
    """Row ranges ``[first, last]`` (inclusive, sharing the row where direction changes) of each direction run.

    ``direction[i]`` is the direction of the motion into row i (+1 forward, -1 reverse); the rows of a run
    start at the row before its first motion.
    """
    d = np.asarray(direction)
    if len(d) < 2:
        return []
    changes = np.flatnonzero(d[2:] != d[1:-1]) + 1  # the row where the motion into the next row changes
    starts = [0, *changes.tolist()]
    ends = [*changes.tolist(), len(d) - 1]
    return list(zip(starts, ends, strict=True))


#: How far ahead of the nearest path point the plan's steer is taken forward [m]: the steer actuator's lag at
#: the tracking speed.
FEEDFORWARD_PREVIEW_M = 0.15


class PathTracker:
    """Drives one direction segment of a planned path (see the module text); a stage's controller.

    ``configs``: the segment's trailer configurations, rows (x_t, y_t, yaw_t, hitch), world frame, in
    the order driven; ``direction``: +1 forward, -1 reverse; ``until_m``: stop this far before the
    segment's end (the rest left to another controller).
    """

    rate_limited = True

    def __init__(
        self,
        vehicle: VehicleTrailer,
        settings: TrackingSettings,
        dt: float,
        configs: np.ndarray,
        direction: int,
        until_m: float = 0.0,
        steers: np.ndarray | None = None,
    ):
        self.vehicle, self.settings, self.dt, self.direction = vehicle, settings, dt, int(direction)
        configs = np.asarray(configs, dtype=float)
        self.configs = configs
        # Forward, the plan's own front steer at each row (None: pure pursuit alone).
        self.steers = None if steers is None or self.direction < 0 else np.asarray(steers, dtype=float)
        if self.direction > 0:
            xr, yr, _ = rear_axle_pose(vehicle, configs[:, 0], configs[:, 1], configs[:, 2], configs[:, 3])
            self.points = np.column_stack([xr, yr])
            self.lookahead = settings.lookahead_forward_m
        else:
            self.points = configs[:, :2].copy()
            self.lookahead = settings.lookahead_reverse_m
        steps = np.hypot(*np.diff(self.points, axis=0).T) if len(self.points) > 1 else np.zeros(0)
        self.s = np.concatenate([[0.0], np.cumsum(steps)])
        self.length = float(self.s[-1])
        self.stop_at = max(0.0, self.length - until_m)
        # Beyond its end the path goes on straight along its last heading (the look-ahead point needs a
        # place to be as the end nears).
        if len(configs) >= 2:
            heading = configs[-1, 2] + (configs[-1, 3] if self.direction > 0 else 0.0)
        else:
            heading = float(configs[0, 2]) if len(configs) else 0.0
        self.end_heading = float(heading) if self.direction > 0 else float(heading) + math.pi
        self.cap = forward_steer_limit(vehicle, length_tolerance=settings.length_tolerance)
        self.index = 0
        self.deviation = 0.0

    @property
    def max_steps(self) -> int:
        """Three times the segment at the cruise speed, and a minute more."""
        return math.ceil(3.0 * self.length / (self.settings.speed * self.dt) + 60.0 / self.dt)

    def reset(self, front_steer: float = 0.0) -> None:
        self.index = 0

    def remaining(self) -> float:
        """Path length left to the stopping point [m] from the last closest point."""
        return self.stop_at - float(self.s[self.index])

    def _tracked(self, state: np.ndarray) -> tuple[float, float, float]:
        """The tracked point and the heading of its motion: rear axle forward, trailer axle backwards."""
        if self.direction > 0:
            x, y, yaw = rear_axle_pose(self.vehicle, *state)
            return float(x), float(y), float(yaw)
        return float(state[0]), float(state[1]), float(state[2]) + math.pi

    def _progress(self, x: float, y: float) -> None:
        """Move the closest path point forward (never back) within :data:`SEARCH_AHEAD_M`."""
        window = np.flatnonzero((self.s >= self.s[self.index]) & (self.s <= self.s[self.index] + SEARCH_AHEAD_M))
        d = np.hypot(self.points[window, 0] - x, self.points[window, 1] - y)
        best = int(np.argmin(d))
        self.index = int(window[best])
        self.deviation = float(d[best])

    def _lookahead_point(self) -> tuple[float, float]:
        target = float(self.s[self.index]) + self.lookahead
        if target <= self.length:
            k = int(np.searchsorted(self.s, target))
            return float(self.points[k, 0]), float(self.points[k, 1])
        beyond = target - self.length
        end = self.points[-1]
        return float(end[0] + beyond * math.cos(self.end_heading)), float(end[1] + beyond * math.sin(self.end_heading))

    def steer(self, state: np.ndarray) -> float:
        """The front steer the pursuit asks at ``state`` (x_t, y_t, yaw_t, hitch) [rad]."""
        x, y, heading = self._tracked(state)
        px, py = self._lookahead_point()
        distance = max(math.hypot(px - x, py - y), 1e-6)
        alpha = float(wrap_angle(math.atan2(py - y, px - x) - heading))
        v = self.vehicle
        if self.direction > 0:
            pursued = pursuit_steer(v.wheelbase, alpha, distance, self.cap)
            if self.steers is None or len(self.steers) != len(self.points):
                return pursued
            # The plan's steer ahead (the actuator's lag) and pure pursuit's correction: what it asks here
            # less what it would ask on the path at the same place, zero when the car is on its path.
            k = self.index
            c = self.configs[k]
            on_x, on_y = self.points[k]
            on_heading = float(c[2] + c[3])
            on_alpha = float(wrap_angle(math.atan2(py - on_y, px - on_x) - on_heading))
            on_distance = max(math.hypot(px - on_x, py - on_y), 1e-6)
            ideal = pursuit_steer(v.wheelbase, on_alpha, on_distance, self.cap)
            ahead = int(np.searchsorted(self.s, self.s[k] + FEEDFORWARD_PREVIEW_M))
            planned = float(self.steers[min(ahead, len(self.steers) - 1)])
            return clamp(planned + (pursued - ideal), -self.cap, self.cap)
        # Driven backwards, a positive virtual steer turns the direction of travel the other way.
        virtual = -pursuit_steer(v.trailer_length, alpha, distance, self.settings.virtual_limit)
        front = float(front_steer_from_virtual(v, float(state[3]), virtual))  # Eq. (45)
        return clamp(front, -v.max_steer, v.max_steer)

    def initial_steer(self, measurement: Measurement, goal: Pose) -> float | None:
        state = measurement.state.as_array()
        self._progress(*self._tracked(state)[:2])
        return self.steer(state)

    def act(self, measurement: Measurement, goal: Pose, in_flight: Sequence[Command] = ()) -> ControlStep:
        """The command for the next sample (``goal`` is not used: the path leads there)."""
        state = measurement.state.as_array()
        v = self.vehicle
        x, y, _ = self._tracked(state)
        self._progress(x, y)
        left = self.remaining()
        if self.index == len(self.s) - 1 and self.stop_at >= self.length:
            # Past the last sample: what is left along the last heading (negative once past the end).
            ex, ey = self.points[-1]
            left = (ex - x) * math.cos(self.end_heading) + (ey - y) * math.sin(self.end_heading)
        steer = self.steer(state)
        hitch = float(state[3])
        if self.deviation > self.settings.max_deviation_m:
            return command_step(v, hitch, 0.0, steer, ok=False, stop=True,
                         status=f"deviated {self.deviation:.2f} m from the planned path")  # fmt: skip
        if abs(hitch) > v.max_hitch - self.settings.hitch_margin:
            return command_step(v, hitch, 0.0, steer, ok=False, stop=True,
                         status=f"hitch {math.degrees(hitch):.1f} deg near the jackknife limit")  # fmt: skip
        if left <= END_TOLERANCE_M:
            return command_step(v, hitch, 0.0, steer, ok=True, stop=True, status="end of segment")
        # Slow down to stop at the end, braking at half the acceleration limit (the rest for the delay).
        speed = min(self.settings.speed, math.sqrt(max(left - END_TOLERANCE_M, 0.0) * v.max_accel) + 0.05)
        return command_step(v, hitch, self.direction * speed, steer, ok=True, stop=False, status="")
