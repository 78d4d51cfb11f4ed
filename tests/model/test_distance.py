"""The compiled exact clearance (distance.c) against Shapely's: the same distances to rounding, the same zeros."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from hitchpark.maneuver.scenario import builtin_scenario
from hitchpark.model import checker as checker_module
from hitchpark.model.checker import SceneChecker
from hitchpark.model.collision import swept_clearance
from hitchpark.model.scene import Area, Obstacle, Scene
from hitchpark.model.vehicle import VehicleTrailer


def _configs(rng: np.random.Generator, scene: Scene, n: int) -> np.ndarray:
    """Configurations over the scene's extent, headings all round, hitch to 70 deg."""
    points = [o.polygon for o in scene.obstacles] + ([scene.area.boundary] if scene.area is not None else [])
    corners = np.concatenate(points)
    low, high = corners.min(axis=0) - 3.0, corners.max(axis=0) + 3.0
    xy = rng.uniform(low, high, (n, 2))
    return np.column_stack([xy, rng.uniform(-math.pi, math.pi, n), rng.uniform(-1.2, 1.2, n)])


def _star(rng: np.random.Generator, centre: np.ndarray, k: int) -> np.ndarray:
    """A simple, mostly non-convex polygon: k vertices around a centre at random radii."""
    angles = (np.arange(k) + rng.uniform(0.0, 0.8, k)) * 2.0 * math.pi / k  # increasing, gaps below pi
    radii = rng.uniform(0.3, 2.5, k)
    return centre + np.column_stack([radii * np.cos(angles), radii * np.sin(angles)])


@pytest.mark.parametrize("name", ["driveway_fence", "hammerhead", "curb_parallel", "loading_dock"])
@pytest.mark.parametrize("tolerance", [0.0, 0.15])
def test_the_compiled_clearance_is_shapelys(shared_jit_cache, name, tolerance):
    scenario = builtin_scenario(name)
    assert checker_module._kernel(True, str(shared_jit_cache[0])) is not None  # the compiled code, not Shapely again
    vehicle = replace(scenario.vehicle, length_tolerance=tolerance)
    checker = SceneChecker(vehicle, scenario.scene)
    configs = _configs(np.random.default_rng(3), scenario.scene, 3000)
    got, want = checker.compiled(configs), checker.clearances_shapely(configs)
    assert got is not None
    np.testing.assert_allclose(got, want, rtol=0.0, atol=1e-9)
    assert np.array_equal(got == 0.0, want == 0.0)
    assert (want == 0.0).any() and (want > 0.0).any()  # both touching and clear configurations are compared


def test_non_convex_obstacles_without_an_area(shared_jit_cache):
    """Star-shaped obstacles (bodies inside them, around them, across them), no area: Shapely's answers."""
    rng = np.random.default_rng(4)
    centres, sizes = rng.uniform(-12.0, 12.0, (12, 2)), rng.integers(3, 12, 12)
    obstacles = [Obstacle(f"star {i}", _star(rng, centres[i], int(sizes[i]))) for i in range(12)]
    scene = Scene(obstacles=obstacles)
    for tolerance in (0.0, 0.2):
        checker = SceneChecker(replace(VehicleTrailer(), length_tolerance=tolerance), scene)
        configs = _configs(rng, scene, 4000)
        got, want = checker.compiled(configs), checker.clearances_shapely(configs)
        np.testing.assert_allclose(got, want, rtol=0.0, atol=1e-9)
        assert np.array_equal(got == 0.0, want == 0.0)


def test_an_area_alone_and_a_body_outside_it(shared_jit_cache):
    scene = Scene(area=Area(np.array([[0.0, 0.0], [30.0, 0.0], [30.0, 8.0], [12.0, 8.0], [12.0, 20.0], [0.0, 20.0]])))
    checker = SceneChecker(VehicleTrailer(), scene)
    configs = _configs(np.random.default_rng(5), scene, 3000)
    got, want = checker.compiled(configs), checker.clearances_shapely(configs)
    np.testing.assert_allclose(got, want, rtol=0.0, atol=1e-9)
    outside = checker.compiled(np.array([[-20.0, -20.0, 0.0, 0.0], [15.0, 15.0, 0.0, 0.0]]))
    assert np.array_equal(outside, [0.0, 0.0])


def test_the_swept_bound_is_the_same_compiled_or_not(shared_jit_cache, monkeypatch):
    """A maneuver-long motion: the same least bound and row, to rounding, with the compiled distances and without."""
    scenario = builtin_scenario("hammerhead")
    rng = np.random.default_rng(6)
    start = np.array([scenario.goal.x, scenario.goal.y, scenario.goal.yaw, 0.0])
    states = start + np.cumsum(rng.normal(0.0, [0.04, 0.04, 0.01, 0.01], (400, 4)), axis=0)
    compiled = swept_clearance(scenario.vehicle, scenario.scene, states)
    monkeypatch.setenv("HITCHPARK_JIT", "0")
    plain = swept_clearance(scenario.vehicle, scenario.scene, states)
    assert compiled[1] == plain[1] and compiled[0] == pytest.approx(plain[0], abs=1e-9)
