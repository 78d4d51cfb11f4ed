"""Planar geometry: the outlines of the bodies and of the parking space, in the world frame.

NumPy, but for :func:`body_corners`, which evaluates on NumPy arrays and on CasADi symbols alike (the
collision checks and the NMPC's obstacle constraints share it). Poses and the parking frame live in
:mod:`.state` (re-exported here).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .kinematics import hitch_point, ops, rear_axle_pose
from .state import Pose, check_pose, to_goal_frame, wrap_angle
from .vehicle import VehicleTrailer

__all__ = [
    "Pose",
    "along",
    "body_corners",
    "body_outlines",
    "body_reaches",
    "check_pose",
    "has_tow_bar",
    "parking_space",
    "rectangle",
    "to_goal_frame",
    "tolerant_corners",
    "wheel_outlines",
    "wrap_angle",
]


#: Wheel footprint used for drawing [m]: length (tyre diameter) and width.
_WHEEL_LENGTH, _WHEEL_WIDTH = 0.68, 0.24


def rectangle(x: float, y: float, yaw: float, back: float, front: float, half_width: float) -> np.ndarray:
    """Closed 5x2 polygon of a rectangle in a frame at (x, y, yaw): from ``-back`` to ``front`` along it."""
    local = np.array(
        [
            [-back, -half_width],
            [front, -half_width],
            [front, half_width],
            [-back, half_width],
            [-back, -half_width],
        ]
    )
    c, s = math.cos(yaw), math.sin(yaw)
    rot = np.array([[c, -s], [s, c]])
    return local @ rot.T + np.array([x, y])


def along(x: float, y: float, yaw: float, distance: float, lateral: float = 0.0) -> np.ndarray:
    """The point ``distance`` ahead of and ``lateral`` left of (x, y) in a frame with heading ``yaw``."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([x + distance * c - lateral * s, y + distance * s + lateral * c])


def has_tow_bar(vehicle: VehicleTrailer) -> bool:
    """Whether the tow bar sticks out behind the vehicle body (the hitch lies behind its rear)."""
    return vehicle.hitch_offset > vehicle.rear_overhang


def body_corners(
    vehicle: VehicleTrailer, x_trailer: Any, y_trailer: Any, yaw_trailer: Any, hitch: Any
) -> dict[str, Any]:
    """The corners of the convex bodies: ``{name: [(x, y), ...]}``, NumPy (arrays broadcast) or CasADi alike.

    ``"vehicle"`` and ``"trailer"``: the body rectangles (as :func:`body_outlines` draws them), counter-
    clockwise from the rear right; ``"drawbar"``: the trailer body front's centre and the hitch;
    ``"tow_bar"`` (only when :func:`has_tow_bar`): the vehicle body rear's centre and the hitch. Every
    body is the convex hull of its corners.
    """
    v = vehicle
    m = ops(x_trailer, y_trailer, yaw_trailer, hitch)
    x_h, y_h = hitch_point(v, x_trailer, y_trailer, yaw_trailer)  # Eqs. (25)-(26)
    x_r, y_r, yaw_v = rear_axle_pose(v, x_trailer, y_trailer, yaw_trailer, hitch)  # Eqs. (27)-(28)

    def box(x: Any, y: Any, yaw: Any, back: float, front: float, half: float) -> list[tuple[Any, Any]]:
        c, s = m.cos(yaw), m.sin(yaw)
        local = ((-back, -half), (front, -half), (front, half), (-back, half))
        return [(x + a * c - b * s, y + a * s + b * c) for a, b in local]

    c_t, s_t = m.cos(yaw_trailer), m.sin(yaw_trailer)
    bodies = {
        "vehicle": box(x_r, y_r, yaw_v, v.rear_overhang, v.wheelbase + v.front_overhang, v.vehicle_width / 2),
        "trailer": box(x_trailer, y_trailer, yaw_trailer, v.trailer_rear, v.trailer_front, v.trailer_width / 2),
        "drawbar": [(x_trailer + v.trailer_front * c_t, y_trailer + v.trailer_front * s_t), (x_h, y_h)],
    }
    if has_tow_bar(v):
        back = v.rear_overhang
        bodies["tow_bar"] = [(x_r - back * m.cos(yaw_v), y_r - back * m.sin(yaw_v)), (x_h, y_h)]
    return bodies


def tolerant_corners(vehicle: VehicleTrailer, configs: np.ndarray) -> dict[str, np.ndarray]:
    """Each body's points (m, k, 2) at configurations ``configs`` (m, 4), over the range of its lengths.

    With ``vehicle.length_tolerance`` f > 0, L_H and L_T scaled by one factor in [1 - f, 1 + f]: at a configuration
    the lengths only translate the vehicle body along ``dL_T e_t + dL_H e_v`` (``e_t``, ``e_v`` the trailer's and
    the vehicle's heading, Eqs. (25)-(28)) and the hitch along ``dL_T e_t``. A convex body translated along a
    segment covers the convex hull of its two ends, exactly: the vehicle's points are its corners at both ends,
    the tow bar's its two ends at both ends of the range where it sticks out behind the body (shorter, it lies
    within it), the drawbar's its front and the farthest hitch (a segment); the trailer's do not move. With no
    tolerance, the corners of :func:`body_corners`.
    """
    configs = np.asarray(configs, dtype=float).reshape(-1, 4)
    points = {
        name: np.stack([np.stack(p, -1) for p in corners], 1)
        for name, corners in body_corners(vehicle, *configs.T).items()
    }
    f = vehicle.length_tolerance
    if f <= 0.0:
        return points
    yaw_t, yaw_v = configs[:, 2], configs[:, 2] + configs[:, 3]
    hitch = f * vehicle.trailer_length * np.column_stack([np.cos(yaw_t), np.sin(yaw_t)])  # (m, 2) at 1 + f
    body = hitch + f * vehicle.hitch_offset * np.column_stack([np.cos(yaw_v), np.sin(yaw_v)])
    out = dict(points)
    out["vehicle"] = np.concatenate([points["vehicle"] - body[:, None], points["vehicle"] + body[:, None]], 1)
    out["drawbar"] = np.stack([points["drawbar"][:, 0], points["drawbar"][:, 1] + hitch], 1)
    if "tow_bar" in points:
        low = max(-1.0, (vehicle.rear_overhang / vehicle.hitch_offset - 1.0) / f)  # the shortest that sticks out
        rear, at = points["tow_bar"][:, 0], points["tow_bar"][:, 1]
        out["tow_bar"] = np.stack([rear + low * body, rear + body, at + low * hitch, at + hitch], 1)
    return out


def body_reaches(vehicle: VehicleTrailer) -> tuple[float, float, float]:
    """How far [m] a trailer point lies from the trailer axle at most, the hitch from it, and a vehicle point from the
    hitch, with the lengths at the top of their tolerance: the bounds on a body point's movement between samples."""
    v, grow = vehicle, 1.0 + vehicle.length_tolerance
    hitch = grow * v.trailer_length
    trailer = max(math.hypot(max(v.trailer_rear, v.trailer_front), v.trailer_width / 2), hitch)
    car = math.hypot(grow * v.hitch_offset + v.wheelbase + v.front_overhang, v.vehicle_width / 2)
    return trailer, hitch, car


def body_outlines(
    vehicle: VehicleTrailer, x_trailer: float, y_trailer: float, yaw_trailer: float, hitch: float
) -> dict[str, np.ndarray]:
    """Outlines of the vehicle and trailer bodies for one configuration, in the world frame.

    Parameters
    ----------
    vehicle : VehicleTrailer
        Kinematic lengths and body dimensions.
    x_trailer, y_trailer : float
        Trailer-axle centre [m].
    yaw_trailer : float
        Trailer heading [rad].
    hitch : float
        Hitch angle, vehicle yaw minus trailer yaw [rad].

    Returns
    -------
    dict of str to numpy.ndarray
        ``"vehicle"``, ``"trailer"``: closed polygons, 5x2 arrays (first row repeated
        last), counter-clockwise. The vehicle body spans ``rear_overhang`` behind the
        rear axle to ``wheelbase + front_overhang`` ahead of it, ``vehicle_width`` wide;
        the trailer body spans ``trailer_rear`` behind the trailer axle to
        ``trailer_front`` ahead of it, ``trailer_width`` wide.
        ``"drawbar"``: 2x2 segment from the centre of the trailer body front to the hitch.
        ``"tow_bar"``: 2x2 segment from the centre of the vehicle body rear to the hitch
        (zero length when the hitch lies under the vehicle body).
        ``"hitch"``: the hitch point, shape (2,).
        ``"rear_axle"``, ``"trailer_axle"``: the axle centres, shape (2,).
    """
    x_t, y_t, yaw_t, d_psi = float(x_trailer), float(y_trailer), float(yaw_trailer), float(hitch)
    corners = body_corners(vehicle, x_t, y_t, yaw_t, d_psi)
    x_r, y_r, yaw_v = (float(c) for c in rear_axle_pose(vehicle, x_t, y_t, yaw_t, d_psi))  # Eqs. (27)-(28)
    hitch_xy = np.array(corners["drawbar"][1], dtype=float)
    bumper = along(x_r, y_r, yaw_v, -min(vehicle.rear_overhang, vehicle.hitch_offset))

    def closed(points: list[tuple[float, float]]) -> np.ndarray:
        return np.array([*points, points[0]], dtype=float)

    return {
        "vehicle": closed(corners["vehicle"]),
        "trailer": closed(corners["trailer"]),
        "drawbar": np.array(corners["drawbar"], dtype=float),
        "tow_bar": np.vstack([bumper, hitch_xy]),
        "hitch": hitch_xy,
        "rear_axle": np.array([x_r, y_r]),
        "trailer_axle": np.array([x_t, y_t]),
    }


def wheel_outlines(
    vehicle: VehicleTrailer,
    x_trailer: float,
    y_trailer: float,
    yaw_trailer: float,
    hitch: float,
    front_steer: float = 0.0,
) -> np.ndarray:
    """Tyre footprints for drawing: an array (6, 5, 2) of closed polygons, world frame.

    Rows: rear-right, rear-left, front-right, front-left (turned by ``front_steer``
    [rad]), trailer-right, trailer-left. The tracks are the body widths less a tyre
    width; the tyre size is a fixed 0.68 m x 0.24 m, shrunk for very small vehicles.
    """
    x_t, y_t, yaw_t = float(x_trailer), float(y_trailer), float(yaw_trailer)
    x_r, y_r, yaw_v = (float(v) for v in rear_axle_pose(vehicle, x_t, y_t, yaw_t, float(hitch)))
    length = min(_WHEEL_LENGTH, 0.3 * vehicle.wheelbase, 0.3 * vehicle.trailer_length)
    width = min(_WHEEL_WIDTH, 0.2 * vehicle.vehicle_width, 0.2 * vehicle.trailer_width)
    half_v = (vehicle.vehicle_width - width) / 2
    half_t = (vehicle.trailer_width - width) / 2
    centres = [
        (along(x_r, y_r, yaw_v, 0.0, -half_v), yaw_v),
        (along(x_r, y_r, yaw_v, 0.0, half_v), yaw_v),
        (along(x_r, y_r, yaw_v, vehicle.wheelbase, -half_v), yaw_v + front_steer),
        (along(x_r, y_r, yaw_v, vehicle.wheelbase, half_v), yaw_v + front_steer),
        (along(x_t, y_t, yaw_t, 0.0, -half_t), yaw_t),
        (along(x_t, y_t, yaw_t, 0.0, half_t), yaw_t),
    ]
    return np.stack([rectangle(c[0], c[1], yaw, length / 2, length / 2, width / 2) for c, yaw in centres])


def parking_space(vehicle: VehicleTrailer, goal: Pose, margin: float = 0.35) -> np.ndarray:
    """The parking space: the trailer footprint at ``goal`` grown by ``margin`` [m]; closed 5x2 polygon."""
    return rectangle(
        goal.x,
        goal.y,
        goal.yaw,
        vehicle.trailer_rear + margin,
        vehicle.trailer_front + margin,
        vehicle.trailer_width / 2 + margin,
    )
