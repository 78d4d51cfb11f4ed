"""The built-in obstacle scenes (driveway, campsite, curb_parallel, bay, loading_dock): each loads and keeps clear.

For the paper's vehicle (the default :class:`VehicleTrailer`): the goal, at hitch 0, keeps every body at
least 0.3 m from the scene; the start and the four corners of the start region's x-y box (at its middle
heading and hitch angle) more than 0.2 m. Clearances by the exact :func:`swept_clearance` of one state.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from hitchpark.maneuver.scenario import BUILTIN_ORDER, builtin_scenario
from hitchpark.model import VehicleTrailer
from hitchpark.model.collision import swept_clearance

SCENES = ("driveway", "campsite", "curb_parallel", "bay", "loading_dock")

#: Least clearance of the parked combination [m].
GOAL_CLEARANCE = 0.3

#: Clearance a start must exceed [m].
START_CLEARANCE = 0.2


def clearance_at(scenario, x: float, y: float, yaw: float, hitch: float) -> float:
    best, _ = swept_clearance(VehicleTrailer(), scenario.scene, np.array([[x, y, yaw, hitch]]))
    return best


@pytest.fixture(scope="module", params=SCENES)
def scenario(request):
    return builtin_scenario(request.param)


def test_scene_loads(scenario):
    assert scenario.name in SCENES and scenario.description
    assert scenario.vehicle == VehicleTrailer()
    assert scenario.scene.area is not None and scenario.scene.obstacles
    assert all(o.name for o in scenario.scene.obstacles)
    assert scenario.start_region is not None


def test_scenes_are_not_among_the_papers_four():
    assert not set(SCENES) & set(BUILTIN_ORDER)


def test_goal_keeps_clear(scenario):
    g = scenario.goal
    assert clearance_at(scenario, g.x, g.y, g.yaw, 0.0) >= GOAL_CLEARANCE


def test_start_keeps_clear(scenario):
    s = scenario.start
    assert clearance_at(scenario, s.x, s.y, s.yaw, s.hitch) > START_CLEARANCE


def test_start_inside_its_region(scenario):
    r, s = scenario.start_region, scenario.start
    assert r.x[0] <= s.x <= r.x[1] and r.y[0] <= s.y <= r.y[1]
    assert r.yaw_deg[0] <= math.degrees(s.yaw) <= r.yaw_deg[1]
    assert r.hitch_deg[0] <= math.degrees(s.hitch) <= r.hitch_deg[1]


def test_start_region_corners_keep_clear(scenario):
    r = scenario.start_region
    yaw, hitch = math.radians(sum(r.yaw_deg) / 2), math.radians(sum(r.hitch_deg) / 2)
    for x, y in itertools.product(r.x, r.y):
        assert clearance_at(scenario, x, y, yaw, hitch) > START_CLEARANCE, (x, y)


def test_start_region_grid_keeps_clear(scenario):
    """Beyond the corners: every start of a 3 x 3 x 3 x 3 grid over the whole region, the headings and hitch
    angles at their limits too."""
    r = scenario.start_region
    axes = [np.linspace(lo, hi, 3) for lo, hi in (r.x, r.y, r.yaw_deg, r.hitch_deg)]
    for x, y, yaw, hitch in itertools.product(*axes):
        start = (x, y, yaw, hitch)
        assert clearance_at(scenario, x, y, math.radians(yaw), math.radians(hitch)) > START_CLEARANCE, start
