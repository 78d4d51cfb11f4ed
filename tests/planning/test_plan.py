"""The Hybrid A* planner (hitchpark.planning): limits along every path, clearance, the three outcomes."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from hitchpark.checks import InputError
from hitchpark.control.pure_pursuit import forward_steer_limit
from hitchpark.maneuver.scenario import builtin_scenario
from hitchpark.model import Pose, VehicleTrailer
from hitchpark.model.collision import swept_clearance
from hitchpark.model.integrate import step_full
from hitchpark.model.scene import Obstacle, Scene
from hitchpark.model.state import State, to_goal_frame
from hitchpark.planning import PATH_COLUMNS, Plan, PlannerSettings, plan

VEHICLE = VehicleTrailer()
SETTINGS = PlannerSettings(max_expansions=50_000)  # generous: tests assert behaviour, never timings


def box(x0: float, y0: float, x1: float, y1: float) -> list[list[float]]:
    return [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]


#: A bay: walls on both sides of the goal and behind it, open towards +x.
BAY = Scene(
    (
        Obstacle("left wall", box(-3.0, 2.0, 6.0, 2.3)),
        Obstacle("right wall", box(-3.0, -2.3, 6.0, -2.0)),
        Obstacle("back wall", box(-3.3, -2.3, -3.0, 2.3)),
        Obstacle("post", box(9.0, 5.0, 9.5, 5.5)),
    )
)


def check_path(result: Plan, vehicle: VehicleTrailer, settings: PlannerSettings, goal: Pose) -> None:
    """Every limit of the planner along a found path, and its end within the goal tolerance."""
    assert result.status == "found", result.detail
    path = result.path
    assert set(path) == set(PATH_COLUMNS)
    n = len(path["s"])
    assert n >= 2
    for name in PATH_COLUMNS:
        assert path[name].shape == (n,)
        assert np.all(np.isfinite(path[name])), name
    assert np.all(np.diff(path["s"]) >= 0.0)
    assert np.all(np.diff(path["t"]) > 0.0)
    assert path["s"][-1] == pytest.approx(result.length_m)
    steer, direction = path["front_steer"], path["direction"]
    assert set(np.unique(direction)) <= {-1.0, 1.0}
    assert np.all(np.abs(steer) <= vehicle.max_steer + 1e-12)
    assert np.all(np.abs(steer[direction > 0]) <= forward_steer_limit(vehicle) + 1e-12)
    assert np.all(np.abs(path["hitch"]) <= vehicle.max_hitch - settings.hitch_margin + 1e-12)
    # Within a direction the steer moves at most max_steer_rate (1 m/s: t in seconds).
    same = direction[1:] == direction[:-1]
    rate = np.abs(np.diff(steer)) / np.diff(path["t"])
    assert np.all(rate[same] <= vehicle.max_steer_rate + 1e-9)
    assert result.direction_switches == int(np.count_nonzero(~same))
    # Ends within the tolerance of the goal.
    gx, gy, gyaw = to_goal_frame(goal, path["x_trailer"][-1], path["y_trailer"][-1], path["yaw_trailer"][-1])
    assert math.hypot(gx, gy) <= settings.goal_tolerance_m
    assert abs(gyaw) <= settings.goal_tolerance_yaw
    assert abs(path["hitch"][-1]) <= settings.goal_tolerance_hitch


def test_straight_in_front_of_the_goal_is_one_reverse_segment():
    result = plan(VEHICLE, State(10.0, 0.0, 0.0, 0.0), Pose(), Scene(), SETTINGS)
    check_path(result, VEHICLE, SETTINGS, Pose())
    assert result.direction_switches == 0
    assert np.all(result.path["direction"] == -1.0)
    assert result.length_m == pytest.approx(10.0, abs=SETTINGS.goal_tolerance_m + 0.1)


def test_the_path_follows_the_full_model():
    """Each step of the path is the full model (Eqs. 19-24) at 1 m/s under the recorded steer.

    The steer moves within a step (rate-limited towards its command): the reference here holds the mean
    of the step's two steers, which is exact to second order in the step.
    """
    result = plan(VEHICLE, State(8.0, 2.0, math.radians(20.0), math.radians(5.0)), Pose(), Scene(), SETTINGS)
    check_path(result, VEHICLE, SETTINGS, Pose())
    states, path = result.states, result.path
    errors = []
    for i in range(1, len(states)):
        if path["direction"][i] != path["direction"][i - 1]:
            continue
        steer = 0.5 * (path["front_steer"][i] + path["front_steer"][i - 1])
        dt = path["t"][i] - path["t"][i - 1]
        errors.append(np.abs(step_full(VEHICLE, states[i - 1], path["direction"][i], steer, dt) - states[i]).max())
    assert max(errors) < 3e-3
    assert np.median(errors) < 1e-4


@pytest.mark.parametrize(
    "start",
    [
        State(10.0, 3.5, 0.0, 0.0),
        State(6.0, 6.0, math.radians(90.0), 0.0),
        State(12.0, -1.5, math.radians(40.0), math.radians(17.0)),
    ],
)
def test_paths_keep_every_limit(start):
    result = plan(VEHICLE, start, Pose(), Scene(), SETTINGS)
    check_path(result, VEHICLE, SETTINGS, Pose())


def test_among_obstacles_the_path_keeps_the_exact_clearance():
    start = State(11.0, 3.0, math.radians(30.0), 0.0)
    result = plan(VEHICLE, start, Pose(), BAY, SETTINGS)
    check_path(result, VEHICLE, SETTINGS, Pose())
    bound, _ = swept_clearance(VEHICLE, BAY, result.states)
    assert bound >= SETTINGS.min_clearance_m


def test_a_goal_in_the_world_frame():
    goal = Pose(20.0, -5.0, math.radians(135.0))
    c, s = math.cos(goal.yaw), math.sin(goal.yaw)
    start = State(goal.x + 9.0 * c, goal.y + 9.0 * s, goal.yaw, 0.0)  # 9 m straight ahead of the goal
    result = plan(VEHICLE, start, goal, Scene(), SETTINGS)
    check_path(result, VEHICLE, SETTINGS, goal)
    assert result.direction_switches == 0


def test_a_goal_enclosed_by_a_ring_has_no_path():
    ring = (
        Obstacle("south", box(-4.0, -4.0, 4.0, -3.5)),
        Obstacle("east", box(3.5, -4.0, 4.0, 4.0)),
        Obstacle("north", box(-4.0, 3.5, 4.0, 4.0)),
        Obstacle("west", box(-4.0, -4.0, -3.5, 4.0)),
    )
    result = plan(VEHICLE, State(12.0, 0.0, 0.0, 0.0), Pose(), Scene(ring), SETTINGS)
    assert result.status == "no_path"
    assert result.path == {}
    assert result.expanded == 0  # decided before searching


def test_a_goal_inside_an_obstacle_has_no_path():
    scene = Scene((Obstacle("block", box(-1.0, -1.0, 1.0, 1.0)),))
    result = plan(VEHICLE, State(12.0, 0.0, 0.0, 0.0), Pose(), scene, SETTINGS)
    assert result.status == "no_path"


def test_a_start_too_close_to_the_scene_has_no_path():
    scene = Scene((Obstacle("block", box(9.0, 1.0, 11.0, 2.0)),))
    result = plan(VEHICLE, State(10.0, 0.0, 0.0, 0.0), Pose(), scene, SETTINGS)
    assert result.status == "no_path"
    assert "start" in result.detail


def test_a_tiny_safety_net_is_a_planner_timeout():
    settings = PlannerSettings(time_limit_s=1e-6)
    result = plan(VEHICLE, State(10.0, 3.5, 0.0, 0.0), Pose(), Scene(), settings)
    assert result.status == "planner_timeout"
    assert result.path == {}
    assert not result.found


def test_a_spent_budget_is_no_path_with_where_the_search_got_to():
    """The budget is a count: past it, no_path, naming the node nearest the goal and what is nearest to it."""
    sc = builtin_scenario("loading_dock")
    start = State(25.2, 7.0, math.radians(90.0), 0.0)
    settings = replace(sc.settings.planner, min_clearance_m=0.3, max_expansions=5, shot_length_m=0.0)
    result = plan(sc.vehicle, start, sc.goal, sc.scene, settings)
    assert result.status == "no_path" and result.expanded == 5
    assert "budget of 5 expansions" in result.detail and "closest: trailer axle at" in result.detail
    assert " m from obstacles[" in result.detail or "area boundary" in result.detail


@pytest.mark.parametrize(
    "changes",
    [
        {"xy_resolution_m": 0.0},
        {"yaw_bins": 2},
        {"steer_samples": 1.5},
        {"time_limit_s": -1.0},
        {"time_limit_s": math.nan},
        {"goal_tolerance_m": 0.0},
        {"min_clearance_m": -0.1},
        {"weight_switch": "5"},
        {"heuristic_weight": 0.5},
        {"sample_step_m": 0.5, "primitive_length_m": 0.2},
    ],
)
def test_bad_settings_are_refused(changes):
    with pytest.raises(InputError, match=r"planner\."):
        PlannerSettings(**changes)


def test_bad_arguments_are_refused():
    with pytest.raises(InputError):
        plan(VEHICLE, (10.0, 0.0, 0.0, 0.0), Pose(), Scene(), SETTINGS)  # type: ignore[arg-type]
    with pytest.raises(InputError):
        plan(VEHICLE, State(10.0, 0.0, 0.0, 1.5), Pose(), Scene(), SETTINGS)  # past the jackknife limit
    with pytest.raises(InputError):
        plan(VEHICLE, State(10.0, 0.0, 0.0, 0.0), Pose(), Scene(), {"time_limit_s": 1.0})  # type: ignore[arg-type]
    with pytest.raises(InputError):
        plan(VEHICLE, State(10.0, 0.0, 0.0, 0.0), Pose(), "scene", SETTINGS)  # type: ignore[arg-type]


def test_a_start_facing_away_from_the_goal_is_one_bending_reverse_run():
    """The opening's Dubins shot: a single reverse run that bends, every sample within the limits."""
    result = plan(VEHICLE, State(12.0, 4.0, math.radians(30.0), math.radians(10.0)), Pose(), Scene(), SETTINGS)
    check_path(result, VEHICLE, SETTINGS, Pose())
    assert result.direction_switches == 0
    assert np.ptp(result.path["yaw_trailer"]) > math.radians(20.0)  # it bends


def test_a_start_beside_the_goal_pulls_forward_then_reverses_once():
    """Too close to the goal line for a short single reverse: forward, then one reverse run (the opening)."""
    settings = replace(SETTINGS, weight_switch=5.0)
    result = plan(VEHICLE, State(7.2, 6.1, math.radians(2.0), math.radians(20.0)), Pose(), Scene(), settings)
    check_path(result, VEHICLE, settings, Pose())
    assert result.direction_switches == 1
    assert result.path["direction"][0] == 1.0 and result.path["direction"][-1] == -1.0


@pytest.mark.slow
def test_without_end_games_the_search_alone_finds_a_path():
    # A switch at 12 m of path. From beside and ahead of the goal, turned away: two changes of direction
    # in about 8,500 expansions (from 10 m ahead and 1 m aside, three in about 16,000).
    settings = replace(SETTINGS, shot_length_m=0.0, weight_switch=12.0)
    result = plan(VEHICLE, State(16.0, 3.0, -0.2, 0.0), Pose(), Scene(), settings)
    check_path(result, VEHICLE, settings, Pose())
