"""The Hybrid A* planner (hitchpark.planning): limits along every path, clearance, the three outcomes."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from hitchpark.checks import InputError
from hitchpark.control.pure_pursuit import forward_steer_limit
from hitchpark.maneuver.scenario import builtin_scenario
from hitchpark.model import Pose, VehicleTrailer, front_steer_from_virtual, full_rhs
from hitchpark.model.collision import swept_clearance
from hitchpark.model.integrate import step_full
from hitchpark.model.scene import Obstacle, Scene
from hitchpark.model.state import State, to_goal_frame
from hitchpark.planning import PATH_COLUMNS, Plan, PlannerSettings, plan
from hitchpark.planning.dubins import dubins_words, sample_word
from hitchpark.planning.endgame import EndGame
from hitchpark.planning.motion import PrimitiveBatch
from hitchpark.planning.rollouts import PathPursuit, _pursuit_step_function
from hitchpark.planning.settings import arrived

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


def test_a_held_steer_primitive_is_the_plant_model():
    """A forward primitive whose steer starts at its command holds it: RK4 of the full model, as the plant."""
    batch = PrimitiveBatch(VEHICLE, 1.0, 10, 3)
    start = np.array([1.0, -2.0, 0.3, 0.2])
    commands = np.array([-0.4, 0.0, 0.6])
    motions = batch.run(start, commands, commands, np.ones(3))
    for motion, steer in zip(motions, commands, strict=True):
        assert np.all(motion[:, 4] == pytest.approx(steer, abs=1e-12))
        state = start
        for k in range(1, 11):
            state = step_full(VEHICLE, state, 1.0, steer, 0.1)
            assert np.allclose(motion[k, :4], state, atol=1e-6)


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


def test_without_end_games_the_search_alone_finds_a_path():
    # A switch at 12 m of path: the search alone, greedy, takes three times as long at 22 m.
    settings = replace(SETTINGS, shot_length_m=0.0, weight_switch=12.0)
    result = plan(VEHICLE, State(10.0, 1.0, 0.0, 0.0), Pose(), Scene(), settings)
    check_path(result, VEHICLE, settings, Pose())


@pytest.mark.parametrize("seed", [0, 1])
def test_dubins_words_end_at_their_goal(seed):
    rng = np.random.default_rng(seed)
    for _ in range(200):
        start, end, radius = tuple(rng.uniform(-10, 10, 3)), tuple(rng.uniform(-10, 10, 3)), rng.uniform(1, 6)
        words = dubins_words(start, end, radius)
        assert words, "some Dubins word always exists"
        assert [sum(w[1]) for w in words] == sorted(sum(w[1]) for w in words)
        for word, lengths in words:
            last = sample_word(start, word, lengths, radius, 0.1)[-1]
            assert last[:2] == pytest.approx(end[:2], abs=1e-6)
            assert math.remainder(last[2] - end[2], 2 * math.pi) == pytest.approx(0.0, abs=1e-6)


def test_a_pursuit_run_is_held_where_it_first_ended_whether_asked_each_sample_or_in_blocks(monkeypatch):
    """PathPursuit asks ``ended`` about blocks of samples: the runs must be those of asking every sample."""
    runs, step = 5, 0.1
    pursuit = PathPursuit(VEHICLE, step, runs)
    # Straight references behind the start (reverse along -x), offsets across so the runs differ.
    xs = -np.arange(0.0, 12.0, step)
    references = np.stack([np.column_stack([xs, np.full(len(xs), 0.3 * (r - 2))]) for r in range(runs)])
    stops = np.array([-1.0, -3.37, -6.0, -0.55, -20.0])  # the last never stops: its reference ends first
    asked: list[int] = []

    def run() -> np.ndarray:
        start = np.array([0.0, 0.0, 0.0, 0.05, 0.0])
        return pursuit.run(start, references, np.full(runs, 2.0), 0.5, ended_rows)

    def ended_rows(states: np.ndarray, deviation: np.ndarray) -> np.ndarray:
        asked.append(len(states))  # rows: the samples of run 0, then of run 1, ...
        per_run = len(states) // runs
        which = np.repeat(np.arange(runs), per_run)
        return states[:, 0] <= stops[which]

    blocks = run()
    assert max(asked) > runs  # asked about several samples of each run at once
    monkeypatch.setattr(PathPursuit, "CHECK_EVERY", 1)
    asked.clear()
    each = run()
    assert max(asked) == runs
    np.testing.assert_array_equal(blocks, each)
    for r in range(4):  # each stopping run: held from the first sample past its stop on
        first = int(np.argmax(blocks[r, :, 0] <= stops[r]))
        assert first > 0 and np.all(blocks[r, :first, 0] > stops[r])
        np.testing.assert_array_equal(
            blocks[r, first:], np.repeat(blocks[r, first : first + 1], blocks.shape[1] - first, 0)
        )
    assert blocks.shape[1] == len(xs) + PathPursuit.WINDOW + 1  # the last run never ended: to the end of the references


@pytest.mark.parametrize("compiled", [False, True], ids=["casadi", "compiled"])
def test_a_compiled_pursuit_chunk_follows_the_nearest_point_search_done_sample_by_sample(compiled, request):
    """The chunks, compiled to C or in CasADi's virtual machine (the nearest point searched at computed
    indices), give the runs of a plain loop: the nearest of the next WINDOW points in NumPy (the first of
    equals), one RK4 step towards the point ``ahead`` samples past it, indices clipped to the end."""
    if compiled:
        request.getfixturevalue("jit_cache")
    runs, step = 3, 0.1
    rng = np.random.default_rng(5)
    pursuit = PathPursuit(VEHICLE, step, runs)
    # Curved references behind the start, of different bends, one shorter than the others (padded).
    t = np.arange(0.0, 9.0, step)
    references = np.stack([np.column_stack([-t, 0.15 * r * t + 0.02 * (r - 1) * t**2]) for r in range(runs)])
    references[2, 60:] = references[2, 59]  # padded with its last point
    lookaheads = np.array([1.0, 2.0, 3.3])
    start = np.array([0.2, -0.1, rng.uniform(-0.1, 0.1), 0.05, 0.0])
    never = lambda states, deviation: np.zeros(len(states), dtype=bool)  # noqa: E731
    compiled = pursuit.run(start, references, lookaheads, 0.5, never)

    one = _pursuit_step_function(VEHICLE, step)
    m = references.shape[1]
    for r in range(runs):
        ahead = max(1, round(lookaheads[r] / step))
        x, nearest, rows = start.copy(), 0, [start.copy()]
        for _ in range(m + PathPursuit.WINDOW):
            candidates = np.minimum(nearest + np.arange(PathPursuit.WINDOW), m - 1)
            distance = np.hypot(*(references[r, candidates] - x[:2]).T)
            nearest = int(candidates[np.argmin(distance)])
            target = references[r, min(nearest + ahead, m - 1)]
            x = np.asarray(one(x, target, 0.5)).ravel()
            rows.append(x)
        np.testing.assert_allclose(compiled[r], np.array(rows), rtol=0, atol=1e-9)


def test_the_goal_test_asks_for_the_yaws_only_when_some_configuration_is_near():
    """``arrived`` given a function for the yaws: the tolerances' answer (near the goal or its line, the
    yaw wrapped, the hitch), each deciding some, and the function is not called when no configuration is
    near the goal."""
    s = PlannerSettings()
    rng = np.random.default_rng(4)
    calls, decided = [], np.zeros(3, dtype=int)

    def later(yaw):
        def give():
            calls.append(1)
            return yaw

        return give

    for shape in [(), (7,), (3, 40)]:
        for spread in (0.05, 0.3, 30.0):  # near the goal to far from it
            gx, gy = rng.normal(0.0, spread, shape), rng.normal(0.0, spread, shape)
            yaw = rng.normal(0.0, 0.08, shape) + 2.0 * math.pi * rng.integers(-2, 3, shape)
            hitch = rng.normal(0.0, 0.08, shape)
            near = np.hypot(gx - np.clip(gx, s.goal_line_from_m, s.goal_line_m), gy) <= s.goal_tolerance_m
            heading = np.abs(np.angle(np.exp(1j * yaw))) <= s.goal_tolerance_yaw
            straight = np.abs(hitch) <= s.goal_tolerance_hitch
            calls.clear()
            got = arrived(s, gx, gy, later(yaw), hitch)
            np.testing.assert_array_equal(got, near & heading & straight)
            np.testing.assert_array_equal(arrived(s, gx, gy, yaw, hitch), got)
            assert np.shape(got) == shape
            assert len(calls) == int(np.any(near))
            decided += [np.sum(~near), np.sum(near & ~heading), np.sum(near & heading & ~straight)]
    assert np.all(decided > 0)
    # The answer has the inputs' shape broadcast, whichever is larger, near the goal or not.
    for gx in (9.0, 0.0):
        assert arrived(s, np.full(3, gx), 0.0, 0.0, 0.0).shape == (3,)
        assert arrived(s, gx, 0.0, np.zeros((2, 3)), 0.0).shape == (2, 3)
        assert arrived(s, gx, 0.0, 0.0, np.zeros(4)).shape == (4,)


def test_the_pursuit_steers_as_pure_pursuit_written_with_angles():
    """The runs' right-hand side takes the virtual steer's tangent from the bearing's sine (no angle): one RK4
    step of it is one of pure pursuit written with angles, the bearing an arctangent wrapped to +-pi, the
    virtual steer the arctangent of L_T times the curvature 2 sin(alpha) / l_d clipped to +-limit, then Eq.
    (45), on random states and points in every direction (many at the limit, some straight ahead)."""
    step, limit, v = 0.1, 0.5, VEHICLE
    one = _pursuit_step_function(v, step)

    def rhs(x: np.ndarray, point: np.ndarray) -> np.ndarray:
        dx, dy = point[0] - x[0], point[1] - x[1]
        bearing = math.atan2(dy, dx) - (x[2] + math.pi)
        alpha = math.atan2(math.sin(bearing), math.cos(bearing))
        virtual = math.atan(-2.0 * v.trailer_length * math.sin(alpha) / max(math.hypot(dx, dy), 1e-6))
        virtual = min(max(virtual, -limit), limit)
        front = min(max(front_steer_from_virtual(v, x[3], virtual), -v.max_steer), v.max_steer)  # Eq. (45)
        rate = min(max((front - x[4]) / step, -v.max_steer_rate), v.max_steer_rate)
        return np.append(full_rhs(v, x[:4], np.array([-1.0, x[4]])), rate)

    rng = np.random.default_rng(12)
    clipped = 0
    for _ in range(300):
        x = np.array([*rng.uniform(-5.0, 5.0, 2), rng.uniform(-math.pi, math.pi), *rng.uniform(-0.8, 0.8, 2)])
        heading = x[2] + math.pi + rng.choice([rng.uniform(-math.pi, math.pi), 0.0])  # some dead astern
        point = x[:2] + rng.uniform(0.3, 8.0) * np.array([math.cos(heading), math.sin(heading)])
        k1 = rhs(x, point)
        k2 = rhs(x + 0.5 * step * k1, point)
        k3 = rhs(x + 0.5 * step * k2, point)
        k4 = rhs(x + step * k3, point)
        expected = x + step / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        np.testing.assert_allclose(np.asarray(one(x, point, limit)).ravel(), expected, rtol=0, atol=1e-12)
        dx, dy = point - x[:2]
        clipped += abs(2.0 * v.trailer_length * (dx * math.sin(x[2]) - dy * math.cos(x[2]))) > math.tan(limit) * (
            dx * dx + dy * dy
        )
    assert 30 < clipped < 270  # both sides of the limit were tried


def test_a_pursuit_stopped_once_settled_is_the_start_of_the_whole_one():
    """``settles`` stops every run at the check where it says True of a run that ended, ``within`` after as
    many samples: either way the runs so far are those of the whole pursuit, sample for sample."""
    runs, step = 5, 0.1
    pursuit = PathPursuit(VEHICLE, step, runs)
    xs = -np.arange(0.0, 12.0, step)
    references = np.stack([np.column_stack([xs, np.full(len(xs), 0.3 * (r - 2))]) for r in range(runs)])
    stops = np.array([-1.0, -3.37, -6.0, -0.55, -20.0])
    start = np.array([0.0, 0.0, 0.0, 0.05, 0.0])

    def ended_rows(states: np.ndarray, deviation: np.ndarray) -> np.ndarray:
        which = np.repeat(np.arange(runs), len(states) // runs)
        return states[:, 0] <= stops[which]

    asked: list[np.ndarray] = []

    def settles(run: np.ndarray) -> bool:  # True of the second run to end (run 0, past -1 m)
        asked.append(run)
        return len(asked) == 2

    whole = pursuit.run(start, references, np.full(runs, 2.0), 0.5, ended_rows)
    early = pursuit.run(start, references, np.full(runs, 2.0), 0.5, ended_rows, settles)
    n = early.shape[1]
    assert n < whole.shape[1] // 4
    np.testing.assert_array_equal(early, whole[:, :n])
    # Asked about each run that ended, once, with its samples up to where it ended: run 3, then run 0.
    assert len(asked) == 2
    for run, r in zip(asked, (3, 0), strict=True):
        assert run[-1, 0] <= stops[r] and np.all(run[:-1, 0] > stops[r])
        np.testing.assert_array_equal(run, whole[r, : len(run)])
    within = pursuit.run(start, references, np.full(runs, 2.0), 0.5, ended_rows, within=25)
    np.testing.assert_array_equal(within, whole[:, :26])  # 25 samples asked about, and the state after


def test_the_reverse_primitives_alone_are_those_of_the_whole_batch():
    """The opening's reverse-only search integrates the reverse half of the commands in a batch of its own."""
    size = 7
    whole, reverse = PrimitiveBatch(VEHICLE, 1.5, 15, 2 * size), PrimitiveBatch(VEHICLE, 1.5, 15, size)
    commands = np.concatenate([np.linspace(-0.5, 0.5, size), np.linspace(-0.45, 0.45, size)])
    directions = np.concatenate([np.ones(size), -np.ones(size)])
    steer0 = np.linspace(-0.3, 0.2, 2 * size)
    start = np.array([3.0, -1.0, 0.4, 0.25])
    np.testing.assert_array_equal(
        reverse.run(start, steer0[size:], commands[size:], directions[size:]),
        whole.run(start, steer0, commands, directions)[size:],
    )


def test_the_dubins_runs_stopped_once_the_landing_is_settled_plan_the_same_paths(monkeypatch):
    """In open space the Dubins runs stop once no landing still to come is shorter than one taken (or
    than a goal-line landing taken): the planner finds the very paths it finds integrating them all."""
    starts = [
        State(12.0, 4.0, math.radians(30.0), math.radians(10.0)),  # a single bending reverse run
        State(7.2, 6.1, math.radians(2.0), math.radians(20.0)),  # forward, then reverse
        # A goal-line shot lands in 135 samples, a Dubins run in 129 (start 110 of the sweep of seed 7).
        State(11.118740718227746, -4.444849836363771, -0.9564604615747418, 0.3965641671682158),
    ]
    integrated: list[int] = []
    run = PathPursuit.run

    def counted(self, *args, **kwargs):  # type: ignore[no-untyped-def]
        path = run(self, *args, **kwargs)
        integrated.append(path.shape[1])
        return path

    monkeypatch.setattr(PathPursuit, "run", counted)
    early = [plan(VEHICLE, s, Pose(), Scene(), SETTINGS) for s in starts]
    early_samples = sum(integrated)
    integrated.clear()
    shots = EndGame.dubins_shots
    monkeypatch.setattr(
        EndGame, "dubins_shots", lambda self, state, steer, max_length, *rest: shots(self, state, steer, max_length)
    )
    whole = [plan(VEHICLE, s, Pose(), Scene(), SETTINGS) for s in starts]
    assert early_samples < sum(integrated)
    for a, b in zip(early, whole, strict=True):
        assert a.status == b.status == "found"
        assert a.path.keys() == b.path.keys()
        for name in a.path:
            np.testing.assert_array_equal(a.path[name], b.path[name])


def test_the_goal_line_shots_ended_test_judges_each_sample_once_as_if_all_were_judged_again():
    """The goal-line shots are asked whether they ended as they grow by chunks; judging only the new
    samples gives what judging the whole runs again gives: each run arrived (after its start) or past the
    hitch limit at some sample, or lost at its last."""
    endgame = EndGame(VEHICLE, Pose(), SETTINGS)
    rng = np.random.default_rng(3)
    answers = set()
    for _ in range(40):
        runs = np.zeros((3, 121, 5))
        runs[:, :, 0] = np.linspace(rng.uniform(2.0, 8.0), rng.uniform(-1.0, 1.0), 121)
        runs[:, :, 3] = rng.normal(0.0, 0.5, (3, 121)) * (rng.random((3, 1)) < 0.5)  # some pass the limit
        arrive = rng.integers(0, 121, 3)
        runs[np.arange(3), arrive] = 0.0  # a sample at the goal (the start's does not count)
        ended = endgame._lines_ended()
        for k in (41, 81, 121):
            part = runs[:, :k]
            over = (np.abs(part[:, :, 3]) > endgame.hitch_limit).any(axis=1) | endgame._lost(part[:, -1])
            expected = bool((over | endgame.at_goal(part[:, 1:]).any(axis=1)).all())
            assert ended(part) == expected
            answers.add(expected)
    assert answers == {False, True}
