"""Open-loop simulation of the full vehicle-trailer model and the trajectory record.

A :class:`Trajectory` holds named columns in SI units (radians). Row k holds the
state at ``t[k]`` and the command applied from ``t[k]`` to ``t[k+1]``; the last row
holds the final state and a stop (zero speed, steer held).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..checks import MAX_SPEED, InputError, check_mapping, check_number, check_range, check_values, shown
from .integrate import step_full
from .kinematics import rear_axle_pose
from .state import State, check_state
from .vehicle import VehicleTrailer, check_vehicle

__all__ = ["BASE_COLUMNS", "STATE_COLUMNS", "SimulationResult", "State", "Trajectory", "check_state", "simulate"]

#: Longest open-loop run :func:`simulate` accepts, in samples (a day at dt = 0.1 s).
MAX_SIM_STEPS = 864_000

#: The columns that follow from the state alone (:func:`state_columns`).
STATE_COLUMNS = ("x_trailer", "y_trailer", "yaw_trailer", "yaw_vehicle", "hitch", "x_rear", "y_rear")

#: Columns every trajectory has, in order.
BASE_COLUMNS = (
    "t",
    "x_trailer",
    "y_trailer",
    "yaw_trailer",
    "yaw_vehicle",
    "hitch",
    "x_rear",
    "y_rear",
    "rear_speed",
    "front_steer",
)


class Trajectory:
    """Named columns of equal length (NumPy arrays), addressed by name: ``traj["hitch"]``."""

    def __init__(self, columns: Mapping[str, Any]):
        self.columns = {k: np.asarray(v, dtype=float) for k, v in columns.items()}
        shapes = {v.shape for v in self.columns.values()}
        if any(len(shape) != 1 for shape in shapes):
            raise InputError(f"trajectory columns must be 1-D, got shapes {sorted(shapes)}")
        lengths = {len(v) for v in self.columns.values()}
        if len(lengths) > 1:
            raise InputError(f"trajectory columns differ in length: {sorted(lengths)}")

    def __getitem__(self, name: str) -> np.ndarray:
        return self.columns[name]

    def __contains__(self, name: object) -> bool:
        return name in self.columns

    def __len__(self) -> int:
        return len(next(iter(self.columns.values()))) if self.columns else 0

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self.columns)

    def states(self) -> np.ndarray:
        """(n, 4) array of the full-model state ``(x_trailer, y_trailer, yaw_trailer, hitch)``."""
        return np.column_stack([self["x_trailer"], self["y_trailer"], self["yaw_trailer"], self["hitch"]])

    def to_dict(self) -> dict[str, list[float | None]]:
        """Columns as lists; NaN (e.g. no solve time on a forward step) becomes ``None``."""
        return {k: [None if not math.isfinite(x) else float(x) for x in v] for k, v in self.columns.items()}

    @classmethod
    def from_dict(cls, data: Any, finite: Iterable[str] = ()) -> Trajectory:
        """Columns from JSON lists of numbers, ``None`` for a missing value except in the ``finite`` columns.

        A column must be a flat list of numbers (not strings, not nested lists); the time column
        ``t``, where present, must not decrease.
        """
        table = check_mapping("trajectory", data)
        must = set(finite)
        columns = {}
        for name, values in table.items():
            if not isinstance(values, list | tuple | np.ndarray):
                raise InputError(f"trajectory column {name!r} must be a list of numbers, got {shown(values)}")
            if name not in must:
                values = [np.nan if v is None else v for v in values]
            columns[name] = check_values(f"trajectory column {name!r}", values, ndim=1, allow_nan=name not in must)
        if "t" in columns and np.any(np.diff(columns["t"]) < 0):
            raise InputError("trajectory column 't' must not decrease")
        return cls(columns)

    def to_csv(self, path: str | Path) -> None:
        header = ",".join(self.names)
        np.savetxt(path, np.column_stack(list(self.columns.values())), delimiter=",", header=header, comments="")


def state_columns(vehicle: VehicleTrailer, states: np.ndarray) -> dict[str, np.ndarray]:
    """The state part of the base columns from an (n, 4) array of full-model states."""
    x_t, y_t, yaw_t, hitch = states.T
    x_r, y_r, yaw_v = rear_axle_pose(vehicle, x_t, y_t, yaw_t, hitch)
    return {
        "x_trailer": x_t,
        "y_trailer": y_t,
        "yaw_trailer": yaw_t,
        "yaw_vehicle": yaw_v,
        "hitch": hitch,
        "x_rear": x_r,
        "y_rear": y_r,
    }


@dataclass(frozen=True)
class SimulationResult:
    """Result of :func:`simulate`: the trajectory and why it ended (``"completed"`` or ``"jackknife"``)."""

    vehicle: VehicleTrailer
    start: State
    trajectory: Trajectory
    reason: str

    def to_dict(self) -> dict[str, Any]:
        return {
            "vehicle": self.vehicle.to_dict(),
            "start": self.start.to_dict(),
            "reason": self.reason,
            "trajectory": self.trajectory.to_dict(),
        }


def simulate(
    vehicle: VehicleTrailer,
    start: State,
    rear_speed: float,
    front_steer: float,
    duration: float,
    dt: float = 0.1,
) -> SimulationResult:
    """Drive the full model (Eqs. 19-24) with a constant rear-axle speed and front steer.

    The samples are ``dt`` apart (the last one shorter if ``duration`` is not a
    multiple of ``dt``). The run stops early, with reason ``"jackknife"``, before a
    step that would take the hitch angle past ``vehicle.max_hitch``.
    """
    check_vehicle(vehicle)
    check_state(vehicle, start)
    check_range("speed", rear_speed, -MAX_SPEED, MAX_SPEED, unit="m/s (a kinematic model holds at low speed)")
    check_number("steer", front_steer)
    if abs(front_steer) > vehicle.max_steer:
        raise InputError(
            f"steer must be within +-{math.degrees(vehicle.max_steer):g} deg (max_steer), "
            f"got {math.degrees(front_steer):g} deg"
        )
    check_range("dt", dt, 0.0, 10.0, low_open=True, unit="s")
    check_range("duration", duration, 0.0, low_open=True, unit="s")
    if duration / dt > MAX_SIM_STEPS:
        raise InputError(
            f"duration / dt must give at most {MAX_SIM_STEPS} steps, got {duration / dt:.3g} "
            f"(duration {duration:g} s, dt {dt:g} s)"
        )
    n = max(1, math.ceil(duration / dt - 1e-9))
    times = np.minimum(np.arange(n + 1) * dt, duration)
    states = [start.as_array()]
    reason = "completed"
    for k in range(n):
        nxt = step_full(vehicle, states[-1], rear_speed, front_steer, times[k + 1] - times[k])
        if abs(nxt[3]) > vehicle.max_hitch:
            reason = "jackknife"
            break
        states.append(nxt)
    m = len(states)
    cols: dict[str, Any] = {"t": times[:m], **state_columns(vehicle, np.array(states))}
    cols["rear_speed"] = np.full(m, rear_speed)
    cols["rear_speed"][-1] = 0.0
    cols["front_steer"] = np.full(m, front_steer)
    return SimulationResult(vehicle, start, Trajectory({c: cols[c] for c in BASE_COLUMNS}), reason)
