"""The 3-stage parking process (Fig. 7): reverse (NMPC), forward (pure pursuit), reverse again.

The plant is the full vehicle-trailer model (Eqs. 19-24) integrated with RK4 and
the command held over each sample. A reverse stage runs the NMPC until its
optimal trailer speed is zero; if the result is not yet a success, a forward
stage repositions and another reverse stage follows, up to ``max_stages`` stages.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from ..checks import InputError, check_int, check_range
from ..control.nmpc import Pose, TrailerNMPC, to_goal_frame
from ..control.ocp import NMPCSettings
from ..control.pure_pursuit import PurePursuitSettings, forward_done, pure_pursuit_steer
from ..model.integrate import PLANT_SUBSTEPS, step_full
from ..model.inverse import virtual_steer_from_front
from ..model.kinematics import trailer_speed_from_rear_speed
from ..model.vehicle import VehicleTrailer, vehicle_from_dict
from ..sim import BASE_COLUMNS, State, Trajectory, check_state, state_columns

__all__ = [
    "MANEUVER_COLUMNS",
    "ManeuverResult",
    "ManeuverSettings",
    "StageResult",
    "SuccessCriteria",
    "park",
]

#: Trajectory columns of a maneuver: those of ``simulate`` plus the controller's.
MANEUVER_COLUMNS = (*BASE_COLUMNS, "stage", "trailer_speed", "virtual_steer", "cost", "solve_ms")


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
        nmpc = asdict(self.nmpc)
        return {"nmpc": nmpc, "forward": asdict(self.forward), "success": asdict(self.success)}


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
    """A whole maneuver: outcome, stages and the trajectory (columns ``MANEUVER_COLUMNS``)."""

    vehicle: VehicleTrailer
    start: State
    goal: Pose
    settings: ManeuverSettings
    success: bool
    reason: str
    stages: tuple[StageResult, ...]
    trajectory: Trajectory
    name: str = ""

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
            "success": self.success,
            "reason": self.reason,
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
            s = data.get("settings", {})
            nmpc: dict[str, Any] = {k: tuple(v) if isinstance(v, list) else v for k, v in s.get("nmpc", {}).items()}
            settings = ManeuverSettings(
                nmpc=NMPCSettings(**nmpc),
                forward=PurePursuitSettings(**s.get("forward", {})),
                success=SuccessCriteria(**s.get("success", {})),
            )
            result = cls(
                vehicle=vehicle_from_dict(data["vehicle"]),
                start=State.from_dict(data["start"]),
                goal=Pose.from_dict(data["goal"]),
                settings=settings,
                success=bool(data["success"]),
                reason=str(data["reason"]),
                stages=tuple(StageResult(**st) for st in data["stages"]),
                trajectory=Trajectory.from_dict(data["trajectory"]),
                name=str(data.get("name", "")),
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


class _Recorder:
    """Rows of the trajectory as the maneuver runs: state at t_k and the command applied after it."""

    def __init__(self) -> None:
        self.states: list[np.ndarray] = []
        self.cols: dict[str, list[float]] = {
            k: []
            for k in ("t", "rear_speed", "front_steer", "stage", "trailer_speed", "virtual_steer", "cost", "solve_ms")
        }

    def add(self, t: float, state: np.ndarray, stage: int, **cmd: float) -> None:
        self.states.append(state)
        self.cols["t"].append(t)
        self.cols["stage"].append(stage)
        for k in ("rear_speed", "front_steer", "trailer_speed", "virtual_steer", "cost", "solve_ms"):
            self.cols[k].append(cmd.get(k, math.nan))

    def __len__(self) -> int:
        return len(self.states)

    def trajectory(self, vehicle: VehicleTrailer) -> Trajectory:
        cols: dict[str, Any] = {**self.cols, **state_columns(vehicle, np.array(self.states))}
        return Trajectory({c: cols[c] for c in MANEUVER_COLUMNS})


def _forward_virtual(vehicle: VehicleTrailer, hitch: float, rear_speed: float, steer: float) -> dict[str, float]:
    return {
        "trailer_speed": float(trailer_speed_from_rear_speed(vehicle, hitch, rear_speed, steer)),  # Eq. (18)
        "virtual_steer": float(virtual_steer_from_front(vehicle, hitch, steer)),  # Eq. (56)
    }


def park(
    vehicle: VehicleTrailer,
    start: State,
    goal: Pose | None = None,
    settings: ManeuverSettings | None = None,
    name: str = "",
    controller: TrailerNMPC | None = None,
) -> ManeuverResult:
    """Park the trailer at ``goal`` from ``start`` with the 3-stage process of Fig. 7.

    Parameters
    ----------
    vehicle : VehicleTrailer
        The combination (L_H > 0).
    start : State
        Start trailer-axle pose and hitch angle (world frame).
    goal : Pose
        Goal trailer-axle pose (default: the origin, heading +x).
    settings : ManeuverSettings
        NMPC, forward stage and success settings (defaults: Table 4 and the README).
    controller : TrailerNMPC, optional
        A ready controller to reuse (it must match ``vehicle``, ``goal`` and ``settings.nmpc``);
        building one compiles the NLP, so batch runs pass their own.

    Returns
    -------
    ManeuverResult
        ``success`` and ``reason`` (``"parked"``, ``"jackknife"``, ``"solver: ..."``,
        ``"stalled"``, ``"timeout"``, ``"max_stages"``), the stages and the trajectory.
    """
    vehicle.require_hitch_offset()
    check_state(vehicle, start)
    goal = goal or Pose()
    settings = settings or ManeuverSettings()
    ok_crit, nmpc_s, fwd = settings.success, settings.nmpc, settings.forward
    dt = nmpc_s.dt
    nmpc = controller or TrailerNMPC(vehicle, nmpc_s, goal)
    if (nmpc.vehicle, nmpc.goal, nmpc.settings) != (vehicle, goal, nmpc_s):
        raise InputError("controller was built for another vehicle, goal or NMPC settings than this maneuver")
    rec = _Recorder()
    stages: list[StageResult] = []
    state = start.as_array()
    t = 0.0
    steer = 0.0
    reason = ""

    def advance(rear_speed: float, front_steer: float) -> np.ndarray | None:
        nxt = step_full(vehicle, state, rear_speed, front_steer, dt, PLANT_SUBSTEPS)
        return None if abs(nxt[3]) > vehicle.max_hitch else nxt  # would jackknife: not applied

    while True:
        index = len(stages)
        kind = "reverse" if index % 2 == 0 else "forward"
        first = len(rec)
        stage_reason = ""
        steps = 0
        if kind == "reverse":
            nmpc.reset(steer)
            for _ in range(nmpc_s.max_steps):
                if t >= ok_crit.max_time - 1e-9:
                    stage_reason = "timeout"
                    break
                u = nmpc.step(*state)
                if not u.ok:
                    stage_reason = f"solver: {u.status}"
                    break
                if u.stop:
                    stage_reason = "stopped"
                    break
                nxt = advance(u.rear_speed, u.front_steer)
                if nxt is None:
                    stage_reason = "jackknife"
                    break
                steer = u.front_steer
                rec.add(
                    t,
                    state,
                    index,
                    rear_speed=u.rear_speed,
                    front_steer=u.front_steer,
                    trailer_speed=u.trailer_speed,
                    virtual_steer=u.virtual_steer,
                    cost=u.cost,
                    solve_ms=u.solve_ms,
                )
                state, t, steps = nxt, t + dt, steps + 1
            else:
                stage_reason = "stalled"
        else:
            while not forward_done(goal, fwd, state):
                if t >= ok_crit.max_time - 1e-9:
                    stage_reason = "timeout"
                    break
                if steps * fwd.speed * dt >= fwd.max_distance - 1e-9:  # distance driven so far
                    stage_reason = "stalled"
                    break
                steer = pure_pursuit_steer(vehicle, goal, fwd, state)
                nxt = advance(fwd.speed, steer)
                if nxt is None:
                    stage_reason = "jackknife"
                    break
                rec.add(
                    t,
                    state,
                    index,
                    rear_speed=fwd.speed,
                    front_steer=steer,
                    **_forward_virtual(vehicle, state[3], fwd.speed, steer),
                )
                state, t, steps = nxt, t + dt, steps + 1
            else:
                stage_reason = "repositioned"
        dist, orient = pose_errors(goal, state)
        stages.append(
            StageResult(kind, steps, dist, math.degrees(orient), math.degrees(state[3]), first, len(rec), stage_reason)
        )
        if stage_reason in ("timeout", "jackknife", "stalled") or stage_reason.startswith("solver"):
            reason = stage_reason
            break
        parked = dist <= ok_crit.distance and abs(orient) <= ok_crit.orientation and abs(state[3]) <= ok_crit.hitch
        if kind == "reverse" and parked:
            reason = "parked"
            break
        if len(stages) >= ok_crit.max_stages:
            reason = "max_stages"
            break
    # Final row: the final state and a stop, steer held.
    rec.add(
        t,
        state,
        len(stages) - 1,
        rear_speed=0.0,
        front_steer=steer,
        trailer_speed=0.0,
        virtual_steer=float(virtual_steer_from_front(vehicle, state[3], steer)),
    )
    traj = rec.trajectory(vehicle)
    within_limits = (
        np.max(np.abs(traj["front_steer"])) <= vehicle.max_steer + 1e-12
        and np.max(np.abs(traj["hitch"])) <= vehicle.max_hitch
    )
    success = reason == "parked" and bool(within_limits) and t <= ok_crit.max_time + 1e-9
    if reason == "parked" and not success:
        reason = "limits exceeded"
    return ManeuverResult(vehicle, start, goal, settings, success, reason, tuple(stages), traj, name)
