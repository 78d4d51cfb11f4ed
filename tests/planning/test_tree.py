"""The goal tree (hitchpark.planning.tree) and the planner's count-bounded, machine-independent answers."""

from __future__ import annotations

import math
import multiprocessing
import time
from dataclasses import replace

import numpy as np
import pytest

from hitchpark.control.pure_pursuit import forward_steer_limit
from hitchpark.maneuver.scenario import PLACES_SUITE, builtin_scenario
from hitchpark.model import State
from hitchpark.model.collision import clearance, swept_clearance
from hitchpark.model.kinematics import full_rhs
from hitchpark.model.state import to_goal_frame
from hitchpark.planning import cache, endgame, plan, tree
from hitchpark.planning.prepare import scene_bounds, tree_settings

CLEARANCE = 0.3  # the planned process's: success.min_clearance_m + process.plan_margin_m


def _settings(scenario, **changes):
    return replace(scenario.settings.planner, **{"min_clearance_m": CLEARANCE, **changes})


@pytest.fixture(scope="module")
def driveway():
    sc = builtin_scenario("driveway")
    settings = tree_settings(_settings(sc))
    bounds = scene_bounds(sc.vehicle, sc.goal, sc.scene, settings)
    grown = tree.goal_tree(sc.vehicle, sc.goal, sc.scene, settings, bounds)
    return sc, grown


def test_every_tree_path_is_a_reverse_run_into_the_goal_that_keeps_clear(driveway):
    """Read backwards, each node's path is a motion of the full model in reverse (Eqs. 19-24 at v = -1, the
    front steer of each sample), ends at the goal, keeps the hitch limit and the exact clearance."""
    sc, grown = driveway
    assert len(grown.states) > 200
    _assert_reverse_runs_into_the_goal(sc, grown)


def _assert_reverse_runs_into_the_goal(sc, grown) -> None:
    v = sc.vehicle
    rng = np.random.default_rng(3)
    for node in rng.choice(np.arange(1, len(grown.states)), size=12, replace=False):
        path = grown.path(int(node))
        assert np.all(np.isfinite(path))
        np.testing.assert_allclose(path[-1, :4], [sc.goal.x, sc.goal.y, sc.goal.yaw, 0.0], atol=1e-12)
        np.testing.assert_allclose(path[0], grown.states[node])
        assert np.all(np.abs(path[:, 3]) <= v.max_hitch - sc.settings.planner.hitch_margin + 1e-12)
        bound, _ = swept_clearance(v, sc.scene, path[:, :4])
        assert bound >= CLEARANCE - 1e-9
        # Reverse motion: the change between samples is the model's slope at v = -1 (the rear axle moves
        # sample_step_m a sample; the midpoint's slope, second order).
        mid = 0.5 * (path[1:] + path[:-1])
        slope = np.stack([full_rhs(v, m[:4], np.array([-1.0, m[4]])) for m in mid])
        step = sc.settings.planner.sample_step_m
        moves = np.diff(path[:, :4], axis=0)
        # (The last step, into the goal, is the root's first motion, steered at standstill: its own steer.)
        np.testing.assert_allclose(moves[:-1], step * slope[:-1], atol=2e-3)


@pytest.mark.slow
def test_a_tree_grown_from_a_shifted_trunk_holds_reverse_runs_into_the_goal(driveway):
    """Grown from the end of a straight 0.5 m out of the goal (node 1, the straight; its rows before the
    straight's samples are nan), every node's path is still a reverse run into the goal, the straight its end."""
    sc, grown = driveway
    shifted = tree.GoalTree(
        sc.vehicle, sc.goal, sc.scene, grown.settings, (0.0, 0.0, 1.0, 1.0),
        tree.GoalTree._grow(sc.vehicle, sc.goal, sc.scene, grown.settings, scene_bounds(
            sc.vehicle, sc.goal, sc.scene, grown.settings), trunk=0.5),
    )  # fmt: skip
    assert len(shifted.states) > 200
    trunk = shifted.path(1)
    np.testing.assert_allclose(trunk[:, 0], np.linspace(0.5, 0.0, 6), atol=1e-12)  # along the goal line, yaw 0
    np.testing.assert_array_equal(trunk[:, 1:], 0.0)
    assert np.all(shifted.parent[2:] > 0)  # every run in ends with the trunk
    _assert_reverse_runs_into_the_goal(sc, shifted)


def test_a_stunted_tree_is_grown_again_from_shifted_trunks_and_the_largest_kept(driveway, monkeypatch):
    """A tree that never leaves the goal line (no node more than STUNTED_M off it) is grown again from straight
    trunks of 1/3 and 2/3 of a primitive (the way out may turn between the branches a primitive apart); the
    tree of the most nodes is kept, the goal's own on a tie. A tree that leaves the line is grown once."""
    sc, grown = driveway
    s = grown.settings  # primitives of 1.5 m sampled every 0.1 m: trunks of 0.5 and 1.0 m

    def fake(sizes, across):
        def grow(vehicle, goal, scene, settings, bounds, trunk=0.0):
            calls.append(round(trunk, 9))
            n = sizes[len(calls) - 1]
            states = np.zeros((n, 5))
            states[:, 0] = np.arange(n)
            states[-1, 1] = across[len(calls) - 1]
            return {"states": states, "parent": np.arange(-1, n - 1), "cost": np.arange(n, dtype=float),
                    "samples": np.zeros((n, s.samples, 5))}  # fmt: skip

        return grow

    cases = [  # sizes and how far the last node is off the line, per growth; trunks grown; nodes kept
        ((5, 7, 6), (tree.STUNTED_M, 4.0, 4.0), [0.0, 0.5, 1.0], 7),
        ((5, 5, 4), (0.5, 3.0, 3.0), [0.0, 0.5, 1.0], 5),
        ((5, 7, 9), (tree.STUNTED_M + 0.2, 4.0, 4.0), [0.0], 5),
    ]
    for sizes, across, trunks, kept in cases:
        calls: list[float] = []
        monkeypatch.setattr(tree.GoalTree, "_grow", staticmethod(fake(sizes, across)))
        arrays = tree.GoalTree._grown(sc.vehicle, sc.goal, sc.scene, s, (0.0, 0.0, 1.0, 1.0))
        assert calls == trunks and len(arrays["states"]) == kept
        if kept == 5:
            assert arrays["states"][-1, 1] == across[0]  # the goal's own


def test_a_tree_shot_that_comes_onto_its_tree_path_is_handed_off_to_it(driveway):
    """A run started off a tree node's path comes onto it and is handed off: from there on the landing is the
    tree's path sample for sample (exact to the goal, not pursued), where the two meet they agree within the
    hand-off's tolerances, and the steer keeps its rate limit across the join."""
    sc, grown = driveway
    game = endgame.EndGame(sc.vehicle, sc.goal, _settings(sc))
    step = sc.vehicle.max_steer_rate * sc.settings.planner.sample_step_m  # the steer's change in a sample at 1 m/s
    far = np.flatnonzero((grown.cost > 15.0) & (np.abs(grown.states[:, 3]) < 0.05))
    handed = 0
    for node in far[:: max(1, len(far) // 12)][:12]:
        x, y, yaw, hitch, steer = grown.states[node]
        start = np.array([x - 0.25 * math.sin(yaw), y + 0.25 * math.cos(yaw), yaw + 0.02, hitch])  # 0.25 m aside
        for world, steers, pursued in game.tree_shots(start, float(steer), grown):
            if pursued == len(world):
                continue  # landed in the tolerance by pursuit alone
            handed += 1
            np.testing.assert_allclose(world[-1], [sc.goal.x, sc.goal.y, sc.goal.yaw, 0.0], atol=1e-9)
            # The rest is the path of one of the near nodes, from the sample after the one the run came onto.
            rest = np.column_stack([world[pursued:], steers[pursued:]])
            matches = [
                p
                for p in (grown.path(int(other)) for other in grown.near(start, 6))
                if len(p) > len(rest) and np.allclose(p[-len(rest) :], rest, atol=1e-9)
            ]
            assert matches, "a handed-off landing ends in none of the near nodes' paths"
            onto = matches[0][-len(rest) - 1]
            assert np.hypot(*(world[pursued - 1, :2] - onto[:2])) <= endgame.HANDOFF_M + 1e-12
            assert abs(world[pursued - 1, 2] - onto[2]) <= endgame.HANDOFF_ANGLE + 1e-12
            assert abs(world[pursued - 1, 3] - onto[3]) <= endgame.HANDOFF_ANGLE + 1e-12
            assert np.all(np.abs(np.diff(steers[pursued - 1 :])) <= step * (1 + 1e-9))
    assert handed >= 3


def test_a_tree_path_arrives_with_the_steer_of_its_last_sample(driveway):
    """The first motion out of the goal is steered at standstill: read backwards, the run arrives with its wheels
    turned, and the goal's row says so (no jump in the last sample)."""
    sc, grown = driveway
    samples = np.zeros((2, 3, 5))
    samples[1, :, 0] = [0.1, 0.2, 0.3]  # driven forward out of the goal
    samples[1, :, 4] = 0.3  # held
    arrays = {
        "states": np.array([[0.0, 0.0, 0.0, 0.0, 0.0], samples[1, -1]]),
        "parent": np.array([-1, 0]),
        "cost": np.array([0.0, 0.3]),
        "samples": samples,
    }
    small = tree.GoalTree(sc.vehicle, sc.goal, sc.scene, grown.settings, (0.0, 0.0, 1.0, 1.0), arrays)
    path = small.path(1)
    np.testing.assert_array_equal(path[:, 0], [0.3, 0.2, 0.1, 0.0])
    np.testing.assert_array_equal(path[:, 4], [0.3, 0.3, 0.3, 0.3])


@pytest.mark.slow
def test_the_tree_is_cached_on_disk_and_read_back_the_same(driveway, tmp_path, monkeypatch):
    sc, grown = driveway
    monkeypatch.setattr(cache, "cache_dir", lambda: tmp_path)
    settings = tree_settings(_settings(sc))
    bounds = scene_bounds(sc.vehicle, sc.goal, sc.scene, settings)
    built = tree.goal_tree.__wrapped__(sc.vehicle, sc.goal, sc.scene, settings, bounds)
    assert len(list(tmp_path.glob("planner-tree-*.npz"))) == 1
    read = tree.goal_tree.__wrapped__(sc.vehicle, sc.goal, sc.scene, settings, bounds)
    for name, values in built.arrays.items():
        np.testing.assert_array_equal(read.arrays[name], values, err_msg=name)
        np.testing.assert_array_equal(grown.arrays[name], values, err_msg=name)
    # Another clearance is another tree.
    other = tree_settings(_settings(sc, min_clearance_m=0.4))
    tree.goal_tree.__wrapped__(sc.vehicle, sc.goal, sc.scene, other, bounds)
    assert len(list(tmp_path.glob("planner-tree-*.npz"))) == 2


def test_tree_estimates_are_at_most_its_costs_at_its_nodes_and_none_far_from_it(driveway):
    _, grown = driveway
    nodes = np.arange(1, len(grown.states), 37)
    at_nodes = grown.estimate(grown.states[nodes, :4])
    assert np.all(at_nodes <= grown.cost[nodes] + 1e-12) and np.all(at_nodes >= 0.0)
    far = grown.states[nodes[:3], :4] + np.array([100.0, 0.0, 0.0, 0.0])
    assert np.all(np.isinf(grown.estimate(far)))
    assert np.all(np.isfinite(grown.estimate(far, math.inf)))


def _hog(stop) -> None:
    while not stop.is_set():
        sum(i * i for i in range(10_000))


def test_the_same_plan_on_a_loaded_machine():
    """The budget is a count: the plan from a start that needs the search (a pull forward at the loading
    dock's mouth) is the same to the last bit with two busy processes beside it."""
    sc = builtin_scenario("loading_dock")
    start = State(25.75, 7.51, math.radians(91.6), math.radians(-2.76))
    settings = _settings(sc)
    quiet = plan(sc.vehicle, start, sc.goal, sc.scene, settings)
    stop = multiprocessing.Event()
    hogs = [multiprocessing.Process(target=_hog, args=(stop,)) for _ in range(2)]
    for h in hogs:
        h.start()
    try:
        time.sleep(0.2)
        loaded = plan(sc.vehicle, start, sc.goal, sc.scene, settings)
    finally:
        stop.set()
        for h in hogs:
            h.join()
    assert quiet.status == loaded.status == "found"
    assert (quiet.expanded, quiet.direction_switches, quiet.detail) == (
        loaded.expanded,
        loaded.direction_switches,
        loaded.detail,
    )
    for column, values in quiet.path.items():
        np.testing.assert_array_equal(loaded.path[column], values, err_msg=column)


@pytest.mark.slow
def test_a_start_within_the_slack_keeps_its_own_clearance():
    """A start nearer the scene than min_clearance_m, within start_slack_m: the path keeps what it keeps."""
    sc = builtin_scenario("driveway")
    start = State(11.74, 6.0, math.radians(90.0), 0.0)  # the car's left side 0.265 m from the kerb line
    near = clearance(sc.vehicle, sc.scene, start.x, start.y, start.yaw, start.hitch)
    assert 0.23 < near < CLEARANCE
    refused = plan(sc.vehicle, start, sc.goal, sc.scene, _settings(sc))
    assert refused.status == "no_path" and "the start keeps only" in refused.detail
    found = plan(sc.vehicle, start, sc.goal, sc.scene, _settings(sc, start_slack_m=0.07))
    assert found.status == "found"
    bound, _ = swept_clearance(sc.vehicle, sc.scene, found.states)
    assert max(near - 0.03, CLEARANCE - 0.07) - 1e-9 <= bound
    assert plan(sc.vehicle, start, sc.goal, sc.scene, _settings(sc, start_slack_m=0.01)).status == "no_path"


@pytest.mark.parametrize("name", PLACES_SUITE)
def test_each_place_cites_public_sources_and_its_goal_keeps_clear(name):
    from importlib import resources

    text = (resources.files("hitchpark.maneuver") / "scenarios" / f"{name}.toml").read_text(encoding="utf-8")
    assert "/work" not in text and "FIELD.md" not in text
    sources = ("AASHTO", "Dimensions of Parking", "96/53/EC", "658.15", "Forest Service", "Boating Access")
    assert any(source in text for source in sources)
    sc = builtin_scenario(name)
    assert sc.start_region is not None and not sc.scene.is_empty
    at_goal = clearance(sc.vehicle, sc.scene, sc.goal.x, sc.goal.y, sc.goal.yaw, 0.0)
    assert at_goal >= sc.settings.success.min_clearance_m + sc.settings.process.plan_margin_m
    gx, gy, _ = to_goal_frame(sc.goal, sc.start.x, sc.start.y, sc.start.yaw)
    assert math.hypot(gx, gy) > 5.0  # the start is not at the goal


@pytest.mark.parametrize("name", ["hammerhead", "boat_ramp"])
def test_new_places_plan_from_their_start(name):
    """As the planned process plans: forward within the tracker's steer cap. From the hammerhead's stem, heading
    for the junction, the opening pulls forward round into the far arm and backs across into the near one."""
    sc = builtin_scenario(name)
    found = plan(sc.vehicle, sc.start, sc.goal, sc.scene, _settings(sc, forward_length_tolerance=0.2))
    assert found.status == "found", found.detail
    bound, _ = swept_clearance(sc.vehicle, sc.scene, found.states)
    assert bound >= CLEARANCE - 0.0051
    forward = found.path["direction"] > 0
    cap = forward_steer_limit(sc.vehicle, length_tolerance=0.2)
    assert np.all(np.abs(found.path["front_steer"][forward]) <= cap + 1e-12)
    if name == "hammerhead":
        assert "opening" in found.detail and found.direction_switches == 1
        turn = int(np.argmin(forward)) - 1  # the last forward sample
        assert forward[: turn + 1].all() and not forward[turn + 1 :].any()
        assert found.path["x_trailer"][turn] > sc.start.x  # east of the stem: in the far arm
