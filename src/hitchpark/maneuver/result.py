"""What a maneuver yields: its outcome, its stages, its trajectory; and the settings that shaped it.

One schema: :meth:`ManeuverResult.to_dict` writes ``maneuver.json`` and
:meth:`ManeuverResult.from_dict` reads it back and checks it. The scene of a maneuver is saved as
``"obstacles"`` (a list of ``{"name", "polygon"}``) and ``"area"`` (``{"boundary"}`` or null), as
:meth:`~hitchpark.model.scene.Scene.to_dict` writes them; files without them load with an empty scene.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np

from ..checks import (
    InputError,
    build,
    check_choice,
    check_flag,
    check_keys,
    check_text,
    shown,
)
from ..io import check_format, format_tag
from ..model.collision import swept_clearance
from ..model.plant import PlantSettings
from ..model.scene import Scene
from ..model.simulate import BASE_COLUMNS, Trajectory
from ..model.state import Pose, State, check_state, to_goal_frame
from ..model.vehicle import VehicleTrailer, vehicle_from_dict
from .predictions import Predictions
from .records import PLAN_COLUMNS, Outcome, PlanRecord, StageResult
from .settings import ManeuverSettings, ProcessSettings, SuccessCriteria

__all__ = [
    "ASSIST_COLUMNS",
    "MANEUVER_COLUMNS",
    "PLAN_COLUMNS",
    "ManeuverResult",
    "ManeuverSettings",
    "Outcome",
    "PlanRecord",
    "ProcessSettings",
    "StageResult",
    "SuccessCriteria",
    "pose_errors",
]

#: Trajectory columns of a maneuver: those of ``simulate`` (``front_steer`` and ``rear_speed`` the actual
#: values at t_k), the commands issued at t_k, the hitch angle the controller saw and how far it may be from the
#: truth (``Measurement.doubt``: 0 for a reading taken as it comes), and the controller's own.
MANEUVER_COLUMNS = (
    *BASE_COLUMNS,
    "front_steer_cmd",
    "rear_speed_cmd",
    "hitch_measured",
    "hitch_doubt",
    "stage",
    "trailer_speed",
    "virtual_steer",
    "cost",
    "solve_ms",
)


#: The knob assist's own columns (``hitchpark assist``, ``drive``; absent from a parking maneuver): the knob, the
#: reverse speed requested [m/s], the override (an index in :data:`hitchpark.assist.OVERRIDES`), the curvature
#: the knob asks and the one the assist follows [1/m]; missing (null) on the rows no assist step made.
ASSIST_COLUMNS = ("knob", "speed_request", "override", "curvature_asked", "curvature_cmd")

#: Columns that are numbers on every row; the others are missing (None in JSON) where they do not apply
#: (no solve on a forward step, say).
FINITE_COLUMNS = (*BASE_COLUMNS, "front_steer_cmd", "rear_speed_cmd", "hitch_measured", "hitch_doubt", "stage")

#: Keys of ``maneuver.json``: those read back, those written for readers only (derived from the rest).
_SAVED_KEYS = (
    "format",
    "name",
    "vehicle",
    "start",
    "goal",
    "obstacles",
    "area",
    "plant",
    "success",
    "reason",
    "detail",
    "stages",
    "settings",
    "trajectory",
    "plans",
    "predictions",
)
_DERIVED_KEYS = (
    "duration_s",
    "max_abs_front_steer_deg",
    "max_abs_hitch_deg",
    "min_clearance_m",
    "collision",
    "planning_s",
    "direction_switches",
)
_REQUIRED_KEYS = ("vehicle", "start", "goal", "success", "reason", "stages", "trajectory")


def _listed_tables(key: str, data: dict[str, Any]) -> list[Any]:
    value = data.get(key, [])
    if not isinstance(value, list):
        raise InputError(f"{key} must be a list of tables, got {shown(value)}")
    return value


def pose_errors(goal: Pose, state: np.ndarray) -> tuple[float, float]:
    """Trailer-axle distance to the goal [m] and signed orientation error [rad]."""
    gx, gy, gyaw = to_goal_frame(goal, state[0], state[1], state[2])
    return float(math.hypot(gx, gy)), float(gyaw)


@dataclass(frozen=True)
class ManeuverResult:
    """A whole maneuver: outcome, stages and the trajectory (columns ``MANEUVER_COLUMNS``).

    ``vehicle`` is the controller's model; ``plant`` the car it drove (``plant_vehicle`` its
    real lengths and limits). ``reason`` is the outcome's value; ``detail`` says more (the
    solver's status). ``scene`` holds the obstacles and area it moved among (empty by default).
    ``predictions``: the NMPC's predicted paths row by row, when recorded (:mod:`.predictions`), else None.
    """

    vehicle: VehicleTrailer
    start: State
    goal: Pose
    settings: ManeuverSettings
    success: bool
    reason: str
    stages: tuple[StageResult, ...]
    trajectory: Trajectory
    name: str = ""
    plant: PlantSettings = field(default_factory=PlantSettings)
    detail: str = ""
    scene: Scene = field(default_factory=Scene)
    plans: tuple[PlanRecord, ...] = ()
    predictions: Predictions | None = None

    @property
    def outcome(self) -> Outcome:
        return Outcome(self.reason)

    @property
    def plant_vehicle(self) -> VehicleTrailer:
        return self.plant.resolve_vehicle(self.vehicle)

    @property
    def max_abs_front_steer_deg(self) -> float:
        return float(np.degrees(np.max(np.abs(self.trajectory["front_steer"]))))

    @property
    def max_abs_hitch_deg(self) -> float:
        return float(np.degrees(np.max(np.abs(self.trajectory["hitch"]))))

    @property
    def duration(self) -> float:
        return float(self.trajectory["t"][-1])

    @cached_property
    def swept(self) -> tuple[float, int]:
        """(least clearance [m], row where it is least) of the true motion: see :attr:`min_clearance_m`."""
        return swept_clearance(self.plant_vehicle, self.scene, self.trajectory.states())

    @property
    def min_clearance_m(self) -> float | None:
        """Least clearance [m] between the real car's bodies and the scene over the whole motion; None if no scene.

        Swept along the true trajectory (columns ``x_trailer``, ``y_trailer``, ``yaw_trailer``, ``hitch``)
        with the plant's lengths (:attr:`plant_vehicle`): a lower bound, low by at most
        ``MAX_STEP_M / 2`` = 2.5 cm (:func:`~hitchpark.model.collision.swept_clearance`); 0 when a body touched
        an obstacle or left the area. ``None`` (null in ``maneuver.json``) for an empty scene, where there
        is nothing to hit.
        """
        return None if self.scene.is_empty else self.swept[0]

    @property
    def planning_s(self) -> float:
        """Wall-clock time of all the planning of this maneuver, replans included [s] (0 if it planned nothing)."""
        return float(sum(p.planning_s for p in self.plans))

    @property
    def direction_switches(self) -> int:
        """Changes of direction of the car's actual motion (forward to reverse or back)."""
        v = self.trajectory["rear_speed"]
        moving = np.sign(v[np.abs(v) > 1e-6])
        return int(np.count_nonzero(moving[1:] != moving[:-1]))

    @property
    def collision(self) -> bool:
        """True if a body touched or overlapped an obstacle or left the area (:attr:`min_clearance_m` is 0)."""
        return self.min_clearance_m == 0.0

    def stage_rows(self, index: int) -> slice:
        """Rows of stage ``index``, including the state it ended in."""
        st = self.stages[index]
        return slice(st.first_row, st.last_row + 1)

    def to_dict(self) -> dict[str, Any]:
        return {
            "format": format_tag("maneuver"),
            "name": self.name,
            "vehicle": self.vehicle.to_dict(),
            "start": self.start.to_dict(),
            "goal": self.goal.to_dict(),
            **self.scene.to_dict(),
            "plant": {**self.plant.to_dict(), "vehicle": self.plant_vehicle.to_dict()},
            "success": self.success,
            "reason": self.reason,
            "detail": self.detail,
            "duration_s": self.duration,
            "max_abs_front_steer_deg": self.max_abs_front_steer_deg,
            "max_abs_hitch_deg": self.max_abs_hitch_deg,
            "min_clearance_m": self.min_clearance_m,
            "collision": self.collision,
            "planning_s": self.planning_s,
            "direction_switches": self.direction_switches,
            "plans": [p.to_dict() for p in self.plans],
            "stages": [s.to_dict() for s in self.stages],
            "settings": self.settings.to_dict(),
            "trajectory": self.trajectory.to_dict(),
        } | ({} if self.predictions is None else {"predictions": self.predictions.to_dict()})

    @classmethod
    def from_dict(cls, data: Any) -> ManeuverResult:
        """Rebuild a saved result, checked field by field; a malformed one is an ``InputError`` saying what."""
        known = (*_SAVED_KEYS, *_DERIVED_KEYS)
        data = check_keys("maneuver", data, known, "top-level key {!r}")
        check_format("maneuver", data)
        missing = [k for k in _REQUIRED_KEYS if k not in data]
        if missing:
            raise InputError(f"maneuver data lacks {missing[0]!r}")
        settings = ManeuverSettings.from_dict(data.get("settings", {}))
        vehicle = vehicle_from_dict(data["vehicle"])
        plant = PlantSettings.from_dict(data["plant"]) if "plant" in data else PlantSettings(kind="ideal")
        reason = check_text("reason", data["reason"], max_length=500)
        detail = check_text("detail", data.get("detail", ""), max_length=2000)
        if reason.startswith("solver:"):  # written before outcomes were an enum
            reason, detail = "solver", reason.partition(":")[2].strip()
        check_choice("reason", reason, [o.value for o in Outcome])
        stages = data["stages"]
        if not isinstance(stages, list):
            raise InputError(f"stages must be a list of stage tables, got {shown(stages)}")
        start = State.from_dict(data["start"])
        check_state(vehicle, start)
        scene = Scene.from_dict({k: data[k] for k in ("obstacles", "area") if k in data})
        result = cls(
            vehicle=vehicle,
            start=start,
            goal=Pose.from_dict(data["goal"]),
            settings=settings,
            success=check_flag("success", data["success"]),
            reason=reason,
            stages=tuple(build(StageResult, st, f"stages[{i}]") for i, st in enumerate(stages)),
            trajectory=Trajectory.from_dict(data["trajectory"], finite=FINITE_COLUMNS),
            name=check_text("name", data.get("name", ""), max_length=200),
            plant=plant,
            detail=detail,
            scene=scene,
            plans=tuple(PlanRecord.from_dict(p, f"plans[{i}]") for i, p in enumerate(_listed_tables("plans", data))),
            predictions=None if data.get("predictions") is None else Predictions.from_dict(data["predictions"]),
        )
        result._check_layout()
        return result

    def _check_layout(self) -> None:
        """Stages must tile the trajectory: contiguous rows from 0 to the last, every column present."""
        missing = [c for c in MANEUVER_COLUMNS if c not in self.trajectory]
        if missing and set(missing) <= {"front_steer_cmd", "rear_speed_cmd", "hitch_measured", "hitch_doubt"}:
            # Saved before the estimator had a doubt (no hitch_doubt: the hitch was taken as read), or before the
            # plant was a car of its own (the ideal plant, commands acted at once).
            cols = dict(self.trajectory.columns)
            if "hitch_measured" in missing:
                cols.update(
                    front_steer_cmd=cols["front_steer"],
                    rear_speed_cmd=cols["rear_speed"],
                    hitch_measured=cols["hitch"],
                )
            cols.setdefault("hitch_doubt", np.zeros(len(cols["hitch"])))
            object.__setattr__(self, "trajectory", Trajectory({c: cols[c] for c in MANEUVER_COLUMNS}))
            missing = []
        if missing:
            raise InputError(f"maneuver trajectory lacks the column {missing[0]!r}")
        n = len(self.trajectory)
        if n < 1 or not self.stages:
            raise InputError("maneuver has no rows or no stages")
        expected_first = 0
        for i, st in enumerate(self.stages):
            if st.first_row != expected_first or not st.first_row <= st.last_row < n:
                raise InputError(
                    f"stage {i} rows [{st.first_row}, {st.last_row}] do not follow on from row {expected_first} "
                    f"within the {n} rows of the trajectory"
                )
            expected_first = st.last_row
        if expected_first != n - 1:
            raise InputError(f"the stages end at row {expected_first}, the trajectory at row {n - 1}")
        if self.predictions is not None and len(self.predictions) != n:
            raise InputError(f"predictions has {len(self.predictions)} rows, the trajectory {n}")
