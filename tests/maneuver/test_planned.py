"""The planned process (maneuver.planned): plan, track, hand over to the NMPC; no path; records."""

from __future__ import annotations

import itertools
import json
import math
import os

import numpy as np
import pytest

from hitchpark.checks import InputError
from hitchpark.control.guard import CLEARANCE_SPARE_M, Guard
from hitchpark.control.nmpc import FullNMPC, make_nmpc
from hitchpark.io import to_jsonable
from hitchpark.maneuver import ManeuverResult, ManeuverSettings, ProcessSettings, park
from hitchpark.maneuver.process import direction_segments_of
from hitchpark.maneuver.result import StageResult
from hitchpark.maneuver.stages import GuardedStage, ReverseStage
from hitchpark.model import VehicleTrailer
from hitchpark.model.plant import Measurement
from hitchpark.model.scene import Obstacle, Scene
from hitchpark.model.state import Pose, State
from hitchpark.ocp.reference import PathReference
from hitchpark.ocp.settings import NMPCSettings

V = VehicleTrailer()


@pytest.fixture(scope="module")
def planned():
    return park(V, State(10.0, 3.0, 0.3, 0.0))


@pytest.mark.slow
def test_a_planned_maneuver_parks_and_records_its_plans(planned):
    r = planned
    assert r.success, r.detail
    assert r.plans and r.plans[0].status == "found" and r.planning_s > 0
    assert {s.controller for s in r.stages} <= {"tracking", "nmpc"}
    assert r.stages[-1].controller == "nmpc" and r.stages[-1].kind == "reverse"
    tr = r.trajectory
    assert np.all(np.abs(tr["front_steer"]) <= V.max_steer) and np.all(np.abs(tr["hitch"]) <= V.max_hitch)
    rates = np.abs(np.diff(tr["front_steer_cmd"])) / np.diff(tr["t"])
    assert np.all(rates <= V.max_steer_rate + 1e-9)


def test_the_nmpc_tracks_the_whole_last_reverse_segment_to_the_goal(planned):
    r = planned
    last = r.stages[-1]
    assert last.controller == "nmpc" and all(s.controller == "tracking" for s in r.stages[:-1])
    path = r.plans[-1].path
    forward = np.flatnonzero(path["direction"] > 0)
    start = int(forward[-1]) if len(forward) else 0  # where the last reverse segment begins
    planned_xy = np.column_stack([path["x_trailer"], path["y_trailer"]])[start:]
    planned_xy = np.vstack([planned_xy, [[0.0, 0.0]]])  # the line from the plan's end to the goal
    rows = slice(last.first_row, last.last_row + 1)
    x, y = r.trajectory["x_trailer"][rows], r.trajectory["y_trailer"][rows]
    dense = np.vstack([np.linspace(a, b, 20) for a, b in itertools.pairwise(planned_xy)])
    gaps = np.min(np.hypot(x[:, None] - dense[None, :, 0], y[:, None] - dense[None, :, 1]), axis=1)
    assert gaps.max() < ManeuverSettings().tracking.max_deviation_m
    assert abs(last.distance_error_m) < 0.05


def test_without_nmpc_tracking_pure_pursuit_hands_the_last_metres_to_the_nmpc():
    settings = ManeuverSettings(process=ProcessSettings(nmpc_tracking=False))
    r = park(V, State(10.0, 3.0, 0.3, 0.0), settings=settings)
    assert r.success, r.detail
    assert [s.controller for s in r.stages][-2:] == ["tracking", "nmpc"]


def test_a_tracking_stage_stops_and_gives_up_when_the_car_strays_from_the_path():
    nmpc = make_nmpc(V, NMPCSettings(kind="full"))
    s = nmpc.settings
    path = np.column_stack([np.linspace(8.0, 1.0, 50), np.full(50, 1.0), np.zeros(50), np.zeros(50)])  # 1 m aside
    reference = PathReference(path, Pose(), 0.6, V.max_accel, s.prediction_dt, s.horizon)
    stage = ReverseStage(nmpc, reference, max_deviation_m=0.35)
    m = Measurement(0.0, State(8.0, 0.0, 0.0, 0.0), 0.0, 0.0)
    stage.begin(m, Pose())
    step = stage.act(m, Pose(), ())
    assert not step.ok and step.stop and step.rear_speed == 0.0 and "deviated" in step.status


def test_only_the_full_nmpc_tracks_a_path_and_with_its_own_horizon():
    path = np.column_stack([np.linspace(8.0, 1.0, 50), np.zeros((50, 3))])
    with pytest.raises(InputError, match="full"):
        ReverseStage(make_nmpc(V, NMPCSettings(kind="paper")), PathReference(path, Pose(), 0.6, 1.0, 0.3, 10))
    nmpc = make_nmpc(V, NMPCSettings(kind="full"))
    assert isinstance(nmpc, FullNMPC)
    with pytest.raises(InputError, match="horizon"):
        nmpc.follow(PathReference(path, Pose(), 0.6, 1.0, 0.3, 7))


def test_a_planned_maneuver_round_trips_through_json(planned):
    data = json.loads(json.dumps(to_jsonable(planned.to_dict())))
    assert data["planning_s"] == pytest.approx(planned.planning_s)
    assert data["direction_switches"] == planned.direction_switches
    back = ManeuverResult.from_dict(data)
    assert back.plans[0].status == planned.plans[0].status
    for column, values in planned.plans[0].path.items():
        np.testing.assert_allclose(back.plans[0].path[column], values)
    assert [s.controller for s in back.stages] == [s.controller for s in planned.stages]


def test_a_start_on_the_goal_line_reverses_straight_in_without_a_plan():
    r = park(V, State(5.0, 0.0, 0.0, 0.0))
    assert r.success and r.plans == () and r.direction_switches == 0
    assert {s.kind for s in r.stages} == {"reverse"}


def test_a_blocked_goal_ends_as_no_path_with_the_car_standing():
    box = Obstacle("crate on the goal", ((-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)))
    r = park(V, State(10.0, 3.0, 0.3, 0.0), scene=Scene((box,)))
    assert not r.success and r.reason == "no_path" and "planner" in r.detail
    assert len(r.trajectory) == 1 and r.trajectory["rear_speed"][0] == 0.0
    assert r.plans[0].status == "no_path"


def test_the_staged_process_is_still_there():
    r = park(V, State(10.0, 3.0, 0.3, 0.0), settings=ManeuverSettings(process=ProcessSettings(kind="staged")))
    assert r.plans == () and r.stages[0].controller == "nmpc"


def test_stages_in_a_row_of_one_direction_count_as_one_segment():
    def stage(kind: str) -> StageResult:
        return StageResult(kind, 1, 0.0, 0.0, 0.0, 0, 1, "", "tracking")

    assert direction_segments_of([stage("reverse"), stage("reverse")]) == 1
    assert direction_segments_of([stage("forward"), stage("reverse"), stage("reverse"), stage("forward")]) == 3


def test_process_settings_read_from_a_table():
    s = ManeuverSettings.from_dict({"process": {"kind": "staged", "approach_m": 4.0}, "tracking": {"speed": 0.5}})
    assert s.process.kind == "staged" and s.process.approach_m == 4.0 and s.tracking.speed == 0.5
    assert ManeuverSettings.from_dict(s.to_dict()) == s
    assert math.isclose(ManeuverSettings().process.handover_m, 4.0)
    assert Pose() == Pose(0.0, 0.0, 0.0)


@pytest.mark.slow
def test_the_campsite_scene_parks_clear_of_the_trees(request):
    from hitchpark.maneuver.scenario import builtin_scenario

    sc = builtin_scenario("campsite")
    if os.environ.get("HITCHPARK_JIT") == "0":  # the suite's setting: the maneuver the solver tests record, parked
        _, r, _ = request.getfixturevalue("campsite_recorded")  # once a run (recording it changes nothing)
    else:
        r = park(sc.vehicle, sc.start, sc.goal, sc.settings, plant=sc.plant, scene=sc.scene)
    assert r.success, r.detail
    assert not r.collision and r.min_clearance_m >= sc.settings.success.min_clearance_m
    assert r.plans and r.plans[-1].status == "found"


@pytest.mark.slow
def test_a_guard_stop_before_the_nmpc_moves_plans_again_where_a_solver_failure_ends():
    """The guard stopping the NMPC at its first step (its prediction too near the scene) is a reason to plan from
    where the car stands, as any guard stop; the NMPC failing to solve there ends the maneuver."""
    from hitchpark.maneuver.planned import PlannedProcess
    from hitchpark.maneuver.result import Outcome
    from hitchpark.maneuver.stages import Ending, StageEnd

    settings = ManeuverSettings()
    post = Obstacle("post", ((30.0, 20.0), (30.5, 20.0), (30.5, 20.5), (30.0, 20.5)))
    process = PlannedProcess(V, settings, Scene((post,)), make_nmpc(V, settings.nmpc), 0)
    m, goal = Measurement(0.0, State(10.0, 3.0, 0.3, 0.0), 0.0, 0.0), Pose()
    assert not isinstance(process.first(m, goal), Ending) and process.rounds == 1
    guarded = StageEnd("reverse", "nmpc", "guard: too close", failed=True, status="guard: too close: 0.2 m ahead")
    assert not isinstance(process.next(m, goal, guarded), Ending) and process.rounds == 2
    failed = StageEnd("reverse", "nmpc", "solver: infeasible", failed=True, status="Infeasible_Problem_Detected")
    ended = process.next(m, goal, failed)
    assert isinstance(ended, Ending) and ended.outcome is Outcome.SOLVER


def test_guard_stops_before_moving_on_the_straight_approach_end_the_maneuver():
    """On the goal line no plan is made (no round counted): stopped there before it moves, again and again, the
    process gives up after ``max_replans`` such stops instead of handing out the same stage for ever."""
    from hitchpark.maneuver.planned import PlannedProcess
    from hitchpark.maneuver.result import Outcome
    from hitchpark.maneuver.stages import Ending, StageEnd

    settings = ManeuverSettings()
    post = Obstacle("post", ((30.0, 20.0), (30.5, 20.0), (30.5, 20.5), (30.0, 20.5)))
    process = PlannedProcess(V, settings, Scene((post,)), make_nmpc(V, settings.nmpc), 0)
    m, goal = Measurement(0.0, State(2.0, 0.0, 0.0, 0.0), 0.0, 0.0), Pose()
    assert not isinstance(process.first(m, goal), Ending)
    stopped = StageEnd("reverse", "nmpc", "guard: too close", failed=True, status="guard: too close: 0.2 m ahead")
    outcomes = [process.next(m, goal, stopped) for _ in range(settings.process.max_replans + 1)]
    assert not any(isinstance(o, Ending) for o in outcomes[:-1])
    assert isinstance(outcomes[-1], Ending) and outcomes[-1].outcome is Outcome.NO_PATH
    assert "before it moved" in outcomes[-1].detail and process.rounds == 0


def test_a_search_that_finds_nothing_records_and_draws_where_it_got_stuck():
    """no_path with a tiny budget: each failed plan keeps the configuration its search reached nearest the goal (the
    one its detail names), the record round-trips it, and the motion figure marks it."""
    from dataclasses import replace

    from hitchpark.maneuver.scenario import builtin_scenario
    from hitchpark.viz.figures import motion_figure

    sc = builtin_scenario("loading_dock")
    settings = replace(sc.settings, planner=replace(sc.settings.planner, max_expansions=5, shot_length_m=0.0))
    r = park(sc.vehicle, State(25.2, 7.0, math.radians(90.0), 0.0), sc.goal, settings, scene=sc.scene)
    assert r.reason == "no_path"
    stuck = [p for p in r.plans if p.closest is not None]
    assert stuck and all(p.status == "no_path" for p in stuck)
    for p in stuck:
        x, y = p.closest[:2]
        assert f"closest: trailer axle at ({x:.2f}, {y:.2f}) m" in p.detail
    back = ManeuverResult.from_dict(json.loads(json.dumps(to_jsonable(r.to_dict()))))
    assert [p.closest for p in back.plans] == [p.closest for p in r.plans]
    import matplotlib.pyplot as plt

    figure = motion_figure(r)
    try:
        texts = [t.get_text() for ax in figure.axes for t in ax.texts]
    finally:
        plt.close(figure)  # no figure left open for the tests after
    assert texts.count("search stuck here") >= len(stuck)
    with pytest.raises(InputError, match="4 numbers"):
        ManeuverResult.from_dict({**back.to_dict(), "plans": [{**back.plans[0].to_dict(), "closest": [1.0, 2.0]}]})


def test_a_guarded_reverse_stage_keeps_the_doubts_share_of_the_clearance_in_its_predictions():
    """The guard allows for the estimate's doubt; the NMPC's predictions (the estimate's clearance) then keep the
    guard's clearance, the doubt's share at the measured configuration, and the spare, or the NMPC plans what the
    guard stops. Without a doubt the stage keeps keep_clear's clearance, as before."""
    side = Obstacle("wall", np.array([[-20.0, 3.0], [20.0, 3.0], [20.0, 4.0], [-20.0, 4.0]]))
    back = Obstacle("back wall", np.array([[-9.0, -20.0], [-8.0, -20.0], [-8.0, 2.0], [-9.0, 2.0]]))
    wall = Scene((side, back))
    nmpc = FullNMPC(V, NMPCSettings(jit=False))
    nmpc.keep_clear(wall, 0.24)
    guard = Guard(V, wall, 0.2, 0.03, 0.1, 1)
    stage = GuardedStage(ReverseStage(nmpc), guard)
    sure = Measurement(0.0, State(6.0, 1.0, 0.0, 0.0), 0.0, 0.0)
    stage.begin(sure, Pose())
    assert nmpc.clearance_m == 0.24 and guard.doubt_gap(sure)[1] == 0.0
    doubtful = Measurement(0.0, sure.state, 0.0, 0.0, (0.0, 0.0, 0.0, math.radians(1.0)))
    stage.begin(doubtful, Pose())
    now, gap = guard.doubt_gap(doubtful)
    s = sure.state
    estimated, least = guard.clearances(np.array([[s.x, s.y, s.yaw, s.hitch]]), doubtful.doubt)
    assert now == estimated[0] and gap == pytest.approx(estimated[0] - least[0]) and gap > 0.02  # cm at the corners
    assert nmpc.clearance_m == pytest.approx(guard.stage_need + gap + CLEARANCE_SPARE_M)
    step = stage.act(doubtful, Pose(), ())
    assert step.ok and step.rear_speed < 0.0
    # Where the trailer (whose pose is exact) is the body nearest the scene, the doubt takes nothing: the stage's own.
    by_the_back = Measurement(0.1, State(-6.5, -2.0, 0.0, 0.0), 0.0, -0.1, doubtful.doubt)
    assert guard.doubt_gap(by_the_back)[1] == 0.0
    stage.act(by_the_back, Pose(), ())
    assert nmpc.clearance_m == pytest.approx(guard.stage_need + CLEARANCE_SPARE_M)
    # Begun with 0.21 m as doubted (the guard keeps min_clearance_m, 0.2): the share would ask all it has, and the
    # stage keeps what it began with less the spare.
    near = Measurement(0.0, State(6.0, 1.0 + now - (0.21 + gap), 0.0, 0.0), 0.0, 0.0, doubtful.doubt)
    stage.begin(near, Pose())
    began, share = guard.doubt_gap(near)
    assert guard.stage_need == guard.floor and began - share == pytest.approx(0.21)
    assert nmpc.clearance_m == pytest.approx(began - CLEARANCE_SPARE_M)
    assert nmpc.clearance_m < guard.stage_need + share + CLEARANCE_SPARE_M
