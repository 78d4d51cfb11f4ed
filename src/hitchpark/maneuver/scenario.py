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
import re
from dataclasses import dataclass, field, fields
from importlib import resources
from pathlib import Path
from typing import Any

from ..checks import InputError, check_number
from ..control.ocp import NMPCSettings
from ..control.pure_pursuit import PurePursuitSettings
from ..io import read_toml
from ..model.plant import PlantSettings
from ..model.state import Pose, State, check_state
from ..model.vehicle import VehicleTrailer, vehicle_from_dict
from .result import ManeuverSettings, SuccessCriteria

__all__ = ["BUILTIN_ORDER", "Scenario", "builtin_scenarios", "load_scenario", "scenario_from_dict"]

#: The paper's four scenarios, in its order.
BUILTIN_ORDER = ("parallel", "parallel_hitch", "perpendicular", "random")

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


def _table(data: dict[str, Any], key: str) -> dict[str, Any]:
    value = data.get(key, {})
    if not isinstance(value, dict):
        raise InputError(f"[{key}] must be a table, got {type(value).__name__}")
    return value


def _number(table: str, key: str, value: Any) -> float:
    return check_number(f"{table}.{key}", value)


def _pose_fields(table: str, data: dict[str, Any], keys: tuple[str, ...], required: bool) -> dict[str, float]:
    unknown = sorted(set(data) - set(keys))
    if unknown:
        raise InputError(f"unknown key {table}.{unknown[0]}; allowed: {', '.join(keys)}")
    missing = [k for k in keys if k not in data]
    if required and missing:
        raise InputError(f"{table}.{missing[0]} is missing; [{table}] needs {', '.join(keys)}")
    return {k: _number(table, k, data[k]) for k in keys if k in data}


def _settings(cls: type, table: str, data: dict[str, Any]) -> Any:
    allowed = tuple(f.name for f in fields(cls) if f.name != "solver_options")
    unknown = sorted(set(data) - set(allowed))
    if unknown:
        raise InputError(f"unknown key {table}.{unknown[0]}; allowed: {', '.join(allowed)}")
    values = {k: tuple(v) if isinstance(v, list) else v for k, v in data.items()}
    try:
        return cls(**values)
    except TypeError as exc:
        raise InputError(f"[{table}]: {exc}") from None


def scenario_from_dict(data: dict[str, Any], path: Path | None = None) -> Scenario:
    """Build and check a :class:`Scenario` from parsed TOML."""
    unknown = sorted(set(data) - set(_TOP))
    if unknown:
        raise InputError(f"unknown top-level key {unknown[0]!r}; allowed: {', '.join(_TOP)}")
    if "start" not in data:
        raise InputError("[start] is missing: it needs x, y, yaw_deg, hitch_deg")
    start_d = _pose_fields("start", _table(data, "start"), ("x", "y", "yaw_deg", "hitch_deg"), required=True)
    goal_d = _pose_fields("goal", _table(data, "goal"), ("x", "y", "yaw_deg"), required=False)
    name = data.get("name", path.stem if path else "scenario")
    if not isinstance(name, str) or not re.fullmatch(r"[A-Za-z0-9][A-Za-z0-9_.-]*", name):
        raise InputError(f"name must be letters, digits, '_', '.' or '-' (it names a folder), got {name!r}")
    description = data.get("description", "")
    if not isinstance(description, str):
        raise InputError(f"description must be a string, got {description!r}")
    vehicle = vehicle_from_dict(_table(data, "vehicle"))
    start = State(start_d["x"], start_d["y"], math.radians(start_d["yaw_deg"]), math.radians(start_d["hitch_deg"]))
    goal = Pose(goal_d.get("x", 0.0), goal_d.get("y", 0.0), math.radians(goal_d.get("yaw_deg", 0.0)))
    settings = ManeuverSettings(
        nmpc=_settings(NMPCSettings, "nmpc", _table(data, "nmpc")),
        forward=_settings(PurePursuitSettings, "forward", _table(data, "forward")),
        success=_settings(SuccessCriteria, "success", _table(data, "success")),
    )
    plant = PlantSettings.from_dict(_table(data, "plant"))
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
