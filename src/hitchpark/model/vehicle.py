"""Vehicle-trailer parameters (Table 1 of the paper; defaults from Table 4)."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields, replace
from pathlib import Path
from typing import Any

from ..checks import InputError, check_range
from ..io import read_toml

__all__ = ["VehicleTrailer", "load_vehicle", "vehicle_from_dict"]


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
        Front-wheel steer limit |delta_f| <= max_steer [rad], in (0, pi/2).
    max_hitch : float
        Jackknife limit |hitch angle| <= max_hitch [rad], in (0, pi/2). Default 70 deg.
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
    """

    wheelbase: float = 2.896
    hitch_offset: float = 1.159
    trailer_length: float = 2.693
    max_steer: float = 0.75
    max_hitch: float = math.radians(70.0)
    front_overhang: float = 0.95
    rear_overhang: float = 1.0
    vehicle_width: float = 1.95
    trailer_front: float = 2.0
    trailer_rear: float = 1.0
    trailer_width: float = 1.8
    max_steer_rate: float = 0.6
    max_accel: float = 1.0

    def __post_init__(self) -> None:
        def put(name: str, value: float) -> None:
            object.__setattr__(self, name, value)

        for name in (
            "wheelbase",
            "trailer_length",
            "front_overhang",
            "rear_overhang",
            "vehicle_width",
            "trailer_front",
            "trailer_rear",
            "trailer_width",
        ):
            put(name, check_range(name, getattr(self, name), 0.0, low_open=True, unit="m"))
        put("hitch_offset", check_range("hitch_offset", self.hitch_offset, 0.0, unit="m (hitch behind the rear axle)"))
        for name in ("max_steer", "max_hitch"):
            put(
                name,
                check_range(
                    name, getattr(self, name), 0.0, math.pi / 2, low_open=True, high_open=True, unit="rad (0 to 90 deg)"
                ),
            )
        put(
            "max_steer_rate", check_range("max_steer_rate", self.max_steer_rate, 0.0, 10.0, low_open=True, unit="rad/s")
        )
        put("max_accel", check_range("max_accel", self.max_accel, 0.0, 10.0, low_open=True, unit="m/s^2"))
        if self.trailer_front >= self.trailer_length:
            raise InputError(
                f"trailer_front must be < trailer_length ({self.trailer_length:g} m): "
                f"the trailer body ends before the hitch, got {self.trailer_front:g}"
            )

    def require_hitch_offset(self) -> None:
        """Raise ``ValueError`` unless L_H > 0, which the inverse kinematics need."""
        if self.hitch_offset <= 0.0:
            raise InputError(
                "hitch_offset must be > 0 m for the inverse kinematics (Eq. 45 divides by L_H); "
                f"got {self.hitch_offset:g}"
            )

    def to_dict(self) -> dict[str, float]:
        return asdict(self)


_FIELDS = tuple(f.name for f in fields(VehicleTrailer))


def vehicle_from_dict(data: dict[str, Any], base: VehicleTrailer | None = None) -> VehicleTrailer:
    """Build a vehicle from a mapping of field names, starting from ``base`` (default: Table 4)."""
    unknown = sorted(set(data) - set(_FIELDS))
    if unknown:
        raise InputError(f"unknown vehicle field {unknown[0]!r}; allowed fields: {', '.join(_FIELDS)}")
    return replace(base or VehicleTrailer(), **data)


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
