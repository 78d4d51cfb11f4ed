"""The parts of a maneuver's record: how it ended (:class:`Outcome`), each stage (:class:`StageResult`) and each
plan (:class:`PlanRecord`), each read back and checked by the one schema of :mod:`.result`."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from enum import StrEnum
from typing import Any

import numpy as np

from ..checks import (
    Choice,
    InputError,
    Integer,
    Real,
    Text,
    build,
    check_fields,
    check_keys,
    check_mapping,
    check_values,
    checked,
)
from ..model.simulate import Trajectory
from ..planning import STATUSES, Plan
from .settings import MAX_MANEUVER_TIME

__all__ = ["PLAN_COLUMNS", "Outcome", "PlanRecord", "StageResult"]


class Outcome(StrEnum):
    """How a maneuver ended."""

    PARKED = "parked"
    JACKKNIFE = "jackknife"  # the next step would pass max_hitch; it was not applied
    SOLVER = "solver"  # the NMPC and its fallbacks failed; the car was stopped
    STALLED = "stalled"  # a stage that never ended and no longer made its way (reverse, or forward short of its end)
    TIMEOUT = "timeout"
    MAX_STAGES = "max_stages"
    LIMITS_EXCEEDED = "limits exceeded"
    COLLISION = "collision"  # a body touched an obstacle, left the area, or came closer than min_clearance_m
    NO_PATH = "no_path"  # the planner found no way (or gave up replanning); the car was stopped
    PLANNER_TIMEOUT = "planner_timeout"  # the planner's wall-clock safety net passed; the car was stopped
    DRIVEN = "driven"  # a knob-assisted drive ran its knob profile to the end and stopped (``hitchpark assist``)
    STOPPED_FOR_OBSTACLE = "stopped_for_obstacle"  # a knob-assisted drive ended held by the guard before the scene
    STOPPED_BY_DRIVER = "stopped_by_driver"  # a live drive the driver stopped (Esc, ``hitchpark drive``)


@dataclass(frozen=True)
class StageResult:
    """One stage: its kind, number of applied steps, rows [first_row, last_row], its end errors, why it
    ended, and the controller that drove it (``nmpc``, ``pursuit``, ``tracking`` or ``assist``)."""

    kind: str = checked(check=Choice(("reverse", "forward")))
    steps: int = checked(check=Integer(0))
    distance_error_m: float = checked(check=Real(0.0))
    orientation_error_deg: float = checked(check=Real(-180.0, 180.0, unit="deg"))
    final_hitch_deg: float = checked(check=Real(-180.0, 180.0, unit="deg"))
    first_row: int = checked(check=Integer(0))
    last_row: int = checked(check=Integer(0))
    reason: str = checked(check=Text(max_length=200))
    # "": not recorded (older files)
    controller: str = checked("", Choice(("", "nmpc", "pursuit", "tracking", "assist")))

    def __post_init__(self) -> None:
        check_fields(self, "stage.")

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


#: The columns of a planned path kept in a result: the trailer-axle pose, the hitch, the direction.
PLAN_COLUMNS = ("x_trailer", "y_trailer", "yaw_trailer", "hitch", "direction")


@dataclass(frozen=True)
class PlanRecord:
    """One plan of a planned maneuver: its status, planning time [s], detail, path (:data:`PLAN_COLUMNS`), and for
    a search that found nothing, where it got stuck (``closest``: x, y, yaw, hitch of the trailer axle, or None;
    written only where there is one)."""

    status: str = checked(check=Choice(STATUSES))
    planning_s: float = checked(check=Real(0.0, MAX_MANEUVER_TIME, unit="s"))
    detail: str = checked("", Text(max_length=500))
    path: dict[str, np.ndarray] = field(default_factory=dict)
    closest: tuple[float, float, float, float] | None = None

    def __post_init__(self) -> None:
        check_fields(self, "plans[].")
        if self.closest is not None:
            values = check_values("plans[].closest", self.closest, ndim=1)
            if values.shape != (4,):
                raise InputError(f"plans[].closest must be 4 numbers (x, y, yaw, hitch), got {values.size}")
            object.__setattr__(self, "closest", tuple(float(v) for v in values))

    @classmethod
    def of(cls, plan: Plan) -> PlanRecord:
        path = {c: plan.path[c] for c in PLAN_COLUMNS} if plan.path else {}
        closest = None if plan.closest is None else tuple(float(v) for v in plan.closest)
        return cls(plan.status, plan.planning_s, plan.detail[:500], path, closest)  # type: ignore[arg-type]

    @property
    def direction_switches(self) -> int:
        d = self.path.get("direction", np.zeros(0))
        return int(np.count_nonzero(d[2:] != d[1:-1])) if len(d) > 2 else 0

    def to_dict(self) -> dict[str, Any]:
        return {
            "status": self.status,
            "planning_s": self.planning_s,
            "detail": self.detail,
            "path": {c: self.path[c].tolist() for c in PLAN_COLUMNS} if self.path else {},
        } | ({} if self.closest is None else {"closest": list(self.closest)})

    @classmethod
    def from_dict(cls, data: Any, what: str) -> PlanRecord:
        table = dict(check_keys(what, data, ("status", "planning_s", "detail", "path", "closest")))
        columns: dict[str, np.ndarray] = {}
        if table.get("path"):
            path = Trajectory.from_dict(check_mapping(f"{what}.path", table["path"]), finite=PLAN_COLUMNS)
            missing = [c for c in PLAN_COLUMNS if c not in path]
            if missing:
                raise InputError(f"{what}.path lacks the column {missing[0]!r}")
            columns = {c: np.asarray(path[c], dtype=float) for c in PLAN_COLUMNS}
        return build(cls, {**table, "path": columns}, what)
