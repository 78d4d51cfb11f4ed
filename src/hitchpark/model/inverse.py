"""Inverse kinematics (Section 3) and steering-feasible virtual-steer bounds (Section 4.2).

The trailer is treated as a vehicle of its own with a virtual steered axle at the
hitch; these maps carry its inputs (trailer speed V_T, virtual steer delta_T) to the
vehicle's (rear-axle speed V_R, front steer delta_f) and back. All angles in radians;
floats, NumPy arrays (broadcast) or CasADi symbols.
"""

from __future__ import annotations

import math
from typing import Any

import casadi as ca
import numpy as np

from ..checks import check_range, check_values
from .kinematics import full_rates, ops
from .vehicle import VehicleTrailer, check_vehicle

__all__ = [
    "actual_virtual_steer",
    "front_steer_from_virtual",
    "front_steer_from_virtual_tangent",
    "rear_speed_from_trailer_speed",
    "steady_hitch_from_virtual",
    "trailer_speed_from_virtual",
    "vehicle_yaw_rate_from_virtual",
    "virtual_steer_bounds",
    "virtual_steer_from_front",
]


def _inputs(vehicle: Any, **values: Any) -> list[Any]:
    """The inputs, checked: a vehicle, finite numbers or arrays (lists become arrays); CasADi symbols pass."""
    check_vehicle(vehicle)
    out: list[Any] = []
    for name, value in values.items():
        if type(value) is float and math.isfinite(value):  # the control loop's scalars, passed as they are
            out.append(value)
        elif isinstance(value, ca.SX | ca.MX | ca.DM):
            out.append(value)
        else:
            array = check_values(name, value)
            if isinstance(value, list | tuple):
                out.append(array)
            elif isinstance(value, int):  # Python's ints can outgrow NumPy's
                out.append(float(array))
            else:
                out.append(value)
    return out


def front_steer_from_virtual(vehicle: VehicleTrailer, hitch_angle: Any, virtual_steer: Any) -> Any:
    """Front steer delta_f that makes the trailer move as if steered by ``virtual_steer``, Eq. (45).

    Needs L_H > 0. Equivalent to tan(delta_f) = (L / L_H) tan(hitch - delta_T).
    """
    hitch_angle, virtual_steer = _inputs(vehicle, hitch_angle=hitch_angle, virtual_steer=virtual_steer)
    return _front_steer(vehicle, hitch_angle, ops(hitch_angle, virtual_steer).tan(virtual_steer))


def front_steer_from_virtual_tangent(vehicle: VehicleTrailer, hitch_angle: Any, tan_virtual: Any) -> Any:
    """Eq. (45) from tan(delta_T) rather than delta_T: for a caller that has the tangent (a pure pursuit's
    curvature times L_T, Eq. 42) and need not compute the angle to take its tangent again."""
    hitch_angle, tan_virtual = _inputs(vehicle, hitch_angle=hitch_angle, tan_virtual=tan_virtual)
    return _front_steer(vehicle, hitch_angle, tan_virtual)


def _front_steer(vehicle: VehicleTrailer, hitch_angle: Any, t: Any) -> Any:
    """Eq. (45): delta_f from the hitch angle and t = tan(delta_T)."""
    vehicle.require_hitch_offset()
    m = ops(hitch_angle, t)
    s, c = m.sin(hitch_angle), m.cos(hitch_angle)
    L, L_H = vehicle.wheelbase, vehicle.hitch_offset
    return m.atan(L / L_H * (s - c * t) / (c + s * t))  # Eq. (45)


def virtual_steer_from_front(vehicle: VehicleTrailer, hitch_angle: Any, front_steer: Any) -> Any:
    """Virtual steer delta_T that a front steer produces at the current hitch angle, Eq. (56).

    The exact inverse of Eq. (45): delta_T = hitch - atan((L_H / L) tan(delta_f)).
    Eq. (56)'s ratio is evaluated with a two-argument arctangent (its denominator is
    positive whenever ``|hitch - delta_T| < 90 deg``), so the answer stays on the right
    branch for large hitch angles too. Works for L_H = 0 (then delta_T = hitch).
    """
    hitch_angle, front_steer = _inputs(vehicle, hitch_angle=hitch_angle, front_steer=front_steer)
    m = ops(hitch_angle, front_steer)
    s, c, t = m.sin(hitch_angle), m.cos(hitch_angle), m.tan(front_steer)
    L, L_H = vehicle.wheelbase, vehicle.hitch_offset
    return m.atan2(L * s - L_H * c * t, L * c + L_H * s * t)  # Eq. (56)


def steady_hitch_from_virtual(vehicle: VehicleTrailer, virtual_steer: Any) -> Any:
    """Hitch angle at which a virtual steer held constant keeps the hitch still: Eq. (43) equal to Eq. (42).

    The vehicle then turns at the trailer's yaw rate, both about one centre, and the trailer axle runs on a
    circle of curvature tan(delta_T) / L_T. Setting (V_T / L_H)(sin h - cos h tan delta_T) = (V_T / L_T) tan delta_T
    and dividing by sqrt(1 + tan^2 delta_T) gives sin(h - delta_T) = (L_H / L_T) sin(delta_T), so
    ``h = delta_T + asin((L_H / L_T) sin delta_T)``, whatever the speed and its sign. With L_H > L_T the asin's
    argument is clipped to [-1, 1] (past it no steady turn exists; the hitch there is the nearest one).
    NumPy only (floats or arrays).
    """
    (virtual_steer,) = _inputs(vehicle, virtual_steer=virtual_steer)
    ratio = np.clip(vehicle.hitch_offset / vehicle.trailer_length * np.sin(virtual_steer), -1.0, 1.0)
    hitch = virtual_steer + np.arcsin(ratio)
    return float(hitch) if np.ndim(hitch) == 0 else hitch


def _eq44_ratio(hitch_angle: Any, virtual_steer: Any) -> Any:
    """V_R / V_T = cos(hitch) + sin(hitch) tan(delta_T): the denominator of Eq. (44)."""
    m = ops(hitch_angle, virtual_steer)
    return m.cos(hitch_angle) + m.sin(hitch_angle) * m.tan(virtual_steer)


def trailer_speed_from_virtual(vehicle: VehicleTrailer, hitch_angle: Any, virtual_steer: Any, rear_speed: Any) -> Any:
    """Trailer-axle speed V_T from the rear-axle speed V_R, Eq. (44)."""
    hitch_angle, virtual_steer, rear_speed = _inputs(
        vehicle, hitch_angle=hitch_angle, virtual_steer=virtual_steer, rear_speed=rear_speed
    )
    return rear_speed / _eq44_ratio(hitch_angle, virtual_steer)  # Eq. (44)


def rear_speed_from_trailer_speed(
    vehicle: VehicleTrailer, hitch_angle: Any, virtual_steer: Any, trailer_speed: Any
) -> Any:
    """Rear-axle speed V_R that gives the trailer axle the speed V_T: Eq. (44) solved for V_R."""
    hitch_angle, virtual_steer, trailer_speed = _inputs(
        vehicle, hitch_angle=hitch_angle, virtual_steer=virtual_steer, trailer_speed=trailer_speed
    )
    return trailer_speed * _eq44_ratio(hitch_angle, virtual_steer)  # Eq. (44)


def vehicle_yaw_rate_from_virtual(
    vehicle: VehicleTrailer, hitch_angle: Any, virtual_steer: Any, trailer_speed: Any
) -> Any:
    """Vehicle yaw rate that the virtual input asks for, Eq. (43). Needs L_H > 0."""
    hitch_angle, virtual_steer, trailer_speed = _inputs(
        vehicle, hitch_angle=hitch_angle, virtual_steer=virtual_steer, trailer_speed=trailer_speed
    )
    vehicle.require_hitch_offset()
    m = ops(hitch_angle, virtual_steer, trailer_speed)
    s, c = m.sin(hitch_angle), m.cos(hitch_angle)
    return trailer_speed / vehicle.hitch_offset * (s - c * m.tan(virtual_steer))  # Eq. (43)


def actual_virtual_steer(
    vehicle: VehicleTrailer, yaw_trailer: Any, hitch_angle: Any, rear_speed: Any, front_steer: Any
) -> Any:
    """Virtual steer the full model actually shows: direction of the hitch velocity minus the trailer yaw, Eq. (46).

    NumPy only. The hitch velocity's direction is taken modulo pi (its line, as
    Eq. (46)'s single-argument arctangent does), so reverse motion gives the same
    angle as forward motion; the result lies in [-pi/2, pi/2).
    """
    _, yaw_rate_t, v_t = full_rates(vehicle, hitch_angle, rear_speed, front_steer)
    L_T = vehicle.trailer_length
    x_dot_h = v_t * np.cos(yaw_trailer) - L_T * yaw_rate_t * np.sin(yaw_trailer)  # Eq. (32)
    y_dot_h = v_t * np.sin(yaw_trailer) + L_T * yaw_rate_t * np.cos(yaw_trailer)
    angle = np.arctan2(y_dot_h, x_dot_h) - yaw_trailer  # Eq. (46)
    return np.mod(angle + np.pi / 2, np.pi) - np.pi / 2


def virtual_steer_bounds(vehicle: VehicleTrailer, hitch_angle: Any, virtual_limit: float) -> tuple[Any, Any]:
    """Steering-feasible bounds on the virtual steer at the current hitch angle, Eqs. (56)-(57).

    Eq. (56) maps the front-steer range [-max_steer, max_steer] to
    [delta_T,lb1, delta_T,ub1] (it decreases with delta_f), which is intersected with
    [-virtual_limit, virtual_limit], Eq. (57). Any delta_T in the result maps back
    through Eq. (45) to a front steer within the vehicle's limit.

    If the two intervals do not meet (a hitch angle beyond about
    ``virtual_limit + atan(L_H / L * tan(max_steer))``), the vehicle's limit wins:
    both bounds collapse onto the end of [lb1, ub1] nearest the virtual range.
    Returns ``(low, high)``, floats or arrays like ``hitch_angle``.
    """
    (hitch_angle,) = _inputs(vehicle, hitch_angle=hitch_angle)
    virtual_limit = check_range("virtual_limit", virtual_limit, 0.0, np.pi / 2, low_open=True, high_open=True)
    vehicle.require_hitch_offset()  # at L_H = 0 the virtual steer is pinned to the hitch angle
    lb1 = virtual_steer_from_front(vehicle, hitch_angle, vehicle.max_steer)  # Eq. (56) at delta_f,max
    ub1 = virtual_steer_from_front(vehicle, hitch_angle, -vehicle.max_steer)  # Eq. (56) at delta_f,min
    low = np.clip(np.maximum(lb1, -virtual_limit), lb1, ub1)  # Eq. (57), clipped into [lb1, ub1]
    high = np.clip(np.minimum(ub1, virtual_limit), lb1, ub1)
    if np.ndim(low) == 0:
        return float(low), float(high)
    return low, high
