"""Where a sweep's cases start: a region of start configurations (:class:`Region`, ``--region`` text),
starts drawn from it by a seed, and over a scene only those clear of it (:func:`draw_clear_starts`)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..checks import MAX_COORDINATE, MAX_YAW, InputError, check_int
from ..maneuver.scenario import check_start_clear
from ..model.scene import Scene
from ..model.vehicle import VehicleTrailer
from .records import Start

__all__ = ["DEFAULT_REGION", "MAX_CASES", "Region", "draw_clear_starts", "draw_starts", "parse_region"]


#: The most cases one sweep accepts.
MAX_CASES = 1_000_000


_RANGE_KEYS = {"x": "x", "y": "y", "yaw": "yaw_deg", "hitch": "hitch_deg"}  # text key -> Region field


def _fmt(value: float) -> str:
    short = f"{value:g}"
    return short if float(short) == value else repr(value)


@dataclass(frozen=True)
class Region:
    """Where starts are drawn: ``(lo, hi)`` of the trailer-axle x, y [m], yaw [deg] and hitch angle [deg].

    In the world frame of the sweep's goal and scene; with the default goal (origin, heading 0) the parking frame.

    Each range is finite with lo <= hi, |x|, |y| <= ``MAX_COORDINATE`` and |yaw| <= ``MAX_YAW``;
    the hitch range is checked against a vehicle's jackknife limit by :meth:`check_vehicle`.
    """

    x: tuple[float, float] = (4.0, 16.0)
    y: tuple[float, float] = (-8.0, 8.0)
    yaw_deg: tuple[float, float] = (-90.0, 90.0)
    hitch_deg: tuple[float, float] = (-30.0, 30.0)

    def __post_init__(self) -> None:
        limits = {"x": MAX_COORDINATE, "y": MAX_COORDINATE, "yaw_deg": math.degrees(MAX_YAW), "hitch_deg": math.inf}
        for key, name in _RANGE_KEYS.items():
            value = getattr(self, name)
            try:
                lo, hi = (float(v) for v in value)
            except (TypeError, ValueError):
                raise InputError(f"region {key} must be a pair lo, hi of numbers, got {value!r}") from None
            unit = " deg" if name.endswith("_deg") else " m"
            if not (math.isfinite(lo) and math.isfinite(hi)) or lo > hi:
                raise InputError(f"region {key} must be lo:hi with finite lo <= hi, got {_fmt(lo)}:{_fmt(hi)}")
            if max(abs(lo), abs(hi)) > limits[name]:
                raise InputError(
                    f"region {key} must lie within -{limits[name]:g}:{limits[name]:g}{unit}, got {_fmt(lo)}:{_fmt(hi)}"
                )
            object.__setattr__(self, name, (lo, hi))

    def check_vehicle(self, vehicle: VehicleTrailer) -> None:
        """Raise :class:`InputError` unless every hitch angle of the region is within ``vehicle.max_hitch``."""
        lo, hi = self.hitch_deg
        if max(abs(math.radians(lo)), abs(math.radians(hi))) > vehicle.max_hitch:
            limit = math.degrees(vehicle.max_hitch)
            raise InputError(
                f"region hitch must lie within -{limit:g}:{limit:g} deg (the vehicle's jackknife limit max_hitch), "
                f"got {_fmt(lo)}:{_fmt(hi)}"
            )

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """``(lo, hi)`` arrays in the order x, y, yaw_deg, hitch_deg."""
        pairs = [getattr(self, name) for name in _RANGE_KEYS.values()]
        return np.array([p[0] for p in pairs]), np.array([p[1] for p in pairs])

    def to_dict(self) -> dict[str, list[float]]:
        return {name: list(getattr(self, name)) for name in _RANGE_KEYS.values()}

    def __str__(self) -> str:
        return ",".join(f"{k}={_fmt(getattr(self, n)[0])}:{_fmt(getattr(self, n)[1])}" for k, n in _RANGE_KEYS.items())


DEFAULT_REGION = Region()


def parse_region(text: str, vehicle: VehicleTrailer | None = None) -> Region:
    """``"x=4:16,y=-8:8,yaw=-90:90,hitch=-30:30"`` -> :class:`Region`; a key left out keeps its default.

    With ``vehicle``, the hitch range must also lie within its jackknife limit.
    """
    allowed = f"comma-separated KEY=LO:HI with KEY one of {', '.join(_RANGE_KEYS)}"
    ranges: dict[str, tuple[float, float]] = {}
    for item in text.split(",") if text.strip() else []:
        key, eq, value = item.partition("=")
        key = key.strip()
        if not eq or key not in _RANGE_KEYS:
            raise InputError(f"--region must be {allowed}; got the entry {item.strip()!r}")
        if _RANGE_KEYS[key] in ranges:
            raise InputError(f"--region gives {key} twice: {text!r}")
        parts = value.split(":")
        try:
            lo, hi = (float(p) for p in parts)
        except ValueError:
            raise InputError(f"--region {key} must be LO:HI (two numbers), got {value.strip()!r}") from None
        ranges[_RANGE_KEYS[key]] = (lo, hi)
    region = Region(**ranges)
    if vehicle is not None:
        region.check_vehicle(vehicle)
    return region


def draw_starts(seed: int, n: int, region: Region) -> list[Start]:
    """The ``n`` starts of a sweep, uniform over ``region``, all drawn up front from ``default_rng(seed)``.

    Row i of the draw is case i; as the generator's stream is consumed in order, the first
    cases of a sweep do not depend on ``n`` either.
    """
    seed = check_int("seed", seed, 0)
    n = check_int("n", n, 1, MAX_CASES)
    lo, hi = region.bounds()
    values = np.clip(lo + np.random.default_rng(seed).random((n, 4)) * (hi - lo), lo, hi)
    return [Start(*(float(v) for v in row)) for row in values]


#: At most this many draws per case (and at least ``_MIN_DRAWS``) look for starts clear of a scene.
_DRAWS_PER_CASE = 100


_MIN_DRAWS = 10_000


def draw_clear_starts(
    seed: int, n: int, region: Region, keep: Callable[[Start], bool] | None = None
) -> tuple[list[Start], int]:
    """The ``n`` starts of a sweep and how many draws were skipped: the draws of :func:`draw_starts`, in order,
    less those ``keep`` refuses (starts that collide with a scene).

    Case i is the i-th kept draw, so the first cases still do not depend on ``n``. Without ``keep`` it is
    :func:`draw_starts` and nothing is skipped. Raises :class:`InputError` if too few draws are kept
    (fewer than ``n`` in ``max(10000, 100 n)``).
    """
    if keep is None:
        return draw_starts(seed, n, region), 0
    seed = check_int("seed", seed, 0)
    n = check_int("n", n, 1, MAX_CASES)
    lo, hi = region.bounds()
    rng = np.random.default_rng(seed)  # drawn in batches: the stream is the same as one draw of all rows
    starts: list[Start] = []
    drawn, limit = 0, max(_MIN_DRAWS, _DRAWS_PER_CASE * n)
    while len(starts) < n:
        if drawn >= limit:
            raise InputError(
                f"only {len(starts)} of {drawn} starts drawn from the region {region} keep clear of the scene "
                f"(success.min_clearance_m and process.guard_margin_m), fewer than --n {n}: move or widen the start "
                "region"
            )
        batch = min(limit - drawn, max(64, 2 * (n - len(starts))))
        for row in np.clip(lo + rng.random((batch, 4)) * (hi - lo), lo, hi):
            drawn += 1
            start = Start(*(float(v) for v in row))
            if keep(start):
                starts.append(start)
                if len(starts) == n:
                    break
    return starts, drawn - n


@dataclass(frozen=True)
class _ClearOf:
    """Keeps a start whose bodies (the real car's) are ``min_clearance`` clear of ``scene`` and inside its area."""

    vehicle: VehicleTrailer
    scene: Scene
    min_clearance: float

    def __call__(self, start: Start) -> bool:
        try:
            check_start_clear(self.vehicle, self.scene, start.state(), self.min_clearance)
        except InputError:
            return False
        return True
