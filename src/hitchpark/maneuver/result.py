"""What a maneuver yields: its outcome, its stages, its trajectory; and the settings that shaped it.

One schema: :meth:`ManeuverResult.to_dict` writes ``maneuver.json`` and
:meth:`ManeuverResult.from_dict` reads it back and checks it.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from enum import StrEnum
from typing import Any

import numpy as np

from ..checks import InputError, check_int, check_range
from ..control.ocp import NMPCSettings
from ..control.pure_pursuit import PurePursuitSettings
from ..model.plant import PlantSettings
from ..model.state import Pose, State, to_goal_frame
from ..model.vehicle import VehicleTrailer, vehicle_from_dict
from ..sim import BASE_COLUMNS, Trajectory

__all__ = [
    "MANEUVER_COLUMNS",
    "ManeuverResult",
    "ManeuverSettings",
    "Outcome",
    "StageResult",
    "SuccessCriteria",
    "pose_errors",
]

#: Trajectory columns of a maneuver: those of ``simulate`` (``front_steer`` and ``rear_speed`` the actual
#: values at t_k), the commands issued at t_k, the hitch angle the controller saw, and the controller's own.
MANEUVER_COLUMNS = (
    *BASE_COLUMNS,
    "front_steer_cmd",
    "rear_speed_cmd",
    "hitch_measured",
    "stage",
    "trailer_speed",
    "virtual_steer",
    "cost",
    "solve_ms",
)


class Outcome(StrEnum):
    """How a maneuver ended."""

    PARKED = "parked"
    JACKKNIFE = "jackknife"  # the next step would pass max_hitch; it was not applied
    SOLVER = "solver"  # the NMPC and its fallbacks failed; the car was stopped
    STALLED = "stalled"  # a stage that never ended (reverse never stopped, forward never met its conditions)
    TIMEOUT = "timeout"
    MAX_STAGES = "max_stages"
    LIMITS_EXCEEDED = "limits exceeded"


@dataclass(frozen=True)
class SuccessCriteria:
    """Success, defined once: final errors within these, limits never exceeded, within stages and time.

    distance [m] (trailer axle to goal), orientation [rad] (trailer yaw error),
    hitch [rad] (final |hitch|), max_stages, max_time [s] of maneuver time.
    """

    distance: float = 0.05
    orientation: float = math.radians(0.5)
    hitch: float = math.radians(3.0)
    max_stages: int = 7
    max_time: float = 300.0

    def __post_init__(self) -> None:
        for name in ("distance", "orientation", "hitch", "max_time"):
            object.__setattr__(self, name, check_range(f"success.{name}", getattr(self, name), 0.0, low_open=True))
        object.__setattr__(self, "max_stages", check_int("success.max_stages", self.max_stages, 1, 1000))


@dataclass(frozen=True)
class ManeuverSettings:
    """Everything that shapes a maneuver besides the vehicle, start and goal."""

    nmpc: NMPCSettings = field(default_factory=NMPCSettings)
    forward: PurePursuitSettings = field(default_factory=PurePursuitSettings)
    success: SuccessCriteria = field(default_factory=SuccessCriteria)

    def to_dict(self) -> dict[str, Any]:
        return {"nmpc": asdict(self.nmpc), "forward": asdict(self.forward), "success": asdict(self.success)}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> ManeuverSettings:
        nmpc: dict[str, Any] = {k: tuple(v) if isinstance(v, list) else v for k, v in data.get("nmpc", {}).items()}
        return cls(
            nmpc=NMPCSettings(**nmpc),
            forward=PurePursuitSettings(**data.get("forward", {})),
            success=SuccessCriteria(**data.get("success", {})),
        )


@dataclass(frozen=True)
class StageResult:
    """One stage: its kind, number of applied steps, rows [first_row, last_row] and its end errors."""

    kind: str
    steps: int
    distance_error_m: float
    orientation_error_deg: float
    final_hitch_deg: float
    first_row: int
    last_row: int
    reason: str

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def pose_errors(goal: Pose, state: np.ndarray) -> tuple[float, float]:
    """Trailer-axle distance to the goal [m] and signed orientation error [rad]."""
    gx, gy, gyaw = to_goal_frame(goal, state[0], state[1], state[2])
    return float(math.hypot(gx, gy)), float(gyaw)


@dataclass(frozen=True)
class ManeuverResult:
    """A whole maneuver: outcome, stages and the trajectory (columns ``MANEUVER_COLUMNS``).

    ``vehicle`` is the controller's model; ``plant`` the car it drove (``plant_vehicle`` its
    real lengths and limits). ``reason`` is the outcome's value; ``detail`` says more (the
    solver's status).
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

    def stage_rows(self, index: int) -> slice:
        """Rows of stage ``index``, including the state it ended in."""
        st = self.stages[index]
        return slice(st.first_row, st.last_row + 1)

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "vehicle": self.vehicle.to_dict(),
            "start": self.start.to_dict(),
            "goal": self.goal.to_dict(),
            "plant": {**self.plant.to_dict(), "vehicle": self.plant_vehicle.to_dict()},
            "success": self.success,
            "reason": self.reason,
            "detail": self.detail,
            "duration_s": self.duration,
            "max_abs_front_steer_deg": self.max_abs_front_steer_deg,
            "max_abs_hitch_deg": self.max_abs_hitch_deg,
            "stages": [s.to_dict() for s in self.stages],
            "settings": self.settings.to_dict(),
            "trajectory": self.trajectory.to_dict(),
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> ManeuverResult:
        """Rebuild a saved result; a malformed one is a ``ValueError`` that says what is wrong."""
        try:
            settings = ManeuverSettings.from_dict(data.get("settings", {}))
            vehicle = vehicle_from_dict(data["vehicle"])
            plant = PlantSettings.from_dict(data["plant"]) if "plant" in data else PlantSettings(kind="ideal")
            reason = str(data["reason"])
            detail = str(data.get("detail", ""))
            if reason.startswith("solver:"):  # written before outcomes were an enum
                reason, detail = "solver", reason.partition(":")[2].strip()
            Outcome(reason)
            result = cls(
                vehicle=vehicle,
                start=State.from_dict(data["start"]),
                goal=Pose.from_dict(data["goal"]),
                settings=settings,
                success=bool(data["success"]),
                reason=reason,
                stages=tuple(StageResult(**st) for st in data["stages"]),
                trajectory=Trajectory.from_dict(data["trajectory"]),
                name=str(data.get("name", "")),
                plant=plant,
                detail=detail,
            )
        except InputError:
            raise
        except KeyError as exc:
            raise InputError(f"maneuver data lacks {exc}") from None
        except (TypeError, AttributeError, ValueError) as exc:
            raise InputError(f"maneuver data is malformed: {exc}") from None
        result._check_layout()
        return result

    def _check_layout(self) -> None:
        """Stages must tile the trajectory: contiguous rows from 0 to the last, every column present."""
        missing = [c for c in MANEUVER_COLUMNS if c not in self.trajectory]
        if missing and set(missing) <= {"front_steer_cmd", "rear_speed_cmd", "hitch_measured"}:
            # Saved before the plant was a car of its own: the ideal plant, commands acted at once.
            cols = dict(self.trajectory.columns)
            cols.update(
                front_steer_cmd=cols["front_steer"], rear_speed_cmd=cols["rear_speed"], hitch_measured=cols["hitch"]
            )
            object.__setattr__(self, "trajectory", Trajectory({c: cols[c] for c in MANEUVER_COLUMNS}))
            missing = []
        if missing:
            raise InputError(f"maneuver trajectory lacks the column {missing[0]!r}")
        n = len(self.trajectory)
        if n < 1 or not self.stages:
            raise InputError("maneuver has no rows or no stages")
        expected_first = 0
        for i, st in enumerate(self.stages):
            if st.kind not in ("reverse", "forward"):
                raise InputError(f"stage {i} kind must be 'reverse' or 'forward', got {st.kind!r}")
            if not (isinstance(st.first_row, int) and isinstance(st.last_row, int)):
                raise InputError(f"stage {i} rows must be integers, got {st.first_row!r}, {st.last_row!r}")
            if st.first_row != expected_first or not st.first_row <= st.last_row < n:
                raise InputError(
                    f"stage {i} rows [{st.first_row}, {st.last_row}] do not follow on from row {expected_first} "
                    f"within the {n} rows of the trajectory"
                )
            expected_first = st.last_row
        if expected_first != n - 1:
            raise InputError(f"the stages end at row {expected_first}, the trajectory at row {n - 1}")
