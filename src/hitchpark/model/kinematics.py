"""Kinematics of the vehicle-trailer system (Section 2) and of the trailer alone (Eq. 47).

Every equation is written once and evaluates on NumPy numbers (floats or arrays,
broadcast elementwise) and on CasADi symbols alike, so the NMPC and the simulator
share one source.

State of the full system, ``FULL_STATE``: trailer-axle pose and hitch angle,
``(x_trailer, y_trailer, yaw_trailer, hitch)``, with ``hitch = yaw_vehicle - yaw_trailer``.
These four numbers fix the whole configuration; the rear-axle pose follows from the
rigid links (Eqs. 25-28), so no constraint can drift while integrating.
Inputs, ``FULL_INPUT``: ``(rear_speed, front_steer)`` = (V_R, delta_f), V_R < 0 in reverse.

State of the trailer-only model, ``TRAILER_STATE``: ``(x_trailer, y_trailer, yaw_trailer)``;
inputs ``TRAILER_INPUT``: ``(trailer_speed, virtual_steer)`` = (V_T, delta_T).
"""

from __future__ import annotations

import math
from types import SimpleNamespace
from typing import Any

import casadi as ca
import numpy as np

from .vehicle import VehicleTrailer

__all__ = [
    "FULL_INPUT",
    "FULL_STATE",
    "TRAILER_INPUT",
    "TRAILER_STATE",
    "full_rates",
    "full_rhs",
    "hitch_point",
    "ops",
    "rear_axle_pose",
    "trailer_rates",
    "trailer_rhs",
    "trailer_speed_from_rear_speed",
]

FULL_STATE = ("x_trailer", "y_trailer", "yaw_trailer", "hitch")
FULL_INPUT = ("rear_speed", "front_steer")
TRAILER_STATE = ("x_trailer", "y_trailer", "yaw_trailer")
TRAILER_INPUT = ("trailer_speed", "virtual_steer")

_NUMPY = SimpleNamespace(sin=np.sin, cos=np.cos, tan=np.tan, atan=np.arctan, atan2=np.arctan2, stack=np.stack)
_MATH = SimpleNamespace(sin=math.sin, cos=math.cos, tan=math.tan, atan=math.atan, atan2=math.atan2, stack=None)
_CASADI = SimpleNamespace(
    sin=ca.sin, cos=ca.cos, tan=ca.tan, atan=ca.atan, atan2=ca.atan2, stack=lambda xs: ca.vertcat(*xs)
)


def ops(*values: Any) -> SimpleNamespace:
    """The math namespace for ``values``: CasADi's if any is symbolic, else NumPy's (Python's ``math`` for
    floats alone: the control loop's scalars)."""
    if all(type(v) is float and math.isfinite(v) for v in values):  # (math raises where NumPy gives NaN)
        return _MATH
    for v in values:
        if isinstance(v, ca.SX | ca.MX | ca.DM):
            return _CASADI
    return _NUMPY


def _stack(m: SimpleNamespace, parts: list[Any]) -> Any:
    if m is not _CASADI:
        return np.stack(np.broadcast_arrays(*parts))
    return m.stack(parts)


def trailer_speed_from_rear_speed(vehicle: VehicleTrailer, hitch: Any, rear_speed: Any, front_steer: Any) -> Any:
    """V_T from V_R and delta_f, Eq. (18)."""
    m = ops(hitch, rear_speed, front_steer)
    k = vehicle.hitch_offset / vehicle.wheelbase
    return rear_speed * (m.cos(hitch) + k * m.sin(hitch) * m.tan(front_steer))  # Eq. (18)


def full_rates(vehicle: VehicleTrailer, hitch: Any, rear_speed: Any, front_steer: Any) -> tuple[Any, Any, Any]:
    """Vehicle yaw rate, trailer yaw rate and trailer speed for the full model.

    Returns ``(yaw_rate_vehicle, yaw_rate_trailer, trailer_speed)``: Eqs. (21), (24), (18).
    """
    m = ops(hitch, rear_speed, front_steer)
    L, L_H, L_T = vehicle.wheelbase, vehicle.hitch_offset, vehicle.trailer_length
    tan_f = m.tan(front_steer)
    yaw_rate_vehicle = rear_speed / L * tan_f  # Eq. (21)
    yaw_rate_trailer = rear_speed / L_T * (m.sin(hitch) - L_H / L * m.cos(hitch) * tan_f)  # Eq. (24)
    trailer_speed = trailer_speed_from_rear_speed(vehicle, hitch, rear_speed, front_steer)  # Eq. (18)
    return yaw_rate_vehicle, yaw_rate_trailer, trailer_speed


def full_rhs(vehicle: VehicleTrailer, state: Any, inputs: Any) -> Any:
    """Time derivative of ``FULL_STATE`` under ``FULL_INPUT``, Eqs. (19)-(24).

    ``state`` has 4 rows and ``inputs`` 2 rows (extra trailing axes broadcast), or
    they are CasADi column vectors. Returns the same kind.
    """
    _, _, yaw_t, hitch = state[0], state[1], state[2], state[3]
    rear_speed, front_steer = inputs[0], inputs[1]
    m = ops(state, inputs)
    yaw_rate_v, yaw_rate_t, v_t = full_rates(vehicle, hitch, rear_speed, front_steer)
    return _stack(
        m,
        [
            v_t * m.cos(yaw_t),  # Eq. (22)
            v_t * m.sin(yaw_t),  # Eq. (23)
            yaw_rate_t,  # Eq. (24)
            yaw_rate_v - yaw_rate_t,  # hitch = psi_1 - psi_2: Eq. (21) minus Eq. (24)
        ],
    )


def trailer_rates(
    vehicle: VehicleTrailer, yaw_trailer: Any, trailer_speed: Any, virtual_steer: Any
) -> tuple[Any, Any, Any]:
    """(x_dot, y_dot, yaw_dot) of the trailer seen as a vehicle steered at its hitch, Eq. (47)."""
    m = ops(yaw_trailer, trailer_speed, virtual_steer)
    return (
        trailer_speed * m.cos(yaw_trailer),
        trailer_speed * m.sin(yaw_trailer),
        trailer_speed / vehicle.trailer_length * m.tan(virtual_steer),  # Eq. (42)
    )


def trailer_rhs(vehicle: VehicleTrailer, state: Any, inputs: Any) -> Any:
    """Time derivative of ``TRAILER_STATE`` under ``TRAILER_INPUT``: f(X, U) of Eq. (47)."""
    m = ops(state, inputs)
    return _stack(m, list(trailer_rates(vehicle, state[2], inputs[0], inputs[1])))


def hitch_point(vehicle: VehicleTrailer, x_trailer: Any, y_trailer: Any, yaw_trailer: Any) -> tuple[Any, Any]:
    """Hitch joint position from the trailer-axle pose, Eqs. (25)-(26)."""
    m = ops(x_trailer, y_trailer, yaw_trailer)
    L_T = vehicle.trailer_length
    return x_trailer + L_T * m.cos(yaw_trailer), y_trailer + L_T * m.sin(yaw_trailer)


def rear_axle_pose(
    vehicle: VehicleTrailer, x_trailer: Any, y_trailer: Any, yaw_trailer: Any, hitch: Any
) -> tuple[Any, Any, Any]:
    """Vehicle rear-axle position and vehicle yaw from the trailer pose and hitch angle, Eqs. (25)-(28)."""
    m = ops(x_trailer, y_trailer, yaw_trailer, hitch)
    yaw_v = yaw_trailer + hitch
    x_h, y_h = hitch_point(vehicle, x_trailer, y_trailer, yaw_trailer)
    L_H = vehicle.hitch_offset
    return x_h + L_H * m.cos(yaw_v), y_h + L_H * m.sin(yaw_v), yaw_v
