"""Scenario files: a start, a goal, optional vehicle and settings, and the scene around them, in TOML.

Format (every table but ``[start]`` optional)::

    name = "parallel"
    description = "free text"

    [start]            # trailer-axle pose and hitch angle, world frame
    x = 10.0
    y = 3.5
    yaw_deg = 0.0
    hitch_deg = 0.0

    [goal]             # goal trailer-axle pose (default: origin, heading +x)
    x = 0.0
    y = 0.0
    yaw_deg = 0.0

    [vehicle]          # VehicleTrailer fields (SI units, radians): the controller's model
    [plant]            # PlantSettings fields, [plant.vehicle] the real car's differing fields
    [nmpc]             # NMPCSettings fields
    [forward]          # PurePursuitSettings fields
    [success]          # SuccessCriteria fields (min_clearance_m: how close the bodies may come to the scene)

    [[obstacles]]      # any number of them; world frame, metres
    name = "parked car"                        # optional
    polygon = [[x, y], [x, y], [x, y], ...]    # a simple polygon, either orientation, closed or not

    [area]             # optional: the bodies must stay inside it
    boundary = [[x, y], ...]

    [start_region]     # optional: where a sweep over this scene draws starts, world frame
    x = [lo, hi]       # trailer-axle x [m]
    y = [lo, hi]       # trailer-axle y [m]
    yaw_deg = [lo, hi]
    hitch_deg = [lo, hi]

The obstacles and the area make the scenario's :class:`~hitchpark.model.scene.Scene`; the start must
keep ``success.min_clearance_m`` clear of it (the real car's bodies, ``[plant.vehicle]``). ``[start]``
stays required even with a ``[start_region]``: ``park`` runs from it.

The four scenarios of Section 6.1 ship with the package (:func:`builtin_scenarios`), and
``driveway.toml``, a scene of obstacles, beside them (not among the four: :func:`builtin_scenario`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

from ..checks import MAX_COORDINATE, MAX_YAW, InputError, check_keys, check_text, check_values, shown
from ..io import read_toml
from ..model.collision import closest
from ..model.plant import PlantSettings
from ..model.scene import Scene
from ..model.state import Pose, State, check_pose, check_state, pose_table
from ..model.vehicle import VehicleTrailer, vehicle_from_dict
from .settings import SETTINGS_TABLES, ManeuverSettings

__all__ = [
    "BUILTIN_ORDER",
    "OBSTACLE_SUITE",
    "PLACES_SUITE",
    "Scenario",
    "StartRegion",
    "builtin_scenario",
    "builtin_scenarios",
    "load_scenario",
    "scenario_from_dict",
]

#: The paper's four scenarios, in its order.
BUILTIN_ORDER = ("parallel", "parallel_hitch", "perpendicular", "random")

#: The built-in scenes of obstacles (``reproduce --suite obstacles``), in the issue's order.
OBSTACLE_SUITE = ("driveway", "campsite", "curb_parallel", "bay", "loading_dock")

#: The places trailers are backed into (``reproduce --suite places``): the scenes of obstacles and eight more, of
#: real dimensions (their sources in their files' comments), none of which the planner was tuned on.
PLACES_SUITE = (
    *OBSTACLE_SUITE,
    "driveway_fence",
    "garage_end",
    "campground_angled",
    "trailer_row",
    "dock_alley",
    "boat_ramp",
    "curb_gap",
    "hammerhead",
)

#: A scenario's name names its output folder: letters, digits, '_', '.', '-', not starting with a dot.
NAME_PATTERN = r"[A-Za-z0-9][A-Za-z0-9_.-]*"
NAME_RULE = "letters, digits, '_', '.' or '-', not starting with '.' or '-' (it names a folder)"

_TOP = (
    "name",
    "description",
    "start",
    "goal",
    "vehicle",
    "plant",
    *SETTINGS_TABLES,
    "obstacles",
    "area",
    "start_region",
)

#: The ranges of a start region, in order.
_REGION_KEYS = ("x", "y", "yaw_deg", "hitch_deg")


@dataclass(frozen=True)
class StartRegion:
    """Where starts are drawn for a scene: ``(lo, hi)`` ranges, world frame.

    ``x``, ``y``: the trailer-axle position [m], within +-``MAX_COORDINATE``; ``yaw_deg``: the trailer
    heading [deg], within +-``MAX_YAW``; ``hitch_deg``: the hitch angle [deg], within +-90 here and
    within a vehicle's jackknife limit by :meth:`check_vehicle`. Each range finite with lo <= hi. The
    same fields as a sweep's ``Region``, which is in the parking frame; this one is in the world frame.
    """

    x: tuple[float, float]
    y: tuple[float, float]
    yaw_deg: tuple[float, float]
    hitch_deg: tuple[float, float]

    def __post_init__(self) -> None:
        limits = {"x": MAX_COORDINATE, "y": MAX_COORDINATE, "yaw_deg": math.degrees(MAX_YAW), "hitch_deg": 90.0}
        for key in _REGION_KEYS:
            name, value = f"start_region.{key}", getattr(self, key)
            if isinstance(value, str | bytes) or not isinstance(value, list | tuple) or len(value) != 2:
                raise InputError(f"{name} must be a pair [lo, hi] of numbers, got {shown(value)}")
            unit = "deg" if key.endswith("_deg") else "m"
            pair = check_values(name, value, ndim=1, low=-limits[key], high=limits[key], unit=unit)
            lo, hi = float(pair[0]), float(pair[1])
            if lo > hi:
                raise InputError(f"{name} must be [lo, hi] with lo <= hi, got [{lo:g}, {hi:g}]")
            object.__setattr__(self, key, (lo, hi))

    def check_vehicle(self, vehicle: VehicleTrailer) -> None:
        """Raise :class:`InputError` unless every hitch angle of the region is within ``vehicle.max_hitch``."""
        lo, hi = self.hitch_deg
        limit = math.degrees(vehicle.max_hitch)
        if max(abs(lo), abs(hi)) > limit:
            raise InputError(
                f"start_region.hitch_deg must lie within [-{limit:g}, {limit:g}] deg (the jackknife limit "
                f"max_hitch), got [{lo:g}, {hi:g}]"
            )

    def to_dict(self) -> dict[str, list[float]]:
        return {key: list(getattr(self, key)) for key in _REGION_KEYS}

    @classmethod
    def from_dict(cls, data: Any) -> StartRegion:
        """From the table ``[start_region]``: all four ranges, no other key."""
        table = check_keys("start_region", data, _REGION_KEYS)
        missing = [k for k in _REGION_KEYS if k not in table]
        if missing:
            raise InputError(f"start_region.{missing[0]} is missing; [start_region] needs {', '.join(_REGION_KEYS)}")
        return cls(**table)


@dataclass(frozen=True)
class Scenario:
    """A parking task: where the combination starts, where the trailer should end, and with what.

    ``scene``: the obstacles and area around it (world frame; empty by default); ``start_region``: where
    a sweep over the scene draws its starts (None if the file gives none).
    """

    name: str
    start: State
    goal: Pose = field(default_factory=Pose)
    vehicle: VehicleTrailer = field(default_factory=VehicleTrailer)
    settings: ManeuverSettings = field(default_factory=ManeuverSettings)
    description: str = ""
    path: Path | None = None
    plant: PlantSettings = field(default_factory=PlantSettings)
    scene: Scene = field(default_factory=Scene)
    start_region: StartRegion | None = None


def scenario_from_dict(data: dict[str, Any], path: Path | None = None) -> Scenario:
    """Build and check a :class:`Scenario` from parsed TOML."""
    data = check_keys("scenario", data, _TOP, "top-level key {!r}")
    if "start" not in data:
        raise InputError("[start] is missing: it needs x, y, yaw_deg, hitch_deg")
    start_d = pose_table("start", data["start"], ("x", "y", "yaw_deg", "hitch_deg"), required=True)
    goal_d = pose_table("goal", data.get("goal", {}), ("x", "y", "yaw_deg"), required=False)
    name = check_text("name", data.get("name", path.stem if path else "scenario"), NAME_PATTERN, NAME_RULE, 100)
    description = check_text("description", data.get("description", ""), max_length=10_000)
    vehicle = vehicle_from_dict(data.get("vehicle", {}))
    check_pose("start", start_d["x"], start_d["y"], math.radians(start_d["yaw_deg"]))
    start = State(start_d["x"], start_d["y"], math.radians(start_d["yaw_deg"]), math.radians(start_d["hitch_deg"]))
    goal = Pose(goal_d.get("x", 0.0), goal_d.get("y", 0.0), math.radians(goal_d.get("yaw_deg", 0.0)))
    settings = ManeuverSettings.from_dict({k: data[k] for k in SETTINGS_TABLES if k in data})
    plant = PlantSettings.from_dict(data.get("plant", {}))
    vehicle.require_hitch_offset()
    check_state(vehicle, start)
    real = plant.resolve_vehicle(vehicle)
    check_state(real, start)
    scene = Scene.from_dict({k: data[k] for k in ("obstacles", "area") if k in data})
    region = None
    if "start_region" in data:
        region = StartRegion.from_dict(data["start_region"])
        region.check_vehicle(vehicle)
        region.check_vehicle(real)
    check_start_clear(real, scene, start, settings.success.min_clearance_m)
    return Scenario(name, start, goal, vehicle, settings, description, path, plant, scene, region)


def check_start_clear(vehicle: VehicleTrailer, scene: Scene, start: State, min_clearance: float) -> None:
    """Raise :class:`InputError` naming the body and the obstacle if ``start`` is not ``min_clearance`` [m] clear.

    ``vehicle`` is the car whose bodies count (the plant's); a body touching the scene or not wholly inside
    its area is refused whatever ``min_clearance``.
    """
    contact = closest(vehicle, scene, start.x, start.y, start.yaw, start.hitch)
    if contact is not None and (contact.distance == 0.0 or contact.distance < min_clearance):
        raise InputError(
            f"start collides: {contact.describe()}; the start must be at least success.min_clearance_m = "
            f"{min_clearance:g} m clear of the obstacles and inside the area"
        )


def load_scenario(path: str | Path) -> Scenario:
    """Read a scenario TOML file; any problem is a ``ValueError`` naming the file and the key."""
    path = Path(path)
    data = read_toml(path, "scenario")
    try:
        return scenario_from_dict(data, path)
    except ValueError as exc:
        raise InputError(f"scenario file {path}: {exc}") from None


def builtin_scenario(name: str) -> Scenario:
    """A scenario file shipped with the package by name: the paper's four and ``driveway``."""
    check_text("scenario name", name, NAME_PATTERN, NAME_RULE, 100)
    path = resources.files("hitchpark.maneuver") / "scenarios" / f"{name}.toml"
    if not path.is_file():
        raise InputError(f"no scenario named {name!r} ships with hitchpark")
    with resources.as_file(path) as p:
        return load_scenario(p)


def builtin_scenarios() -> list[Scenario]:
    """The four scenarios of Section 6.1 shipped with the package, in the paper's order."""
    folder = resources.files("hitchpark.maneuver") / "scenarios"
    out = []
    for name in BUILTIN_ORDER:
        with resources.as_file(folder / f"{name}.toml") as p:
            out.append(load_scenario(p))
    return out
