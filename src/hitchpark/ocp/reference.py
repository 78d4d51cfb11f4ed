"""A planned reverse path as the full NMPC's reference: where the car should be at each prediction step.

The last reverse segment of a plan ends at the goal, settled (the planner's refined end-game), or, where
that could not be had, within the planner's goal tolerance of it (or of the goal line, a straight
approach following); the NMPC tracks it to the goal itself. :class:`PathReference` keeps
the segment in the parking frame of the goal, as the NMPC's states are (trailer axle x, y, yaw, hitch,
front steer, rear speed), and ends it exactly at the goal: the gap between the planned end and the
straight approach (or the goal) is closed gradually over the last :data:`BLEND_M` of the plan, so the
reference has no step.

Each control step :meth:`PathReference.window` finds the closest point of the path (ahead of the last
one, never back) and moves along it in time: the rear-axle speed ``speed``, slowing to stop at the
goal braking at half ``max_accel``. Beyond the goal the reference is the goal at rest, the zero state,
where the tracking OCP is the parking OCP. The yaw is continuous along the path (a path that turns
further than half a turn stays continuous) and ends at 0; the NMPC puts the measured yaw on the same
branch (:meth:`PathReference.branch`).
"""

from __future__ import annotations

import math

import numpy as np

from ..model.state import Pose, to_goal_frame

__all__ = ["BLEND_M", "PathReference"]

#: The gap between the plan's end and the straight approach or goal is closed over this much path [m].
BLEND_M = 3.0

#: The closest point is searched for this far ahead of the last one, each step [m].
SEARCH_AHEAD_M = 3.0

#: Sample spacing of the reference path [m].
SPACING_M = 0.05


def _resample(points: np.ndarray, spacing: float) -> np.ndarray:
    """Rows of ``points`` (x, y, ...) interpolated at equal arc-length steps of at most ``spacing``."""
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(points[:, :2], axis=0).T))])
    if s[-1] <= 0.0:
        return points[-1:].copy()
    t = np.linspace(0.0, s[-1], max(2, math.ceil(s[-1] / spacing) + 1))
    keep = np.concatenate([[True], np.diff(s) > 1e-9])  # repeated samples would stall the interpolation
    return np.column_stack([np.interp(t, s[keep], points[keep, i]) for i in range(points.shape[1])])


class PathReference:
    """A reverse path to the goal, as reference states of the NMPC (see the module text).

    ``configs``: the segment's trailer configurations (x_t, y_t, yaw_t, hitch), world frame, in the order
    driven, ending within a small gap of the straight approach to ``goal`` (or of the goal); ``steer``:
    the front steer at each (optional); ``speed``: cruise speed of the rear axle [m/s]; ``max_accel``
    [m/s^2]; ``dt``: the prediction step [s]; ``horizon``: its steps.
    """

    def __init__(
        self,
        configs: np.ndarray,
        goal: Pose,
        speed: float,
        max_accel: float,
        dt: float,
        horizon: int,
        steer: np.ndarray | None = None,
    ):
        configs = np.asarray(configs, dtype=float)
        if configs.ndim != 2 or configs.shape[1] != 4 or len(configs) < 1:
            raise ValueError("configs must be rows (x, y, yaw, hitch), at least one")
        steers = np.zeros(len(configs)) if steer is None else np.asarray(steer, dtype=float)
        gx, gy, gyaw = to_goal_frame(goal, configs[:, 0], configs[:, 1], configs[:, 2])
        yaw = np.unwrap(np.asarray(gyaw, dtype=float))
        yaw -= 2.0 * math.pi * round(yaw[-1] / (2.0 * math.pi))  # the branch that ends near 0
        path = np.column_stack([gx, gy, yaw, configs[:, 3], steers])
        # The straight approach from abreast of the path's end to the goal, along the goal line.
        end_x = max(float(path[-1, 0]), 0.0)
        line_x = np.arange(end_x, -1e-9, -SPACING_M)
        line_x = np.append(line_x, 0.0) if len(line_x) == 0 or line_x[-1] > 1e-9 else line_x
        line = np.column_stack([line_x, np.zeros((len(line_x), 4))])
        # Close the gap between the path's end and the line's start over the path's last BLEND_M.
        path = _resample(path, SPACING_M)
        s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(path[:, :2], axis=0).T))])
        gap = line[0] - path[-1]
        gap[0] = 0.0 if len(line) > 1 else gap[0]  # along the line the x matches by construction
        weight = np.clip(1.0 - (s[-1] - s) / max(min(BLEND_M, s[-1]), 1e-9), 0.0, 1.0)
        path = path + (weight * weight * (3.0 - 2.0 * weight))[:, None] * gap  # smoothstep
        self.points = np.vstack([path, line[1:]])
        self.s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(self.points[:, :2], axis=0).T))])
        self._columns = [np.ascontiguousarray(self.points[:, i]) for i in range(5)]  # for np.interp each step
        self.length = float(self.s[-1])
        self.speed, self.brake, self.dt, self.horizon = float(speed), 0.5 * float(max_accel), float(dt), int(horizon)
        self.progress = 0.0  # arc length of the closest point so far
        self.deviation = 0.0  # distance of the trailer axle from it [m]

    def reset(self) -> None:
        self.progress, self.deviation = 0.0, 0.0

    def _speed(self, s: np.ndarray | float) -> np.ndarray:
        """Reference rear-axle speed magnitude at arc length ``s``: cruise, braking to stop at the goal."""
        left = np.maximum(self.length - np.asarray(s, dtype=float), 0.0)
        return np.minimum(self.speed, np.sqrt(2.0 * self.brake * left))

    def locate(self, x: float, y: float) -> float:
        """Move the closest point forward (never back) within :data:`SEARCH_AHEAD_M`; its arc length."""
        first = int(np.searchsorted(self.s, self.progress - 1e-9, side="left"))  # s never decreases
        last = int(np.searchsorted(self.s, self.progress + SEARCH_AHEAD_M, side="right"))
        d = np.hypot(self._columns[0][first:last] - x, self._columns[1][first:last] - y)
        best = int(np.argmin(d))
        self.progress, self.deviation = float(self.s[first + best]), float(d[best])
        return self.progress

    def branch(self, yaw: float) -> float:
        """``yaw`` moved by whole turns to the branch of the reference at the closest point."""
        here = float(np.interp(self.progress, self.s, self._columns[2]))
        return yaw + 2.0 * math.pi * round((here - yaw) / (2.0 * math.pi))

    def window(self, x0: np.ndarray, first: float | None = None) -> np.ndarray:
        """Reference states (N, 6) of prediction steps 1..N from the parking-frame state ``x0``.

        The closest point moves on first (:meth:`locate`); from it the reference advances at
        :meth:`_speed` per step (the first step ``first`` s long, default ``dt`` as the others); past the
        goal it is the goal at rest.
        """
        s = self.locate(float(x0[0]), float(x0[1]))
        ahead = np.empty(self.horizon)
        for k in range(self.horizon):
            dt = first if k == 0 and first is not None else self.dt
            s = min(s + min(self.speed, math.sqrt(2.0 * self.brake * max(self.length - s, 0.0))) * dt, self.length)
            ahead[k] = s
        out = np.empty((self.horizon, 6))
        for i, column in enumerate(self._columns):
            out[:, i] = np.interp(ahead, self.s, column)
        out[:, 5] = -self._speed(ahead)  # reverse
        return out

    @property
    def remaining(self) -> float:
        """Path left from the closest point to the goal [m]."""
        return self.length - self.progress
