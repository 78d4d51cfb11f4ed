"""The optimised end-game (hitchpark.planning.refine): exactly at the goal, on the full model, within
every limit, clear of the scene, and the searched path kept when no refined one will do."""

from __future__ import annotations

import math
import re
from dataclasses import replace

import numpy as np
import pytest

from hitchpark.checks import InputError
from hitchpark.maneuver.scenario import builtin_scenario
from hitchpark.model import Pose, VehicleTrailer
from hitchpark.model.collision import swept_clearance
from hitchpark.model.integrate import step_full
from hitchpark.model.scene import Scene
from hitchpark.model.state import State, to_goal_frame
from hitchpark.planning import PlannerSettings, plan
from hitchpark.planning.refine import CHECK_STEP_M, refine_end

VEHICLE = VehicleTrailer()
SETTINGS = PlannerSettings(max_expansions=50_000)  # generous: tests assert behaviour, never timings
HITCH_LIMIT = VEHICLE.max_hitch - SETTINGS.hitch_margin


def _end_in_goal_frame(result, goal: Pose) -> np.ndarray:
    p = result.path
    gx, gy, gyaw = to_goal_frame(goal, p["x_trailer"][-1], p["y_trailer"][-1], p["yaw_trailer"][-1])
    return np.array([gx, gy, gyaw, p["hitch"][-1], p["front_steer"][-1]])


def _check_refined_run(path: dict, first: int) -> None:
    """From row ``first`` on: the full model at 1 m/s in reverse under the recorded steer, every limit kept."""
    steer, t = path["front_steer"], path["t"]
    states = np.column_stack([path[k] for k in ("x_trailer", "y_trailer", "yaw_trailer", "hitch")])
    assert np.all(path["direction"][first + 1 :] == -1.0)
    assert np.all(np.abs(steer) <= VEHICLE.max_steer)
    assert np.all(np.abs(path["hitch"]) <= HITCH_LIMIT)
    rate = np.abs(np.diff(steer[first:])) / np.diff(t[first:])
    assert np.all(rate <= VEHICLE.max_steer_rate + 1e-9)
    errors = [
        np.abs(
            step_full(VEHICLE, states[i], -1.0, 0.5 * (steer[i] + steer[i + 1]), t[i + 1] - t[i]) - states[i + 1]
        ).max()
        for i in range(first, len(t) - 1)
    ]
    assert max(errors) < 3e-3  # the steer ramps within a row: the mean steer is exact to second order


@pytest.mark.parametrize(
    "start",
    [State(12.0, 2.0, math.radians(25.0), math.radians(-10.0)), State(9.0, -3.0, math.radians(-60.0), 0.2)],
)
def test_an_open_space_path_ends_exactly_at_the_goal_settled(start):
    goal = Pose(1.0, -2.0, math.radians(30.0))
    world = Pose(goal.x, goal.y, goal.yaw)
    s = State(*to_world(goal, start))
    refined = plan(VEHICLE, s, world, Scene(), SETTINGS)
    assert refined.found and refined.detail.endswith("its end refined to end at the goal")
    end = _end_in_goal_frame(refined, world)
    assert np.allclose(end, 0.0, atol=1e-6)  # pose, hitch and steer: at the goal, at rest
    # The last metre is the straight stretch along the goal line.
    p = refined.path
    last = p["t"] >= p["t"][-1] - 1.0 + 1e-9
    assert np.allclose(p["hitch"][last], 0.0, atol=1e-9) and np.allclose(p["front_steer"][last], 0.0, atol=1e-9)
    forward = np.flatnonzero(p["direction"] > 0)
    _check_refined_run(p, int(forward[-1]) if len(forward) else 0)
    assert refined.length_m == pytest.approx(p["s"][-1])
    # Without the refinement the search stops within the tolerance, not at the goal.
    searched = plan(VEHICLE, s, world, Scene(), replace(SETTINGS, refine_m=0.0))
    assert searched.found and np.max(np.abs(_end_in_goal_frame(searched, world)[:4])) > 1e-4


def to_world(goal: Pose, start: State) -> tuple[float, float, float, float]:
    """A goal-frame start moved into the world frame of ``goal``."""
    c, s = math.cos(goal.yaw), math.sin(goal.yaw)
    return goal.x + c * start.x - s * start.y, goal.y + s * start.x + c * start.y, start.yaw + goal.yaw, start.hitch


def test_among_obstacles_the_refined_end_keeps_the_clearance():
    """curb_parallel: its goal keeps 0.425 m from the curb and the parked cars; the refined path reaches it
    and keeps the planner's clearance over the continuous motion."""
    sc = builtin_scenario("curb_parallel")
    # The file's generous time limit, not the scene's 5 s (about twice this search on an idle machine): the
    # outcome must not depend on the machine's load.
    settings = replace(sc.settings.planner, min_clearance_m=0.3, max_expansions=SETTINGS.max_expansions)
    result = plan(sc.vehicle, sc.start, sc.goal, sc.scene, settings)
    assert result.found and "its end refined" in result.detail
    assert np.allclose(_end_in_goal_frame(result, sc.goal)[:4], 0.0, atol=1e-6)
    kept, _ = swept_clearance(sc.vehicle, sc.scene, result.states, max_step_m=CHECK_STEP_M)
    assert kept >= settings.min_clearance_m - CHECK_STEP_M / 2


def test_an_end_out_of_reach_is_none():
    """A 1 m run that ends 3 m short of the goal cannot reach it within the refined length's range."""
    s = np.linspace(0.0, 1.0, 11)
    configs = np.column_stack([4.0 - s, np.zeros_like(s), np.zeros_like(s), np.zeros_like(s)])
    assert refine_end(VEHICLE, configs, np.zeros(11), 1.0, Pose(), (0.0, 0.0), HITCH_LIMIT) is None


def test_a_goal_line_end_lands_on_the_line():
    """With a goal line (from, to), the refined run ends on it, then its straight stretch."""
    s = np.linspace(0.0, 8.0, 81)
    configs = np.column_stack([11.0 - s, 0.2 * (1 - s / 8.0), np.zeros_like(s), np.zeros_like(s)])
    out = refine_end(VEHICLE, configs, np.zeros(81), 8.0, Pose(), (2.0, 3.0), HITCH_LIMIT, settle=1.0)
    assert out is not None
    rows, steer, driven = out
    assert 2.0 - 1e-6 <= rows[-1, 0] <= 3.0 + 1e-6  # on the line's stretch, 2 to 3 m out
    straight = driven >= driven[-1] - 1.0 - 1e-9  # the last metre: straight along the line
    assert np.allclose(rows[straight, 1:], 0.0, atol=1e-6) and np.allclose(steer[1:][straight], 0.0, atol=1e-9)
    assert rows[straight, 0][0] == pytest.approx(rows[-1, 0] + 1.0, abs=0.2)
    assert len(steer) == len(rows) + 1 and len(driven) == len(rows)
    assert np.all(np.diff(driven) > 0.0)


@pytest.mark.parametrize("solver", ["fatrop", "ipopt"])
def test_an_end_that_cannot_be_refined_keeps_the_searched_path(solver):
    """0.88 m off the goal line 7 m out: the searched run lands in the tolerance with the steer at 43 deg,
    and no run from there settles exactly at the goal within the limits (infeasible, by either solver). The
    plan is the searched one, and says so."""
    start = State(7.058, -0.879, 0.0143, 0.056)
    refined = plan(VEHICLE, start, Pose(), Scene(), replace(SETTINGS, refine_solver=solver))
    searched = plan(VEHICLE, start, Pose(), Scene(), replace(SETTINGS, refine_m=0.0))
    assert refined.found and f"its end not refined ({solver} found no path ending at the goal)" in refined.detail
    for name, column in searched.path.items():
        np.testing.assert_array_equal(refined.path[name], column)


@pytest.mark.parametrize(
    "start",
    [State(12.0, 2.0, math.radians(25.0), math.radians(-10.0)), State(14.0, -4.0, math.radians(-30.0), 0.1)],
)
def test_fatrop_and_ipopt_refine_to_the_same_path(start):
    """The default solver of the refinement NLP (fatrop, on its stages) and the reference (IPOPT) reach the
    same optimum: the same rows to well within a millimetre, each within every limit."""
    paths = {}
    for solver in ("fatrop", "ipopt"):
        result = plan(VEHICLE, start, Pose(), Scene(), replace(SETTINGS, refine_solver=solver))
        assert result.found and result.detail.endswith("its end refined to end at the goal")
        first = int(np.flatnonzero(result.path["direction"] > 0)[-1]) if np.any(result.path["direction"] > 0) else 0
        _check_refined_run(result.path, first)
        paths[solver] = result.path
    assert len(paths["fatrop"]["s"]) == len(paths["ipopt"]["s"])
    for name in ("x_trailer", "y_trailer", "yaw_trailer", "hitch", "front_steer", "t"):
        np.testing.assert_allclose(paths["fatrop"][name], paths["ipopt"][name], atol=1e-5)


def test_an_unknown_refine_solver_is_refused():
    with pytest.raises(InputError, match=re.escape("planner.refine_solver must be one of 'fatrop', 'ipopt', got 'qp'")):
        PlannerSettings(refine_solver="qp")
