"""Scenario files with a scene: [[obstacles]], [area], [start_region], the start kept clear; driveway.toml."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest

from hitchpark.checks import InputError
from hitchpark.maneuver import ManeuverSettings, builtin_scenarios
from hitchpark.maneuver.scenario import BUILTIN_ORDER, StartRegion, builtin_scenario, load_scenario
from hitchpark.model import PlantSettings, Pose, VehicleTrailer
from hitchpark.model.collision import clearance, closest
from hitchpark.model.scene import Area, Obstacle, Scene

START = "[start]\nx = 10.0\ny = 3.5\nyaw_deg = 0.0\nhitch_deg = 0.0\n"  # trailer x in [9, 12], y in [2.6, 4.4]

SCENE_FILE = (
    START
    + """
[[obstacles]]
name = "parked car"
polygon = [[-6.0, 3.0], [-1.3, 3.0], [-1.3, 4.9], [-6.0, 4.9]]

[[obstacles]]
polygon = [[2.0, -4.0], [3.0, -4.0], [2.5, -3.0], [2.0, -4.0]]

[area]
boundary = [[-20.0, -10.0], [30.0, -10.0], [30.0, 10.0], [-20.0, 10.0]]

[start_region]
x = [8.0, 12.0]
y = [2.0, 5.0]
yaw_deg = [-10.0, 10.0]
hitch_deg = [-5.0, 5.0]
"""
)


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "scene.toml"
    path.write_text(text, encoding="utf-8")
    return path


def test_scene_file_loads(tmp_path):
    sc = load_scenario(write(tmp_path, SCENE_FILE))
    assert sc.scene == Scene(
        (
            Obstacle("parked car", [[-6.0, 3.0], [-1.3, 3.0], [-1.3, 4.9], [-6.0, 4.9]]),
            Obstacle("", [[2.0, -4.0], [3.0, -4.0], [2.5, -3.0]]),  # closing vertex dropped
        ),
        Area([[-20.0, -10.0], [30.0, -10.0], [30.0, 10.0], [-20.0, 10.0]]),
    )
    assert sc.start_region == StartRegion((8.0, 12.0), (2.0, 5.0), (-10.0, 10.0), (-5.0, 5.0))
    assert sc.start_region.to_dict() == {
        "x": [8.0, 12.0],
        "y": [2.0, 5.0],
        "yaw_deg": [-10.0, 10.0],
        "hitch_deg": [-5.0, 5.0],
    }
    assert StartRegion.from_dict(sc.start_region.to_dict()) == sc.start_region
    assert hash(sc) == hash(load_scenario(write(tmp_path, SCENE_FILE)))  # a scenario still hashes by value


def test_file_without_a_scene_has_an_empty_one(tmp_path):
    sc = load_scenario(write(tmp_path, START))
    assert sc.scene == Scene() and sc.scene.is_empty and sc.start_region is None


def test_paper_scenarios_have_no_scene_and_stay_four():
    assert [sc.name for sc in builtin_scenarios()] == list(BUILTIN_ORDER)
    assert "driveway" not in BUILTIN_ORDER
    assert all(sc.scene.is_empty and sc.start_region is None for sc in builtin_scenarios())


def with_obstacle(polygon: str, extra: str = "") -> str:
    return START + extra + f'\n[[obstacles]]\nname = "bin"\npolygon = {polygon}\n'


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (
            with_obstacle("[[9.5, 3.0], [10.5, 3.0], [10.5, 4.0], [9.5, 4.0]]"),
            r'start collides: the trailer touches obstacles\[0\] \("bin"\); the start must be at least '
            r"success\.min_clearance_m = 0\.2 m clear",
        ),
        (
            with_obstacle("[[8.7, 3.0], [8.9, 3.0], [8.9, 3.2], [8.7, 3.2]]"),  # 0.1 m behind the trailer
            r'start collides: the trailer is 0\.1\d* m from obstacles\[0\] \("bin"\)',
        ),
        (
            START + "[area]\nboundary = [[0.0, 0.0], [15.0, 0.0], [15.0, 4.0], [0.0, 4.0]]\n",
            "start collides: the vehicle reaches or leaves the area boundary",
        ),  # the wider body, 0.075 m out
        (
            START + "[area]\nboundary = [[100.0, 0.0], [115.0, 0.0], [115.0, 10.0], [100.0, 10.0]]\n",
            "leaves the area boundary",
        ),
    ],
)
def test_a_start_that_collides_is_refused(tmp_path, text, message):
    path = write(tmp_path, text)
    with pytest.raises(InputError, match=message) as err:
        load_scenario(path)
    assert str(path) in str(err.value)


def test_the_margin_is_the_success_criterion(tmp_path):
    text = with_obstacle("[[8.7, 3.0], [8.9, 3.0], [8.9, 3.2], [8.7, 3.2]]", "[success]\nmin_clearance_m = 0.05\n")
    assert len(load_scenario(write(tmp_path, text)).scene.obstacles) == 1
    touching = with_obstacle("[[9.5, 3.0], [10.5, 3.0], [10.5, 4.0], [9.5, 4.0]]", "[success]\nmin_clearance_m = 0\n")
    with pytest.raises(InputError, match="touches"):
        load_scenario(write(tmp_path, touching))


def test_the_start_is_checked_with_the_real_cars_lengths(tmp_path):
    # The plant's trailer is 0.7 m longer behind its axle: it reaches an obstacle the model's trailer clears.
    text = with_obstacle("[[8.2, 3.0], [8.4, 3.0], [8.4, 3.2], [8.2, 3.2]]")
    assert load_scenario(write(tmp_path, text))
    with pytest.raises(InputError, match="the trailer touches"):
        load_scenario(write(tmp_path, text + "[plant.vehicle]\ntrailer_rear = 1.7\n"))


REGION = "[start_region]\nx = [8.0, 12.0]\ny = [2.0, 5.0]\nyaw_deg = [-10.0, 10.0]\nhitch_deg = [-5.0, 5.0]\n"


@pytest.mark.parametrize(
    ("region", "message"),
    [
        (REGION.replace("x = [8.0, 12.0]", "x = [12.0, 8.0]"), r"start_region\.x must be \[lo, hi\] with lo <= hi"),
        (REGION.replace("x = [8.0, 12.0]\n", ""), r"start_region\.x is missing"),
        (REGION + "z = [0, 1]\n", r"start_region\.z"),
        (REGION.replace("y = [2.0, 5.0]", "y = 3.0"), r"start_region\.y must be a pair"),
        (REGION.replace("y = [2.0, 5.0]", "y = [1.0, 2.0, 3.0]"), r"start_region\.y must be a pair"),
        (REGION.replace("y = [2.0, 5.0]", 'y = ["a", "b"]'), r"start_region\.y must be numbers"),
        (REGION.replace("y = [2.0, 5.0]", "y = [0.0, nan]"), r"start_region\.y must be finite"),
        (REGION.replace("x = [8.0, 12.0]", "x = [0.0, 1e300]"), r"start_region\.x must be >= -100000"),
        (REGION.replace("yaw_deg = [-10.0, 10.0]", "yaw_deg = [0.0, 4000.0]"), r"start_region\.yaw_deg must be"),
        (
            REGION.replace("hitch_deg = [-5.0, 5.0]", "hitch_deg = [-75.0, 0.0]"),
            r"start_region\.hitch_deg must lie within \[-70, 70\] deg",
        ),
        ("start_region = 5\n", r"\[start_region\] must be a table"),
    ],
)
def test_bad_start_regions_are_refused(tmp_path, region, message):
    path = write(tmp_path, region + START)
    with pytest.raises(InputError, match=message):
        load_scenario(path)


def test_start_region_hitch_checked_against_the_plants_limit(tmp_path):
    text = START + REGION.replace("hitch_deg = [-5.0, 5.0]", "hitch_deg = [-60.0, 0.0]")
    assert load_scenario(write(tmp_path, text)).start_region is not None
    with pytest.raises(InputError, match=r"start_region\.hitch_deg must lie within \[-57\.2958, 57\.2958\]"):
        load_scenario(write(tmp_path, text + "[plant.vehicle]\nmax_hitch = 1.0\n"))


def test_bad_obstacles_in_a_file_are_refused_naming_them(tmp_path):
    path = write(tmp_path, with_obstacle("[[0, 0], [2, 2], [2, 0], [0, 2]]"))
    with pytest.raises(InputError, match=r'obstacles\[0\] \("bin"\)\.polygon must be a simple polygon') as err:
        load_scenario(path)
    assert str(path) in str(err.value)
    with pytest.raises(InputError, match="obstacles must be a list"):
        load_scenario(write(tmp_path, START.replace("[start]", 'obstacles = "none"\n[start]')))


# --- driveway.toml ----------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def driveway():
    return builtin_scenario("driveway")


def test_driveway_loads(driveway):
    assert driveway.name == "driveway" and driveway.description
    assert driveway.goal == Pose()
    assert driveway.vehicle == VehicleTrailer()
    assert driveway.settings == ManeuverSettings()  # the full-model NMPC
    assert driveway.plant == PlantSettings()  # the realistic car
    assert {o.name for o in driveway.scene.obstacles} == {"fence", "house", "parked car"}
    assert driveway.scene.area is not None and driveway.start_region is not None


def test_driveway_dimensions(driveway):
    area = driveway.scene.area.boundary
    house = next(o.polygon for o in driveway.scene.obstacles if o.name == "house")
    fence = next(o.polygon for o in driveway.scene.obstacles if o.name == "fence")
    drive = area[area[:, 0] < 10.5]  # the driveway's inner corners; it meets the street at x = 10.5
    # 3.5 m wide between the fence and the house wall, 12 m deep to the back fence.
    assert np.ptp(drive[:, 1]) == pytest.approx(3.5) and 10.5 - drive[:, 0].min() == pytest.approx(12.0)
    assert house[:, 1].min() == pytest.approx(drive[:, 1].max())  # the wall is the driveway's north side
    assert [-1.5, -1.75] in fence.tolist() and [10.5, -1.75] in fence.tolist()  # the fence its south side
    # The street: 7 m curb to curb.
    assert area[:, 0].max() - 10.5 == pytest.approx(7.0)


def test_driveway_start_and_goal_are_clear(driveway):
    real = driveway.plant.resolve_vehicle(driveway.vehicle)
    margin = driveway.settings.success.min_clearance_m
    s = driveway.start
    assert clearance(real, driveway.scene, s.x, s.y, s.yaw, s.hitch) >= margin
    goal = closest(real, driveway.scene, 0.0, 0.0, 0.0, 0.0)
    assert goal is not None and goal.distance >= margin  # parked, the trailer 0.5 m from the back fence
    assert goal.distance == pytest.approx(0.5)


def test_driveway_start_region_is_clear(driveway):
    real = driveway.plant.resolve_vehicle(driveway.vehicle)
    r = driveway.start_region
    grid = itertools.product(*(np.linspace(lo, hi, 5) for lo, hi in (r.x, r.y, r.yaw_deg, r.hitch_deg)))
    least = min(clearance(real, driveway.scene, x, y, math.radians(yaw), math.radians(h)) for x, y, yaw, h in grid)
    assert least >= driveway.settings.success.min_clearance_m


def test_unknown_builtin_scenario():
    with pytest.raises(InputError, match="no scenario named 'garage'"):
        builtin_scenario("garage")
    with pytest.raises(InputError, match="scenario name must be"):
        builtin_scenario("../parallel")
