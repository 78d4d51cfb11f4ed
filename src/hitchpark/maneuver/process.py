"""The parking maneuver as one closed loop: ``plant.sense -> stage.act -> plant.apply``.

Stages alternate from reverse (Fig. 7): a reverse stage runs its NMPC until the optimal
speed is zero; if the trailer is not parked, a forward stage repositions and another
reverse stage follows, up to ``max_stages``. Every stage starts and ends at standstill: the
car brakes to a stop, then the steer is set to what the next stage wants before it moves
(those samples are recorded and their time counts). Success is judged on the true state.

A process (:class:`~.stages.Process`) chooses the stages: the staged one alternates them as above;
the planned one (:mod:`.planned`, the default with the full-model NMPC) plans a path among the
obstacles, tracks it under a guard that stops the car near the scene, and plans again when it must.
Obstacles and an area (a :class:`~hitchpark.model.scene.Scene`) are also checked at the end, on the
whole true motion of the real car (:func:`~hitchpark.model.collision.swept_clearance`): a maneuver that
came closer to them than ``success.min_clearance_m`` (or touched them, or left the area) fails with
the outcome ``collision``.
"""

from __future__ import annotations

from dataclasses import replace

from ..checks import InputError, check_flag, check_instance, check_text
from ..control.estimator import Estimator
from ..control.guard import CLEARANCE_SPARE_M
from ..control.nmpc import FullNMPC, TrailerNMPC, make_nmpc
from ..model.plant import Plant, PlantSettings
from ..model.scene import Scene
from ..model.state import Pose, State, check_goal, check_state
from ..model.vehicle import VehicleTrailer, check_vehicle
from .judge import is_parked, not_started, stage_result, verdict
from .loop import SETTLE_TOLERANCE, Clock, ClosedLoop, run_stage
from .planned import PlannedProcess
from .predictions import Predictions
from .result import ManeuverResult, Outcome, PlanRecord, StageResult
from .settings import ManeuverSettings, SuccessCriteria
from .stages import Ending, Process, StagedProcess, make_stages

__all__ = ["SETTLE_TOLERANCE", "Clock", "park"]


def direction_segments_of(stages: list[StageResult]) -> int:
    """Direction segments driven: stages in a row of the same kind count once (the success limit counts these)."""
    return sum(1 for i, st in enumerate(stages) if i == 0 or st.kind != stages[i - 1].kind)


def predicted_clearance_m(settings: ManeuverSettings) -> float:
    """How far the planned process's NMPC keeps its predicted bodies from the scene [m] (the obstacle OCP,
    :meth:`~hitchpark.control.nmpc.FullNMPC.keep_clear`): what the guard asks, and
    :data:`~hitchpark.control.guard.CLEARANCE_SPARE_M`."""
    return settings.success.min_clearance_m + settings.process.guard_margin_m + CLEARANCE_SPARE_M


def make_process(
    vehicle: VehicleTrailer,
    settings: ManeuverSettings,
    scene: Scene,
    nmpc: TrailerNMPC | FullNMPC | None,
    delay: int,
) -> Process:
    """The process ``settings.process`` names (``auto``: planned with the full NMPC, staged with the paper's)."""
    nmpc = nmpc or make_nmpc(vehicle, settings.nmpc)
    planned = settings.process.resolved(settings.nmpc.kind) == "planned"
    if isinstance(nmpc, FullNMPC):
        # The planned process keeps the NMPC's predictions as clear of the scene as its guard asks (the
        # obstacle OCP); the staged one does not see the scene.
        nmpc.keep_clear(scene if planned else Scene(), predicted_clearance_m(settings))
    if planned:
        return PlannedProcess(vehicle, settings, scene, nmpc, delay)
    return StagedProcess(make_stages(vehicle, settings, nmpc), hand_over=settings.nmpc.kind != "paper")


def park(
    vehicle: VehicleTrailer,
    start: State,
    goal: Pose | None = None,
    settings: ManeuverSettings | None = None,
    name: str = "",
    controller: TrailerNMPC | FullNMPC | None = None,
    plant: PlantSettings | None = None,
    scene: Scene | None = None,
    clock: Clock | None = None,
    predictions: bool = False,
) -> ManeuverResult:
    """Park the trailer at ``goal`` from ``start``: reverse, and forward and reverse again as needed (Fig. 7).

    Parameters
    ----------
    vehicle : VehicleTrailer
        The controller's model of the combination (L_H > 0).
    start : State
        True start trailer-axle pose and hitch angle (world frame); the car stands, wheels straight.
    goal : Pose
        Goal trailer-axle pose (default: the origin, heading +x).
    settings : ManeuverSettings
        NMPC, forward stage and success settings; ``settings.nmpc.kind`` picks the process.
    controller : TrailerNMPC or FullNMPC, optional
        A ready reverse controller to reuse (built for ``vehicle`` and ``settings.nmpc``); building one
        compiles the NLP, so batch runs pass their own. It serves any goal.
    plant : PlantSettings
        The car driven (default: the realistic car, :class:`PlantSettings`); its lengths may differ
        from ``vehicle``'s.
    scene : Scene
        Obstacles and an area, world frame (default: none). The planned process avoids them; the staged
        one does not see them. Checked on the true motion at the end, against
        ``settings.success.min_clearance_m`` (outcome ``collision`` if closer).
    clock : Clock, optional
        Paces the loop (``hitchpark realtime``: a wall-clock tick); default: as fast as it runs.
    predictions : bool
        Record the NMPC's predicted trailer-axle path at each row (:mod:`.predictions`, ``result.predictions``;
        saved in ``maneuver.json``); off by default. The maneuver is the same either way.

    Returns
    -------
    ManeuverResult
        ``success``, ``reason`` (an :class:`Outcome` value) and ``detail``, the stages, the trajectory
        and the scene.
    """
    goal, settings, plant, scene = _checked(vehicle, start, goal, settings, name, controller, plant, scene, clock)
    car = Plant(plant, vehicle, start, settings.nmpc.dt)
    crit = settings.success
    loop = ClosedLoop(
        car, goal, plant.delay_steps, crit.max_time, vehicle.max_steer_rate, vehicle.max_accel, clock=clock
    )
    if settings.estimator.filters:
        loop.estimator = Estimator(vehicle, settings.estimator, settings.nmpc.dt)
    loop.predictions = [] if check_flag("predictions", predictions) else None
    process = make_process(vehicle, settings, scene, controller, plant.delay_steps)
    stages, ending = _drive(loop, process, crit)
    if not stages:  # the process ended before any stage (no path from the start): one row, standing
        stages.append(not_started(goal, car.state.as_array()))
    if ending is not None and loop.outcome is None:
        loop.outcome, loop.detail = ending.outcome, ending.detail
    loop.final_row(len(stages) - 1)
    traj = loop.trajectory()
    success, outcome, detail, swept = verdict(loop, traj, scene, crit)
    plans = tuple(PlanRecord.of(p) for p in process.plans)
    result = ManeuverResult(
        vehicle, start, goal, settings, success, outcome.value, tuple(stages), traj, name, plant, detail, scene, plans
    )
    if loop.predictions is not None:
        result = replace(result, predictions=Predictions.of(loop.predictions))
    if swept is not None:
        result.__dict__["swept"] = swept  # the cached property's value: computed once per maneuver
    return result


def _drive(loop: ClosedLoop, process: Process, crit: SuccessCriteria) -> tuple[list[StageResult], Ending | None]:
    """Run the stages the process gives until the maneuver ends (:mod:`.judge` states the order); the stages'
    records, and the process's ending if it ended it."""
    stages: list[StageResult] = []
    clock = loop.clock
    stage = process.first(loop.sense(), loop.goal)
    if clock is not None:
        clock.restart()
    while not isinstance(stage, Ending):
        first = len(loop.states)
        ended = run_stage(loop, len(stages), stage)
        stages.append(stage_result(stage, ended, loop, first))
        if loop.outcome is not None:
            return stages, None
        if stage.kind == "reverse" and is_parked(loop, crit):
            loop.outcome = Outcome.PARKED
            return stages, None
        upcoming = process.next(loop.sense(), loop.goal, ended)
        if clock is not None:
            clock.restart()
        turns = not isinstance(upcoming, Ending) and upcoming.kind != stage.kind
        if turns and direction_segments_of(stages) >= crit.max_stages:
            loop.outcome = Outcome.MAX_STAGES
            return stages, None
        stage = upcoming
    return stages, stage


def _checked(
    vehicle: VehicleTrailer,
    start: State,
    goal: Pose | None,
    settings: ManeuverSettings | None,
    name: str,
    controller: TrailerNMPC | FullNMPC | None,
    plant: PlantSettings | None,
    scene: Scene | None,
    clock: Clock | None,
) -> tuple[Pose, ManeuverSettings, PlantSettings, Scene]:
    """:func:`park`'s arguments checked, with the defaults of those not given."""
    check_vehicle(vehicle).require_hitch_offset()
    check_state(vehicle, start)
    goal = check_goal(goal)
    settings = ManeuverSettings() if settings is None else settings
    check_instance("settings", settings, ManeuverSettings, "hitchpark.maneuver.ManeuverSettings(...)")
    plant = PlantSettings() if plant is None else plant
    check_instance("plant", plant, PlantSettings, "hitchpark.PlantSettings(...)")
    check_text("name", name, max_length=200)
    scene = Scene() if scene is None else scene
    check_instance("scene", scene, Scene, "hitchpark.model.Scene(obstacles, area)")
    if clock is not None and not all(callable(getattr(clock, m, None)) for m in ("tick", "restart")):
        raise InputError(f"clock must have tick() and restart() methods, got {type(clock).__name__}")
    if controller is not None:
        check_instance("controller", controller, (TrailerNMPC, FullNMPC))
    if controller is not None and (controller.vehicle, controller.settings) != (vehicle, settings.nmpc):
        raise InputError("controller was built for another vehicle or NMPC settings than this maneuver")
    return goal, settings, plant, scene
