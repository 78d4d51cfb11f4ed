"""Maneuvers among obstacles: the clearance criterion, the collision outcome, the scene in maneuver.json."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from hitchpark.checks import InputError
from hitchpark.control import NMPCSettings
from hitchpark.maneuver import ManeuverResult, ManeuverSettings, Outcome, SuccessCriteria, park
from hitchpark.model import IDEAL, State, VehicleTrailer, body_outlines
from hitchpark.model.scene import Area, Obstacle, Scene

SETTINGS = ManeuverSettings(nmpc=NMPCSettings(kind="paper", solver="sqp"))
START = State(6.0, 3.0, 0.0, 0.0)


def box(x0: float, y0: float, x1: float, y1: float) -> list[list[float]]:
    return [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]


def run(scene: Scene | None = None, settings: ManeuverSettings = SETTINGS) -> ManeuverResult:
    """The quick parallel maneuver of the viz tests: paper's NMPC on the ideal plant, 3 stages, parked (0.2 s)."""
    return park(VehicleTrailer(), START, settings=settings, plant=IDEAL, scene=scene, name="among")


@pytest.fixture(scope="module")
def free() -> ManeuverResult:
    return run()


@pytest.fixture(scope="module")
def top(free: ManeuverResult) -> float:
    """The largest y any body reaches in the free maneuver [m]."""
    v, states = free.plant_vehicle, free.trajectory.states()
    return max(float(np.max(body_outlines(v, *row)[key][:, 1])) for row in states for key in ("vehicle", "trailer"))


def ceiling(top: float, gap: float) -> Scene:
    """An area whose upper edge lies ``gap`` above the highest point the bodies reach."""
    return Scene(area=Area(box(-30.0, -30.0, 30.0, top + gap)))


def test_success_criteria_clearance_setting():
    assert SuccessCriteria().min_clearance_m == 0.2
    assert SuccessCriteria(min_clearance_m=0).min_clearance_m == 0.0
    for bad in (-0.1, 5.5, math.nan, "0.2", True):
        with pytest.raises(InputError, match=r"success\.min_clearance_m"):
            SuccessCriteria(min_clearance_m=bad)
    assert ManeuverSettings.from_dict({"success": {"min_clearance_m": 0.5}}).success.min_clearance_m == 0.5


def test_collision_outcome():
    assert Outcome("collision") is Outcome.COLLISION


def test_no_scene_no_clearance(free: ManeuverResult):
    assert free.success and free.reason == "parked"
    assert free.scene == Scene() and free.min_clearance_m is None and not free.collision
    data = free.to_dict()
    assert (data["obstacles"], data["area"], data["min_clearance_m"], data["collision"]) == ([], None, None, False)
    json.dumps(data, allow_nan=False)  # JSON-safe as it is


def test_clear_scene_keeps_the_outcome(free: ManeuverResult, top: float):
    result = run(ceiling(top, 1.0))
    assert result.success and result.reason == "parked"
    assert result.min_clearance_m == pytest.approx(1.0, abs=0.025 + 1e-9)
    assert result.min_clearance_m <= 1.0 + 1e-9 and not result.collision
    np.testing.assert_array_equal(result.trajectory.states(), free.trajectory.states())  # the scene is not seen


def test_too_close_fails_without_touching(top: float):
    result = run(ceiling(top, 0.1))
    assert not result.success and result.outcome is Outcome.COLLISION
    assert 0.07 <= result.min_clearance_m <= 0.1 + 1e-9 and not result.collision
    assert "less than min_clearance_m 0.2 m" in result.detail and "area boundary" in result.detail
    assert "its own outcome: parked" in result.detail
    # A smaller margin allows it.
    relaxed = replace(SETTINGS, success=SuccessCriteria(min_clearance_m=0.05))
    assert run(ceiling(top, 0.1), relaxed).success


def test_leaving_the_area_is_a_collision(top: float):
    result = run(ceiling(top, -0.3))
    assert result.outcome is Outcome.COLLISION and result.collision and result.min_clearance_m == 0.0
    assert "leaves the area" in result.detail


def test_an_obstacle_on_the_path_is_a_collision(free: ManeuverResult):
    # A pole at the trailer axle's position midway through the maneuver: the trailer runs it over.
    mid = len(free.trajectory) // 2
    x, y = free.trajectory["x_trailer"][mid], free.trajectory["y_trailer"][mid]
    scene = Scene((Obstacle("pole", box(x - 0.05, y - 0.05, x + 0.05, y + 0.05)),))
    result = run(scene)
    assert not result.success and result.reason == "collision" and result.collision
    assert result.min_clearance_m == 0.0
    assert 'obstacles[0] ("pole")' in result.detail and "its own outcome: parked" in result.detail
    assert result.swept[1] <= mid  # the first contact comes no later than the row where the pole stands


def test_zero_margin_still_fails_a_touch(free: ManeuverResult):
    x, y = free.trajectory["x_trailer"][0], free.trajectory["y_trailer"][0]
    scene = Scene((Obstacle("stone", box(x - 0.05, y - 0.05, x + 0.05, y + 0.05)),))
    result = run(scene, replace(SETTINGS, success=SuccessCriteria(min_clearance_m=0.0)))
    assert result.outcome is Outcome.COLLISION and result.collision


def test_json_round_trip_with_a_scene(top: float):
    scene = Scene(
        (Obstacle("parked car", box(-12.0, 6.0, -7.3, 7.9)), Obstacle("", [[15, -5], [16, -5], [15.5, -4]])),
        Area(box(-30.0, -30.0, 30.0, top + 0.1)),
    )
    result = run(scene)
    data = json.loads(json.dumps(result.to_dict(), allow_nan=False))
    assert data["obstacles"] == [
        {"name": "parked car", "polygon": box(-12.0, 6.0, -7.3, 7.9)},
        {"name": "", "polygon": [[15.0, -5.0], [16.0, -5.0], [15.5, -4.0]]},
    ]
    assert data["area"] == {"boundary": box(-30.0, -30.0, 30.0, top + 0.1)}
    assert data["min_clearance_m"] == result.min_clearance_m and data["collision"] is False
    again = ManeuverResult.from_dict(data)
    assert again.scene == scene
    assert again.min_clearance_m == result.min_clearance_m and again.swept == result.swept
    assert (again.success, again.reason, again.detail) == (result.success, result.reason, result.detail)
    assert json.loads(json.dumps(again.to_dict())) == data


def test_old_files_without_a_scene_load(free: ManeuverResult):
    data = free.to_dict()
    for key in ("obstacles", "area", "min_clearance_m", "collision"):
        del data[key]
    again = ManeuverResult.from_dict(data)
    assert again.scene == Scene() and again.min_clearance_m is None


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"obstacles": [{"name": "x", "polygon": [[0, 0], [2, 2], [2, 0], [0, 2]]}]}, r'obstacles\[0\] \("x"\)'),
        ({"obstacles": "none"}, "obstacles must be a list"),
        ({"obstacles": [{"polygon": [[0, 0], [1, 0], [1, 1]], "z": 1}]}, r"obstacles\[0\]\.z"),
        ({"area": {"boundary": [[0, 0], [1, 1]]}}, r"area\.boundary must have at least 3"),
        ({"area": []}, r"\[area\] must be a table"),
    ],
)
def test_bad_scene_in_a_saved_maneuver_is_refused(free: ManeuverResult, change, message):
    with pytest.raises(InputError, match=message):
        ManeuverResult.from_dict({**free.to_dict(), **change})


def test_park_refuses_a_scene_of_another_type():
    with pytest.raises(InputError, match="scene must be a Scene"):
        park(VehicleTrailer(), START, settings=SETTINGS, plant=IDEAL, scene={"obstacles": []})
