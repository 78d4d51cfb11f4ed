"""The inverse-kinematics validation study of Section 3.2 (Figs. 3-4, Table 2)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..checks import InputError
from ..model.integrate import rk4
from ..model.inverse import actual_virtual_steer, front_steer_from_virtual, trailer_speed_from_virtual
from ..model.kinematics import full_rhs, trailer_rhs
from ..model.simulate import MAX_SPEED, Trajectory
from ..model.vehicle import VehicleTrailer

__all__ = ["TABLE2_VEHICLE", "IKStudyResult", "default_virtual_profile", "inverse_kinematics_study"]

#: Table 2: L = 3 m, L_H = 1 m, L_T = 2.5 m (body dimensions are the package defaults).
TABLE2_VEHICLE = VehicleTrailer(wheelbase=3.0, hitch_offset=1.0, trailer_length=2.5)


def default_virtual_profile(t: np.ndarray | float) -> np.ndarray | float:
    """A desired virtual steer [rad]: hold, ramp, sinusoid, step back to zero (the paper gives no profile)."""
    t = np.asarray(t, dtype=float)
    ramp = np.clip((t - 2.0) / 3.0, 0.0, 1.0) * 0.2
    wave = np.where((t >= 5.0) & (t < 17.0), 0.15 * np.sin(2 * np.pi * (t - 5.0) / 6.0), 0.0)
    out = np.where(t < 17.0, ramp + wave, -0.1)
    return out if out.ndim else float(out)


@dataclass(frozen=True)
class IKStudyResult:
    """Study record. Columns: ``t``, ``desired_virtual_steer``, ``actual_virtual_steer`` (Eq. 46),
    ``front_steer`` (Eq. 45), ``hitch``, the trailer pose from the full model (``x_trailer``,
    ``y_trailer``, ``yaw_trailer``) and from the trailer-only model (``x_trailer_only``, ...)."""

    vehicle: VehicleTrailer
    rear_speed: float
    trajectory: Trajectory

    @property
    def max_steer_error(self) -> float:
        """max |actual - desired virtual steer| [rad]."""
        return float(np.max(np.abs(self.trajectory["actual_virtual_steer"] - self.trajectory["desired_virtual_steer"])))

    @property
    def max_pose_error(self) -> float:
        """max distance between the trailer axle of the full model and of the trailer-only model [m]."""
        tr = self.trajectory
        return float(np.max(np.hypot(tr["x_trailer"] - tr["x_trailer_only"], tr["y_trailer"] - tr["y_trailer_only"])))

    def to_dict(self) -> dict:
        return {
            "vehicle": self.vehicle.to_dict(),
            "rear_speed": self.rear_speed,
            "max_virtual_steer_error_rad": self.max_steer_error,
            "max_trailer_position_error_m": self.max_pose_error,
            "trajectory": self.trajectory.to_dict(),
        }


def inverse_kinematics_study(
    vehicle: VehicleTrailer = TABLE2_VEHICLE,
    rear_speed: float = -1.0,
    duration: float = 20.0,
    dt: float = 0.05,
    profile: Callable[[Any], Any] = default_virtual_profile,
    start_hitch: float = 0.0,
) -> IKStudyResult:
    """Fig. 3: a desired virtual steer goes through Eq. (45) into the full model; Eq. (46) reads it back.

    The front steer is recomputed from the current hitch angle at every evaluation
    of the model (continuous inverse kinematics). Alongside, the trailer-only model
    (Eq. 47) is driven by the same virtual steer and the trailer speed of Eq. (44):
    both must move the trailer identically. The record has ``round(duration / dt)`` steps of ``dt``.
    """
    vehicle.require_hitch_offset()
    if rear_speed == 0 or not abs(rear_speed) <= MAX_SPEED:
        raise InputError(f"rear speed must be non-zero and within +-{MAX_SPEED:g} m/s, got {rear_speed:g}")

    def rhs(z: np.ndarray) -> np.ndarray:
        t, full, trailer = z[0], z[1:5], z[5:8]
        d_t = profile(t)
        d_f = front_steer_from_virtual(vehicle, full[3], d_t)  # Eq. (45)
        v_t = trailer_speed_from_virtual(vehicle, full[3], d_t, rear_speed)  # Eq. (44)
        return np.concatenate(
            ([1.0], full_rhs(vehicle, full, [rear_speed, d_f]), trailer_rhs(vehicle, trailer, [v_t, d_t]))
        )

    n = round(duration / dt)
    z = np.array([0.0, 0.0, 0.0, 0.0, start_hitch, 0.0, 0.0, 0.0])
    rows = [z]
    for _ in range(n):
        z = rk4(rhs, z, dt, substeps=5)
        rows.append(z)
    z_all = np.array(rows)
    t = np.arange(n + 1) * dt  # the integrated clock z[0] equals this up to rounding
    hitch, yaw_t = z_all[:, 4], z_all[:, 3]
    desired = np.asarray(profile(t), dtype=float) * np.ones_like(t)
    front = front_steer_from_virtual(vehicle, hitch, desired)
    actual = actual_virtual_steer(vehicle, yaw_t, hitch, rear_speed, front)  # Eq. (46)
    traj = Trajectory(
        {
            "t": t,
            "desired_virtual_steer": desired,
            "actual_virtual_steer": actual,
            "front_steer": front,
            "hitch": hitch,
            "x_trailer": z_all[:, 1],
            "y_trailer": z_all[:, 2],
            "yaw_trailer": yaw_t,
            "x_trailer_only": z_all[:, 5],
            "y_trailer_only": z_all[:, 6],
            "yaw_trailer_only": z_all[:, 7],
        }
    )
    return IKStudyResult(vehicle, rear_speed, traj)
