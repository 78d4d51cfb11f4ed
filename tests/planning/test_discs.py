"""The planner's fast collision check compiled (discs.c) against NumPy's: the same numbers to the last bit."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from hitchpark.maneuver.scenario import builtin_scenario
from hitchpark.planning import discs as discs_module
from hitchpark.planning.discs import Discs
from hitchpark.planning.grid import Screen
from hitchpark.planning.raster import DistanceGrid


@pytest.fixture(scope="module")
def place() -> tuple[object, DistanceGrid]:
    scenario = builtin_scenario("driveway_fence")
    return scenario, DistanceGrid(scenario.scene, (-2.0, -31.0, 22.0, 31.0), 0.05)


def _samples(rng: np.random.Generator, n: int, k: int) -> np.ndarray:
    """Configurations clustered about a random point (some off the grid), headings beyond +-pi, hitch to 70 deg."""
    centre = rng.uniform([-3.0, -32.0], [23.0, 32.0])
    xy = centre + rng.normal(0.0, 1.5, (n, k, 2))
    return np.concatenate([xy, rng.uniform(-7.0, 7.0, (n, k, 1)), rng.uniform(-1.2, 1.2, (n, k, 1))], axis=-1)


@pytest.mark.parametrize("tolerance", [0.0, 0.1, 0.3])
def test_the_compiled_check_is_numpys_bit_for_bit(shared_jit_cache, place, tolerance):
    """Both least values of every motion, with and without a length tolerance, off the grid and not a number."""
    scenario, grid = place
    assert discs_module._kernel(True, str(shared_jit_cache[0])) is not None  # the compiled code, not NumPy again
    discs = Discs(replace(scenario.vehicle, length_tolerance=tolerance))
    rng = np.random.default_rng(7)
    for trial in range(30):
        n, k = int(rng.integers(1, 25)), int(rng.integers(1, 10))
        samples, half = _samples(rng, n, k), rng.uniform(0.0, 0.1, (n, k))
        if trial == 0:
            samples[0, 0, 0] = np.nan
            half[-1, -1] = np.nan
        got, want = discs.least(grid, samples, half), discs.least_numpy(grid, samples, half)
        for a, b in zip(got, want, strict=True):
            assert np.array_equal(a, b, equal_nan=True)
    lost = discs.least(grid, _samples(rng, 1, 1) * np.nan, np.zeros((1, 1)))  # reads the frame: blocked
    assert lost[0][0] == -math.inf and lost[1][0] == -math.inf


def test_a_look_that_stops_early_gives_the_same_answers(shared_jit_cache, place):
    """With ``stop = c``, clear by c and surely nearer than c come out as from every point."""
    scenario, grid = place
    discs = Discs(replace(scenario.vehicle, length_tolerance=0.1))
    rng = np.random.default_rng(8)
    stopped_early = 0
    for _ in range(200):
        n, k = int(rng.integers(1, 20)), int(rng.integers(1, 12))
        samples, half, c = _samples(rng, n, k), rng.uniform(0.0, 0.1, (n, k)), float(rng.uniform(0.0, 0.6))
        sure, most = discs.least(grid, samples, half, c)
        full_sure, full_most = discs.least_numpy(grid, samples, half)
        assert np.array_equal(sure > c, full_sure > c) and np.array_equal(most < c, full_most < c)
        stopped_early += int(np.count_nonzero(sure != full_sure))
    assert stopped_early > 0  # the early stop was taken (else this test checks nothing)


def test_the_screen_answers_as_numpy_does(shared_jit_cache, place, monkeypatch):
    """The planner's questions (fast, triage, blocked) get the same answers with the compiled check and without."""
    scenario, grid = place
    rng = np.random.default_rng(9)
    goal = scenario.goal
    starts = np.array([goal.x, goal.y, goal.yaw, 0.0]) + rng.normal(0.0, [2.0, 0.25, 0.05, 0.05], (60, 1, 4))
    steps = rng.normal(0.0, [0.02, 0.01, 0.003, 0.003], (60, 20, 4))
    motions = np.concatenate([starts, starts + np.cumsum(steps, axis=1)], axis=1)  # short motions about the goal
    screen = Screen(scenario.vehicle, scenario.scene, grid, 0.15)
    compiled = screen.fast(motions), screen.triage(motions), screen.blocked(motions[:, 0])
    monkeypatch.setenv("HITCHPARK_JIT", "0")
    plain = screen.fast(motions), screen.triage(motions), screen.blocked(motions[:, 0])
    assert np.array_equal(compiled[0], plain[0]) and np.array_equal(compiled[2], plain[2])
    assert all(np.array_equal(a, b) for a, b in zip(compiled[1], plain[1], strict=True))
    assert compiled[0].any() and not compiled[0].all()  # both answers occur among these motions


def test_where_the_compiler_refuses_the_check_is_numpys(jit_cache, place, monkeypatch):
    monkeypatch.setenv("CC", "false")  # found on the path, compiles nothing
    assert discs_module._kernel(True, str(jit_cache[0])) is None
    scenario, grid = place
    discs = Discs(scenario.vehicle)
    samples = _samples(np.random.default_rng(10), 3, 4)
    got = discs.least(grid, samples, np.zeros((3, 4)), -math.inf)
    want = discs.least_numpy(grid, samples, np.zeros((3, 4)))
    assert all(np.array_equal(a, b) for a, b in zip(got, want, strict=True))


def test_groups_shown_clear_at_their_centre_are_passed_over_with_the_same_answers(shared_jit_cache, place):
    """Short motions about the goal of a narrow driveway, some near its walls, some clear: the compiled check
    passes over groups of points the grid shows clear (its sure value then above NumPy's least) and answers as
    NumPy's every point does, for clearances from touching to a metre."""
    scenario, grid = place
    rng = np.random.default_rng(11)
    goal = scenario.goal
    starts = np.array([goal.x, goal.y, goal.yaw, 0.0]) + rng.normal(0.0, [4.0, 0.3, 0.05, 0.05], (200, 1, 4))
    motions = np.concatenate([starts, starts + np.cumsum(rng.normal(0.0, 0.01, (200, 10, 4)), axis=1)], axis=1)
    discs = Discs(scenario.vehicle)
    full_sure, full_most = discs.least_numpy(grid, motions[:, 1:], np.zeros((200, 10)))
    passed_over = 0
    for c in (0.0, 0.1, 0.3, 0.6, 1.0):
        sure, most = discs.least(grid, motions[:, 1:], np.zeros((200, 10)), c)
        assert np.array_equal(sure > c, full_sure > c) and np.array_equal(most < c, full_most < c)
        passed_over += int(np.count_nonzero(sure > full_sure))
    assert passed_over > 0
