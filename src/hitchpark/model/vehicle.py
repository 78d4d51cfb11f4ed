"""Vehicle-trailer parameters (Table 1 of the paper; defaults from Table 4)."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields, replace
from pathlib import Path
from typing import Any

from ..checks import InputError, Real, check_fields, check_instance, check_keys, checked
from ..io import read_toml

__all__ = ["VehicleTrailer", "check_vehicle", "load_vehicle", "vehicle_from_dict"]


#: Upper bounds of the lengths [m]: past a truck tractor's wheelbase and a semi-trailer's kingpin-to-axle
#: length; a number beyond them is a typo (or a unit mistake), not a vehicle.
MAX_WHEELBASE = 10.0
MAX_HITCH_OFFSET = 5.0
MAX_TRAILER_LENGTH = 20.0
MAX_OVERHANG = 5.0
#: Widest body [m]: road-legal vehicles and trailers are at most 2.55 m (EU) / 2.6 m (US) wide.
MAX_WIDTH = 3.5

_ANGLE_LIMIT = Real(0.0, math.pi / 2, low_open=True, high_open=True, unit="rad (0 to 90 deg)")
_OVERHANG = Real(0.0, MAX_OVERHANG, low_open=True, unit="m")
_WIDTH = Real(0.0, MAX_WIDTH, low_open=True, unit="m")


@dataclass(frozen=True)
class VehicleTrailer:
    """A car-like tractor with one on-axle trailer hitched behind its rear axle.

    Lengths in metres, angles in radians. The defaults are the paper's Table 4
    vehicle (kinematic lengths and steer limit); the body dimensions, which the
    paper does not give, are those of a mid-size SUV towing a small box trailer.

    Parameters
    ----------
    wheelbase : float
        L, rear axle to front axle [m], > 0.
    hitch_offset : float
        L_H, rear axle to hitch joint, measured backwards [m], >= 0. The inverse
        kinematics (Eqs. 43-45) divide by it and need L_H > 0.
    trailer_length : float
        L_T, hitch joint to trailer axle [m], > 0.
    max_steer : float
        Front-wheel steer limit ``|delta_f| <= max_steer`` [rad], in (0, pi/2).
    max_hitch : float
        Jackknife limit ``|hitch angle| <= max_hitch`` [rad], in (0, pi/2). Default 70 deg.
    front_overhang, rear_overhang : float
        Vehicle body ahead of the front axle / behind the rear axle [m], > 0.
    vehicle_width : float
        Vehicle body width [m], > 0.
    trailer_front, trailer_rear : float
        Trailer body ahead of / behind the trailer axle [m], > 0; the body front
        must lie behind the hitch (trailer_front < trailer_length).
    trailer_width : float
        Trailer body width [m], > 0.
    max_steer_rate : float
        Road-wheel steer rate the controllers may command [rad/s], in (0, 10]. Default 0.6 rad/s
        (34 deg/s): electric power steering in parking assists turns the road wheels at 30-40 deg/s.
    max_accel : float
        Longitudinal acceleration the controllers may command [m/s^2], in (0, 10]. Default 1 m/s^2.
    length_tolerance : float
        How far the real L_H and L_T may be from these, as a fraction of them, in [0, 0.5]: the
        collision checks (the planner's and the guard's) keep their clearance for every hitch offset and
        trailer length within it (both scaled by one factor in [1 - f, 1 + f]). A trailer's length
        measured by its owner is good to some centimetres; 0.1 is 27 cm of Table 4's trailer. Default 0:
        the lengths are exact. A plant's real vehicle has 0.
    """

    wheelbase: float = checked(2.896, Real(0.0, MAX_WHEELBASE, low_open=True, unit="m"))
    hitch_offset: float = checked(1.159, Real(0.0, MAX_HITCH_OFFSET, unit="m (hitch behind the rear axle)"))
    trailer_length: float = checked(2.693, Real(0.0, MAX_TRAILER_LENGTH, low_open=True, unit="m"))
    max_steer: float = checked(0.75, _ANGLE_LIMIT)
    max_hitch: float = checked(math.radians(70.0), _ANGLE_LIMIT)
    front_overhang: float = checked(0.95, _OVERHANG)
    rear_overhang: float = checked(1.0, _OVERHANG)
    vehicle_width: float = checked(1.95, _WIDTH)
    trailer_front: float = checked(2.0, Real(0.0, MAX_TRAILER_LENGTH, low_open=True, unit="m"))
    trailer_rear: float = checked(1.0, _OVERHANG)
    trailer_width: float = checked(1.8, _WIDTH)
    max_steer_rate: float = checked(0.6, Real(0.0, 10.0, low_open=True, unit="rad/s"))
    max_accel: float = checked(1.0, Real(0.0, 10.0, low_open=True, unit="m/s^2"))
    length_tolerance: float = checked(0.0, Real(0.0, 0.5, unit="(a fraction of L_H and L_T)"))

    def __post_init__(self) -> None:
        check_fields(self)
        if self.trailer_front >= self.trailer_length:
            raise InputError(
                f"trailer_front must be < trailer_length ({self.trailer_length:g} m): "
                f"the trailer body ends before the hitch, got {self.trailer_front:g}"
            )

    def require_hitch_offset(self) -> None:
        """Raise :class:`~hitchpark.checks.InputError` unless L_H > 0, which the inverse kinematics need."""
        if self.hitch_offset <= 0.0:
            raise InputError(
                "hitch_offset must be > 0 m for the inverse kinematics (Eq. 45 divides by L_H); "
                f"got {self.hitch_offset:g}"
            )

    def to_dict(self) -> dict[str, float]:
        return asdict(self)


_FIELDS = tuple(f.name for f in fields(VehicleTrailer))


def check_vehicle(vehicle: Any, name: str = "vehicle") -> VehicleTrailer:
    """``vehicle`` if it is a :class:`VehicleTrailer`; else an ``InputError``."""
    return check_instance(name, vehicle, VehicleTrailer, "hitchpark.VehicleTrailer(...)")


def vehicle_from_dict(data: Any, base: VehicleTrailer | None = None, what: str = "vehicle") -> VehicleTrailer:
    """Build a vehicle from a mapping of field names (the table ``[what]``), on top of ``base`` (default: Table 4)."""
    table = check_keys(what, data, _FIELDS)
    return replace(base or VehicleTrailer(), **table)


def load_vehicle(path: str | Path, base: VehicleTrailer | None = None) -> VehicleTrailer:
    """Read a vehicle from a TOML file whose keys are :class:`VehicleTrailer` field names.

    The keys may sit at the top level or under a ``[vehicle]`` table.
    """
    path = Path(path)
    data = read_toml(path, "vehicle")
    if "vehicle" in data and isinstance(data["vehicle"], dict) and len(data) == 1:
        data = data["vehicle"]
    try:
        return vehicle_from_dict(data, base)
    except ValueError as exc:
        raise InputError(f"vehicle file {path}: {exc}") from None
