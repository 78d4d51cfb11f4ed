"""A knob-assisted drive as a maneuver: a driver's knob profile through the :class:`~hitchpark.assist.KnobAssist`,
in the same closed loop as parking (``plant.sense -> stage.act -> plant.apply``, :mod:`.loop`), recorded as the
same :class:`~.result.ManeuverResult` with the assist's columns (:data:`~.result.ASSIST_COLUMNS`).

A knob profile is a table of ``t, knob, speed_request`` rows (t [s] from 0, increasing; knob in [-1, 1];
speed_request the reverse speed asked [m/s], >= 0). Between rows the values are **held** (zero-order hold, as a
driver's hand holds a knob between two readings; a ramp is written as rows close together): at time t the row
with the largest ``t_i <= t`` acts. After the last row's time the request is a stop (knob held): the drive ends
when the car stands.

The drive ends ``driven`` (the profile ran out and the car stopped), ``stopped_for_obstacle`` (the same, the
guard holding the car before the scene on the last step the driver asked to move), or as any maneuver can
(``jackknife``, ``timeout``, ``collision`` on the true motion). It succeeds when it ends ``driven`` or
``stopped_for_obstacle`` within the real car's steer and hitch limits.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..checks import InputError, check_instance, check_text
from ..control.assist import AssistSettings, AssistStep, KnobAssist
from ..control.estimator import Estimator, EstimatorSettings
from ..model.plant import Command, Measurement, Plant, PlantSettings
from ..model.scene import Scene
from ..model.state import Pose, State, check_goal, check_state
from ..model.vehicle import VehicleTrailer, check_vehicle
from .judge import stage_result, verdict
from .loop import ClosedLoop, run_stage
from .result import ASSIST_COLUMNS, ManeuverResult, Outcome, StageResult
from .settings import ManeuverSettings

__all__ = [
    "PROFILE_COLUMNS",
    "AssistStage",
    "KnobProfile",
    "assisted_loop",
    "assisted_result",
    "drive_assisted",
    "load_knob_profile",
]

#: The columns of a knob profile, in this order.
PROFILE_COLUMNS = ("t", "knob", "speed_request")

#: Longest knob profile [s] (an hour) and most rows.
MAX_PROFILE_S = 3600.0
MAX_PROFILE_ROWS = 100_000


@dataclass(frozen=True)
class KnobProfile:
    """A driver's knob and speed request over time, held between rows (see the module text)."""

    t: np.ndarray
    knob: np.ndarray
    speed_request: np.ndarray

    def __post_init__(self) -> None:
        arrays = [np.asarray(a, dtype=float) for a in (self.t, self.knob, self.speed_request)]
        if any(a.ndim != 1 for a in arrays) or len({len(a) for a in arrays}) != 1 or len(arrays[0]) == 0:
            raise InputError("a knob profile needs columns t, knob, speed_request of equal length, at least one row")
        t, knob, speed = arrays
        if len(t) > MAX_PROFILE_ROWS:
            raise InputError(f"a knob profile has at most {MAX_PROFILE_ROWS} rows, got {len(t)}")
        for name, values in zip(PROFILE_COLUMNS, arrays, strict=True):
            bad = np.flatnonzero(~np.isfinite(values))
            if len(bad):
                raise InputError(f"knob profile row {bad[0] + 1}: {name} must be a finite number, got {values[bad[0]]}")
        checks = (
            (t[0] != 0.0, 0, "t must start at 0"),
            (t[-1] > MAX_PROFILE_S, len(t) - 1, f"t must stay within {MAX_PROFILE_S:g} s"),
        )
        for failed, row, message in checks:
            if failed:
                raise InputError(f"knob profile row {row + 1}: {message}, got {t[row]:g}")
        for name, values, low, high in (("knob", knob, -1.0, 1.0), ("speed_request", speed, 0.0, 5.0)):
            out = np.flatnonzero((values < low) | (values > high))
            if len(out):
                raise InputError(
                    f"knob profile row {out[0] + 1}: {name} must be in [{low:g}, {high:g}], got {values[out[0]]:g}"
                )
        steps = np.flatnonzero(np.diff(t) <= 0.0)
        if len(steps):
            raise InputError(
                f"knob profile row {steps[0] + 2}: t must increase, got {t[steps[0] + 1]:g} after {t[steps[0]]:g}"
            )
        for name, values in zip(PROFILE_COLUMNS, arrays, strict=True):
            object.__setattr__(self, name, values)

    @property
    def duration(self) -> float:
        return float(self.t[-1])

    def at(self, t: float) -> tuple[float, float]:
        """(knob, speed_request) at time ``t``: the last row at or before it; after the end, the knob held, a stop."""
        i = max(int(np.searchsorted(self.t, t + 1e-9, side="right")) - 1, 0)
        return float(self.knob[i]), (0.0 if t > self.t[-1] + 1e-9 else float(self.speed_request[i]))

    def to_csv(self, path: str | Path) -> None:
        np.savetxt(
            path,
            np.column_stack([self.t, self.knob, self.speed_request]),
            delimiter=",",
            header=",".join(PROFILE_COLUMNS),
            comments="",
            fmt="%.10g",
        )


def load_knob_profile(path: str | Path) -> KnobProfile:
    """Read a knob profile from a CSV file with the header ``t,knob,speed_request`` (see the module text)."""
    path = Path(path)
    try:
        with path.open(newline="", encoding="utf-8") as f:
            rows = list(csv.reader(f))
    except OSError as exc:
        raise InputError(f"cannot read the knob profile {path}: {exc.strerror or exc}") from None
    except UnicodeDecodeError:
        raise InputError(f"knob profile {path}: not UTF-8 text") from None
    rows = [r for r in rows if r and any(c.strip() for c in r)]
    if not rows:
        raise InputError(f"knob profile {path}: empty")
    header = tuple(c.strip() for c in rows[0])
    if header != PROFILE_COLUMNS:
        raise InputError(
            f"knob profile {path}: the header must be {','.join(PROFILE_COLUMNS)}, got {','.join(header)[:80]}"
        )
    values = []
    for i, row in enumerate(rows[1:], start=2):
        if len(row) != 3:
            raise InputError(f"knob profile {path} line {i}: 3 values expected, got {len(row)}")
        try:
            values.append([float(c) for c in row])
        except ValueError:
            raise InputError(f"knob profile {path} line {i}: not numbers: {','.join(row)[:80]}") from None
    if not values:
        raise InputError(f"knob profile {path}: no rows after the header")
    table = np.array(values)
    try:
        return KnobProfile(table[:, 0], table[:, 1], table[:, 2])
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None


class AssistStage:
    """The knob assist as a stage of the closed loop: the profile's knob and request each tick; after the profile,
    a stop, and ``stop`` once the car stands."""

    kind = "reverse"
    controller = "assist"
    rate_limited = True

    def __init__(self, assist: KnobAssist, profile: KnobProfile):
        self.assist, self.profile = assist, profile
        self.last: AssistStep | None = None
        self.held = False  # whether the guard held the car on the last step the driver asked to move

    @property
    def max_steps(self) -> int:
        return math.ceil(self.profile.duration / self.assist.settings.dt) + 1000

    def begin(self, measurement: Measurement, goal: Pose) -> float | None:
        self.assist.reset(measurement.front_steer, measurement.rear_speed)
        return None

    def act(self, measurement: Measurement, goal: Pose, in_flight: Sequence[Command]) -> AssistStep:
        knob, request = self.profile.at(measurement.t)
        step = self.assist.step(measurement, knob, request)
        over = measurement.t > self.profile.duration + 1e-9
        if over and step.rear_speed == 0.0 and measurement.rear_speed == 0.0:
            step = replace(step, stop=True)
        self.last = step
        if request > 0.0:
            self.held = step.override == "stopped_for_obstacle"
        return step


def drive_assisted(
    vehicle: VehicleTrailer,
    start: State,
    profile: KnobProfile,
    *,
    goal: Pose | None = None,
    settings: ManeuverSettings | None = None,
    assist: AssistSettings | None = None,
    plant: PlantSettings | None = None,
    scene: Scene | None = None,
    name: str = "",
) -> ManeuverResult:
    """Drive ``profile`` with the knob assist from ``start`` on ``plant`` among ``scene`` (see the module text).

    ``settings`` gives the sample time (``nmpc.dt``) and the clearance the drive is judged against
    (``success.min_clearance_m``); ``assist`` defaults to those and the plant's known delay.
    """
    check_vehicle(vehicle).require_hitch_offset()
    check_state(vehicle, start)
    check_instance("profile", profile, KnobProfile)
    goal = check_goal(goal)
    settings = ManeuverSettings() if settings is None else settings
    plant = PlantSettings() if plant is None else plant
    scene = Scene() if scene is None else scene
    check_instance("scene", scene, Scene)
    check_text("name", name, max_length=200)
    if assist is None:
        assist = AssistSettings(
            dt=settings.nmpc.dt,
            delay_steps=plant.delay_steps,
            min_clearance_m=settings.success.min_clearance_m,
            margin_m=settings.process.guard_margin_m,
        )
    loop = assisted_loop(vehicle, start, goal, plant, assist.dt, profile.duration + 60.0, settings.estimator)
    stage = AssistStage(KnobAssist(vehicle, assist, scene), profile)
    ended = run_stage(loop, 0, stage)
    if loop.outcome is None:
        loop.outcome = Outcome.STOPPED_FOR_OBSTACLE if stage.held else Outcome.DRIVEN
    return assisted_result(loop, stage_result(stage, ended, loop, 0), vehicle, start, settings, plant, scene, name)


def assisted_loop(
    vehicle: VehicleTrailer,
    start: State,
    goal: Pose,
    plant: PlantSettings,
    dt: float,
    max_time: float,
    estimator: EstimatorSettings | None = None,
) -> ClosedLoop:
    """The closed loop of an assisted drive: a plant from ``start``, recording the assist's columns; the readings
    through an :class:`~hitchpark.control.estimator.Estimator` where ``estimator`` filters (as in a maneuver)."""
    car = Plant(plant, vehicle, start, dt)
    loop = ClosedLoop(car, goal, plant.delay_steps, max_time, vehicle.max_steer_rate, vehicle.max_accel)
    if estimator is not None and estimator.filters:
        loop.estimator = Estimator(vehicle, estimator, dt)
    loop.extras = {c: [] for c in ASSIST_COLUMNS}
    return loop


def assisted_result(
    loop: ClosedLoop,
    stage: StageResult,
    vehicle: VehicleTrailer,
    start: State,
    settings: ManeuverSettings,
    plant: PlantSettings,
    scene: Scene,
    name: str,
) -> ManeuverResult:
    """The result of an assisted drive whose loop has ended (its ``outcome`` set): judged on the true motion."""
    loop.final_row(0)
    traj = loop.trajectory()
    _, outcome, detail, swept = verdict(loop, traj, scene, settings.success)
    real = loop.plant.vehicle
    within = bool(
        np.max(np.abs(traj["front_steer"])) <= real.max_steer + 1e-12
        and np.max(np.abs(traj["hitch"])) <= real.max_hitch
    )
    ends = (Outcome.DRIVEN, Outcome.STOPPED_FOR_OBSTACLE, Outcome.STOPPED_BY_DRIVER)
    success = outcome in ends and within
    if outcome in ends and not within:
        outcome = Outcome.LIMITS_EXCEEDED
    result = ManeuverResult(
        vehicle, start, loop.goal, settings, success, outcome.value, (stage,), traj, name, plant, detail, scene
    )
    if swept is not None:
        result.__dict__["swept"] = swept
    return result
