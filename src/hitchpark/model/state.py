"""States and poses: the configuration of the combination, a goal pose, the parking frame.

A :class:`State` is the trailer-axle pose and the hitch angle (the four numbers that fix
the whole configuration, Eqs. 25-28); a :class:`Pose` is a planar pose, such as the goal
trailer-axle pose. The parking frame (Fig. 5) has its origin at the goal and its x axis
along the goal heading.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..checks import MAX_COORDINATE, MAX_YAW, InputError, check_instance, check_keys, check_number, check_range
from .vehicle import VehicleTrailer

__all__ = [
    "Pose",
    "State",
    "check_goal",
    "check_pose",
    "check_state",
    "clamp",
    "from_goal_frame",
    "goal_frame_position",
    "goal_frame_yaw",
    "to_goal_frame",
    "wrap_angle",
]


def wrap_angle(a: Any) -> Any:
    """Angle(s) wrapped to [-pi, pi) (a float for a Python float: the control loop's scalars skip NumPy)."""
    if type(a) is float:
        w = (a + math.pi) % (2.0 * math.pi) - math.pi
        return w - 2.0 * math.pi if w >= math.pi else w
    r = (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi
    return np.where(r >= np.pi, r - 2 * np.pi, r)  # the modulo can round up to 2 pi


def clamp(value: float, low: float, high: float) -> float:
    """``value`` limited to [low, high], as a float (``np.clip`` for one number, without NumPy's cost)."""
    return float(min(max(value, low), high))


def check_pose(what: str, x: Any, y: Any, yaw: Any) -> None:
    """Raise ``InputError`` unless x, y are finite within +-MAX_COORDINATE m and yaw within +-MAX_YAW rad."""
    if type(x) is float and type(y) is float and type(yaw) is float:  # the loop's case: no messages built
        if abs(x) <= MAX_COORDINATE and abs(y) <= MAX_COORDINATE and abs(yaw) <= MAX_YAW:  # (False for NaN)
            return
    for name, value in (("x", x), ("y", y)):
        check_range(f"{what} {name}", value, -MAX_COORDINATE, MAX_COORDINATE, unit="m")
    check_range(f"{what} yaw", yaw, -MAX_YAW, MAX_YAW, unit=f"rad ({math.degrees(MAX_YAW):g} deg)")


@dataclass(frozen=True)
class Pose:
    """A planar pose in the world frame [m, m, rad]; the goal is the trailer-axle pose when parked."""

    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0

    def __post_init__(self) -> None:
        check_pose("goal", self.x, self.y, self.yaw)
        for name in ("x", "y", "yaw"):
            object.__setattr__(self, name, float(getattr(self, name)))

    def to_dict(self) -> dict[str, float]:
        return {"x": self.x, "y": self.y, "yaw_deg": math.degrees(self.yaw)}

    @classmethod
    def from_dict(cls, data: Any, what: str = "goal") -> Pose:
        """From ``{"x", "y", "yaw_deg"}`` (metres, degrees), as :meth:`to_dict` writes it."""
        x, y, yaw_deg = _numbers(what, data, ("x", "y", "yaw_deg"))
        return cls(x, y, math.radians(yaw_deg))


@dataclass(frozen=True)
class State:
    """Configuration of the system: trailer-axle pose [m, m, rad] and hitch angle [rad]."""

    x: float
    y: float
    yaw: float
    hitch: float

    def __post_init__(self) -> None:
        check_pose("state", self.x, self.y, self.yaw)
        object.__setattr__(self, "hitch", check_range("state hitch", self.hitch, -math.pi, math.pi, unit="rad"))
        for name in ("x", "y", "yaw"):
            object.__setattr__(self, name, float(getattr(self, name)))

    def as_array(self) -> np.ndarray:
        return np.array([self.x, self.y, self.yaw, self.hitch], dtype=float)

    @classmethod
    def from_array(cls, values: Iterable[float]) -> State:
        x, y, yaw, hitch = (float(v) for v in values)
        return cls(x, y, yaw, hitch)

    def to_dict(self) -> dict[str, float]:
        return {"x": self.x, "y": self.y, "yaw_deg": math.degrees(self.yaw), "hitch_deg": math.degrees(self.hitch)}

    @classmethod
    def from_dict(cls, data: Any, what: str = "start") -> State:
        """From ``{"x", "y", "yaw_deg", "hitch_deg"}`` (metres, degrees), as :meth:`to_dict` writes it."""
        x, y, yaw_deg, hitch_deg = _numbers(what, data, ("x", "y", "yaw_deg", "hitch_deg"))
        return cls(x, y, math.radians(yaw_deg), math.radians(hitch_deg))


def pose_table(what: str, data: Any, keys: tuple[str, ...], required: bool = True) -> dict[str, float]:
    """The numbers of a pose table ``[what]``: no key outside ``keys``, each a finite number, all present if
    ``required``."""
    table = check_keys(what, data, keys)
    missing = [k for k in keys if k not in table]
    if required and missing:
        raise InputError(f"{what}.{missing[0]} is missing; [{what}] needs {', '.join(keys)}")
    return {k: check_number(f"{what}.{k}", v) for k, v in table.items()}


def _numbers(what: str, data: Any, keys: tuple[str, ...]) -> list[float]:
    """The numbers of a complete pose table, in the order of ``keys``."""
    table = pose_table(what, data, keys)
    return [table[k] for k in keys]


def check_state(vehicle: VehicleTrailer, state: State, what: str = "start") -> None:
    """Raise ``InputError`` if ``state`` is not a finite pose in range or is beyond the jackknife limit."""
    check_instance(what, state, State, "hitchpark.State(x, y, yaw_rad, hitch_rad)")
    check_pose(what, state.x, state.y, state.yaw)
    check_number(f"{what} hitch", state.hitch)
    if abs(state.hitch) > vehicle.max_hitch:
        raise InputError(
            f"{what} hitch angle must be within the jackknife limit +-{math.degrees(vehicle.max_hitch):g} deg, "
            f"got {math.degrees(state.hitch):g} deg"
        )


def check_goal(goal: Any) -> Pose:
    """The goal pose: ``None`` is the origin heading +x; anything but a :class:`Pose` is refused."""
    if goal is None:
        return Pose()
    return check_instance("goal", goal, Pose, "hitchpark.Pose(x, y, yaw_rad)")


def to_goal_frame(goal: Pose, x: Any, y: Any, yaw: Any) -> tuple[Any, Any, Any]:
    """World pose(s) -> parking frame of ``goal`` (Fig. 5): origin at the goal, X along its heading."""
    if type(x) is float and type(y) is float and type(yaw) is float:  # one pose: floats, no NumPy
        c, s = math.cos(goal.yaw), math.sin(goal.yaw)
        ex, ey = x - goal.x, y - goal.y
        return c * ex + s * ey, -s * ex + c * ey, wrap_angle(yaw - goal.yaw)
    return (*goal_frame_position(goal, x, y), goal_frame_yaw(goal, yaw))


def goal_frame_position(goal: Pose, x: Any, y: Any) -> tuple[np.ndarray, np.ndarray]:
    """The position part of :func:`to_goal_frame` (arrays), for a caller that may not need the yaw."""
    c, s = math.cos(goal.yaw), math.sin(goal.yaw)
    dx, dy = np.asarray(x) - goal.x, np.asarray(y) - goal.y
    return c * dx + s * dy, -s * dx + c * dy


def goal_frame_yaw(goal: Pose, yaw: Any) -> np.ndarray:
    """The yaw part of :func:`to_goal_frame` (arrays): wrapped to [-pi, pi)."""
    return wrap_angle(np.asarray(yaw) - goal.yaw)


def from_goal_frame(goal: Pose, gx: Any, gy: Any, gyaw: Any) -> tuple[Any, Any, Any]:
    """Parking frame of ``goal`` -> world pose(s): the inverse of :func:`to_goal_frame` (yaw not wrapped)."""
    c, s = math.cos(goal.yaw), math.sin(goal.yaw)
    gx, gy = np.asarray(gx), np.asarray(gy)
    return goal.x + c * gx - s * gy, goal.y + s * gx + c * gy, np.asarray(gyaw) + goal.yaw
