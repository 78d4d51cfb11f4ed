"""Scenario files: a start, a goal and optional vehicle and settings, in TOML.

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
    [success]          # SuccessCriteria fields

The four scenarios of Section 6.1 ship with the package (:func:`builtin_scenarios`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

from ..checks import InputError, check_keys, check_number, check_text
from ..io import read_toml
from ..model.plant import PlantSettings
from ..model.state import Pose, State, check_pose, check_state
from ..model.vehicle import VehicleTrailer, vehicle_from_dict
from .result import ManeuverSettings

__all__ = ["BUILTIN_ORDER", "Scenario", "builtin_scenarios", "load_scenario", "scenario_from_dict"]

#: The paper's four scenarios, in its order.
BUILTIN_ORDER = ("parallel", "parallel_hitch", "perpendicular", "random")

#: A scenario's name names its output folder: letters, digits, '_', '.', '-', not starting with a dot.
NAME_PATTERN = r"[A-Za-z0-9][A-Za-z0-9_.-]*"
NAME_RULE = "letters, digits, '_', '.' or '-', not starting with '.' or '-' (it names a folder)"

_TOP = ("name", "description", "start", "goal", "vehicle", "plant", "nmpc", "forward", "success")


@dataclass(frozen=True)
class Scenario:
    """A parking task: where the combination starts, where the trailer should end, and with what."""

    name: str
    start: State
    goal: Pose = field(default_factory=Pose)
    vehicle: VehicleTrailer = field(default_factory=VehicleTrailer)
    settings: ManeuverSettings = field(default_factory=ManeuverSettings)
    description: str = ""
    path: Path | None = None
    plant: PlantSettings = field(default_factory=PlantSettings)


def _pose_fields(table: str, data: Any, keys: tuple[str, ...], required: bool) -> dict[str, float]:
    values = check_keys(table, data, keys)
    missing = [k for k in keys if k not in values]
    if required and missing:
        raise InputError(f"{table}.{missing[0]} is missing; [{table}] needs {', '.join(keys)}")
    return {k: check_number(f"{table}.{k}", v) for k, v in values.items()}


def scenario_from_dict(data: dict[str, Any], path: Path | None = None) -> Scenario:
    """Build and check a :class:`Scenario` from parsed TOML."""
    data = check_keys("scenario", data, _TOP, "top-level key {!r}")
    if "start" not in data:
        raise InputError("[start] is missing: it needs x, y, yaw_deg, hitch_deg")
    start_d = _pose_fields("start", data["start"], ("x", "y", "yaw_deg", "hitch_deg"), required=True)
    goal_d = _pose_fields("goal", data.get("goal", {}), ("x", "y", "yaw_deg"), required=False)
    name = check_text("name", data.get("name", path.stem if path else "scenario"), NAME_PATTERN, NAME_RULE, 100)
    description = check_text("description", data.get("description", ""), max_length=10_000)
    vehicle = vehicle_from_dict(data.get("vehicle", {}))
    check_pose("start", start_d["x"], start_d["y"], math.radians(start_d["yaw_deg"]))
    start = State(start_d["x"], start_d["y"], math.radians(start_d["yaw_deg"]), math.radians(start_d["hitch_deg"]))
    goal = Pose(goal_d.get("x", 0.0), goal_d.get("y", 0.0), math.radians(goal_d.get("yaw_deg", 0.0)))
    settings = ManeuverSettings.from_dict({k: data[k] for k in ("nmpc", "forward", "success") if k in data})
    plant = PlantSettings.from_dict(data.get("plant", {}))
    vehicle.require_hitch_offset()
    check_state(vehicle, start)
    check_state(plant.resolve_vehicle(vehicle), start)
    return Scenario(name, start, goal, vehicle, settings, description, path, plant)


def load_scenario(path: str | Path) -> Scenario:
    """Read a scenario TOML file; any problem is a ``ValueError`` naming the file and the key."""
    path = Path(path)
    data = read_toml(path, "scenario")
    try:
        return scenario_from_dict(data, path)
    except ValueError as exc:
        raise InputError(f"scenario file {path}: {exc}") from None


def builtin_scenarios() -> list[Scenario]:
    """The four scenarios of Section 6.1 shipped with the package, in the paper's order."""
    folder = resources.files("hitchpark.maneuver") / "scenarios"
    out = []
    for name in BUILTIN_ORDER:
        with resources.as_file(folder / f"{name}.toml") as p:
            out.append(load_scenario(p))
    return out
