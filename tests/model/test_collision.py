"""Clearance between the bodies and a scene (hitchpark.model.collision): analytic distances, swept motion."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from hitchpark.checks import InputError
from hitchpark.model import VehicleTrailer
from hitchpark.model.checker import SceneChecker, body_geometries
from hitchpark.model.collision import (
    _subsamples,
    body_shapes,
    clearance,
    closest,
    collides,
    swept_clearance,
)
from hitchpark.model.scene import Area, Obstacle, Scene

V = VehicleTrailer()  # trailer body x in [-1, 2], |y| <= 0.9; drawbar 2 -> 2.693; vehicle body x in [2.852, 7.698]


def box(x0: float, y0: float, x1: float, y1: float) -> list[list[float]]:
    return [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]


def moved(points, angle: float, shift: tuple[float, float]) -> np.ndarray:
    """Points rotated by ``angle`` about the origin, then shifted."""
    c, s = math.cos(angle), math.sin(angle)
    return np.asarray(points, dtype=float) @ np.array([[c, s], [-s, c]]) + np.asarray(shift)


def moved_scene(scene: Scene, angle: float, shift: tuple[float, float]) -> Scene:
    obstacles = tuple(Obstacle(o.name, moved(o.polygon, angle, shift)) for o in scene.obstacles)
    area = None if scene.area is None else Area(moved(scene.area.boundary, angle, shift))
    return Scene(obstacles, area)


def moved_states(states: np.ndarray, angle: float, shift: tuple[float, float]) -> np.ndarray:
    out = np.array(states, dtype=float)
    out[:, :2] = moved(out[:, :2], angle, shift)
    out[:, 2] += angle
    return out


BEHIND = Scene((Obstacle("bollard", box(-3.0, -0.5, -2.0, 0.5)),))  # 1.0 m behind the trailer's rear


def test_trailer_one_metre_from_a_square():
    assert clearance(V, BEHIND, 0.0, 0.0, 0.0, 0.0) == pytest.approx(1.0, abs=1e-9)
    contact = closest(V, BEHIND, 0.0, 0.0, 0.0, 0.0)
    assert contact is not None
    assert (contact.body, contact.other) == ("trailer", 'obstacles[0] ("bollard")')
    assert contact.distance == pytest.approx(1.0, abs=1e-9)
    assert np.allclose(np.abs(contact.points[:, 0]), [1.0, 2.0])  # rear edge of the trailer, face of the bollard
    assert not collides(V, BEHIND, 0.0, 0.0, 0.0, 0.0)


def test_trailer_one_metre_from_a_square_rotated_and_shifted():
    angle, shift = 0.7, (12.0, -4.0)
    scene = moved_scene(BEHIND, angle, shift)
    x, y = moved([[0.0, 0.0]], angle, shift)[0]
    assert clearance(V, scene, x, y, angle, 0.0) == pytest.approx(1.0, abs=1e-9)


def test_overlap_is_zero():
    scene = Scene((Obstacle("post", box(0.5, 0.5, 1.5, 1.5)),))  # across the trailer's left side
    assert clearance(V, scene, 0.0, 0.0, 0.0, 0.0) == 0.0
    assert collides(V, scene, 0.0, 0.0, 0.0, 0.0)
    inside = Scene((Obstacle("hangar", box(-50, -50, 50, 50)),))  # the whole rig inside an obstacle
    assert clearance(V, inside, 0.0, 0.0, 0.0, 0.0) == 0.0


def test_distance_to_the_area_boundary():
    area = Scene(area=Area(box(-5.0, -3.0, 20.0, 3.0)))
    assert clearance(V, area, 0.0, 0.0, 0.0, 0.0) == pytest.approx(3.0 - V.vehicle_width / 2, abs=1e-9)
    contact = closest(V, area, 0.0, 0.0, 0.0, 0.0)
    assert contact is not None and (contact.body, contact.other) == ("vehicle", "area boundary")


def test_leaving_the_area_is_zero():
    short = Scene(area=Area(box(-5.0, -3.0, 6.0, 3.0)))  # the vehicle's front sticks out past x = 6
    assert clearance(V, short, 0.0, 0.0, 0.0, 0.0) == 0.0
    elsewhere = Scene(area=Area(box(100.0, 100.0, 110.0, 110.0)))  # the rig wholly outside
    assert clearance(V, elsewhere, 0.0, 0.0, 0.0, 0.0) == 0.0
    contact = closest(V, elsewhere, 0.0, 0.0, 0.0, 0.0)
    assert contact is not None and contact.distance == 0.0 and "leaves the area" in contact.describe()


def test_drawbar_alone_crossing_a_pole():
    pole = Scene((Obstacle("pole", box(2.30, -0.01, 2.35, 0.01)),))
    assert clearance(V, pole, 0.0, 0.0, 0.0, 0.0) == 0.0
    contact = closest(V, pole, 0.0, 0.0, 0.0, 0.0)
    assert contact is not None and contact.body == "drawbar"
    shapes = body_shapes(V, (0.0, 0.0, 0.0, 0.0))
    polygon = shapely.Polygon(pole.obstacles[0].polygon)
    assert shapely.distance(shapes["trailer"], polygon) == pytest.approx(0.3)
    assert shapely.distance(shapes["vehicle"], polygon) == pytest.approx(2.852 - 2.35)


def test_tow_bar_only_when_the_hitch_is_behind_the_body():
    assert set(body_shapes(V, (0, 0, 0, 0))) == {"vehicle", "trailer", "drawbar", "tow_bar"}
    under = VehicleTrailer(hitch_offset=0.8)
    assert set(body_shapes(under, (0, 0, 0, 0))) == {"vehicle", "trailer", "drawbar"}
    shapes = body_shapes(V, (0, 0, 0, 0))
    assert shapes["tow_bar"].length == pytest.approx(V.hitch_offset - V.rear_overhang)


def test_empty_scene_is_infinitely_clear():
    assert clearance(V, Scene(), 0.0, 0.0, 0.0, 0.0) == math.inf
    assert closest(V, Scene(), 0.0, 0.0, 0.0, 0.0) is None
    assert swept_clearance(V, Scene(), np.zeros((3, 4))) == (math.inf, 0)


WALL = Scene((Obstacle("wall", box(-2.0, -0.01, 9.0, 0.01)),))  # thin, along x


def test_passing_through_a_thin_wall_between_clear_samples_is_caught():
    states = np.array([[0.0, -2.5, 0.0, 0.0], [0.0, 2.5, 0.0, 0.0]])  # sideways across the wall in one step
    per_sample = [clearance(V, WALL, *row) for row in states]
    assert min(per_sample) > 1.0  # both samples clear
    assert swept_clearance(V, WALL, states) == (0.0, 0)


def test_a_pole_between_samples_is_caught_by_the_drawbar():
    pole = Scene((Obstacle("pole", box(2.30, 0.49, 2.35, 0.51)),))  # just left of the drawbar, right of nothing
    states = np.array([[0.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]])
    # Both samples clear of it: the trailer body ends at x = 2, the vehicle begins at x = 2.852.
    assert min(clearance(V, pole, *row) for row in states) > 0.2
    assert swept_clearance(V, pole, states)[0] == 0.0


def test_row_of_the_minimum():
    states = np.column_stack([np.zeros(7), [-6.0, -5.0, -4.0, -3.5, -4.0, -5.0, -6.0], np.zeros(7), np.zeros(7)])
    bound, row = swept_clearance(V, WALL, states, max_step_m=0.01)
    assert row in (2, 3)  # the step that ends at, or begins at, the closest sample
    exact = clearance(V, WALL, *states[3])
    assert exact - 0.005 - 1e-12 <= bound <= exact
    assert swept_clearance(V, WALL, states[3:4]) == (pytest.approx(exact), 0)


def test_standstill_is_the_exact_clearance():
    states = np.tile([0.0, 0.0, 0.0, 0.0], (5, 1))
    assert swept_clearance(V, BEHIND, states) == (pytest.approx(1.0, abs=1e-9), 0)


def test_heading_recorded_wrapped_turns_the_short_way():
    # From just below +pi to just above -pi is a small turn, not nearly a whole one.
    states = np.array([[0.0, 0.0, math.pi - 0.01, 0.0], [0.0, 0.0, -math.pi + 0.01, 0.0]])
    far = Scene((Obstacle("far", box(30.0, 30.0, 31.0, 31.0)),))
    short = swept_clearance(V, far, states, max_step_m=1.0)[0]
    assert short == pytest.approx(clearance(V, far, *states[1]), abs=0.5)


configs = st.tuples(st.floats(-20, 20), st.floats(-20, 20), st.floats(-math.pi, math.pi), st.floats(-1.2, 1.2))


@given(configs)
def test_vectorised_bodies_match_body_shapes(config):
    shapes = body_shapes(V, config)
    fast = body_geometries(V, np.array([config]))[0]
    for geometry, key in zip(fast, ("vehicle", "trailer", "drawbar", "tow_bar"), strict=True):
        assert shapely.equals_exact(geometry, shapes[key], tolerance=1e-9)


SCENE = Scene(
    (
        Obstacle("car", box(-4.0, 3.0, 0.5, 5.0)),
        Obstacle("wall", [[6.0, -6.0], [9.0, -2.0], [8.5, -1.5], [5.5, -5.5]]),
        Obstacle("pole", box(1.0, -3.0, 1.2, -2.8)),
    ),
    Area(box(-15.0, -12.0, 20.0, 12.0)),
)


@given(configs, st.floats(-math.pi, math.pi), st.floats(-500, 500), st.floats(-500, 500))
def test_clearance_invariant_under_moving_everything(config, angle, dx, dy):
    before = clearance(V, SCENE, *config)
    state = moved_states(np.array([config]), angle, (dx, dy))[0]
    after = clearance(V, moved_scene(SCENE, angle, (dx, dy)), *state)
    assert after == pytest.approx(before, abs=1e-7)


motions = st.lists(
    st.tuples(st.floats(-6, 6), st.floats(-6, 6), st.floats(-1.5, 1.5), st.floats(-1.0, 1.0)), min_size=2, max_size=6
)


@given(motions, st.floats(-math.pi, math.pi), st.floats(-500, 500), st.floats(-500, 500))
def test_swept_clearance_invariant_under_moving_everything(rows, angle, dx, dy):
    states = np.array(rows)
    before = swept_clearance(V, SCENE, states, max_step_m=0.2)[0]
    after = swept_clearance(V, moved_scene(SCENE, angle, (dx, dy)), moved_states(states, angle, (dx, dy)), 0.2)[0]
    assert after == pytest.approx(before, abs=1e-6)


@pytest.mark.slow
@settings(max_examples=30)  # about 0.2 s an example: 10 000 exact clearances
@given(motions, st.sampled_from([0.02, 0.1, 0.5]))
def test_swept_clearance_is_a_lower_bound_within_half_a_step(rows, max_step):
    states = np.array(rows)
    bound = swept_clearance(V, SCENE, states, max_step_m=max_step)[0]
    # Dense sampling of the same linear motion, 2000 samples a step (exact clearance at each).
    fine = np.concatenate(
        [a + np.linspace(0.0, 1.0, 2000, endpoint=False)[:, None] * (b - a) for a, b in itertools.pairwise(states)]
        + [states[-1:]]
    )
    dense = float(SceneChecker(V, SCENE).clearances(fine).min())
    assert bound <= dense + 1e-9
    assert bound >= dense - max_step / 2 - 0.01  # the dense sampling itself may miss up to 5 mm


@pytest.mark.slow
@settings(max_examples=60)
@given(motions, st.sampled_from([0.02, 0.1, 0.5]))
def test_pruned_sweep_equals_checking_every_pair(rows, max_step):
    """The sweep skips obstacles whose boxes are too far to matter; checking every pair gives the same answer."""
    states = np.array(rows)
    configs, row_of, half = _subsamples(V, states, max_step)
    exact = SceneChecker(V, SCENE).clearances(configs)  # every body against every obstacle (nearest in the tree)
    bound = np.maximum(exact - half, 0.0)
    k = int(np.lexsort((exact, bound))[0])
    least, row = swept_clearance(V, SCENE, states, max_step_m=max_step)
    assert least == pytest.approx(bound[k], abs=1e-12)
    assert row == row_of[k]


BAD = [
    ("states of three columns", lambda: swept_clearance(V, SCENE, np.zeros((3, 3))), "states must be an"),
    ("no states", lambda: swept_clearance(V, SCENE, np.zeros((0, 4))), "states must be an"),
    ("NaN in states", lambda: swept_clearance(V, SCENE, [[0, 0, 0, math.nan]]), "states must be finite"),
    ("a string for states", lambda: swept_clearance(V, SCENE, "states"), "states must be numbers"),
    ("zero step", lambda: swept_clearance(V, SCENE, np.zeros((2, 4)), 0.0), "max_step_m must be > 0"),
    ("far jump", lambda: swept_clearance(V, SCENE, [[0, 0, 0, 0], [9e4, 0, 0, 0]], 0.01), "move too far"),
    ("scene not a Scene", lambda: clearance(V, {"obstacles": []}, 0, 0, 0, 0), "scene must be a Scene"),
    ("vehicle not a vehicle", lambda: clearance(None, SCENE, 0, 0, 0, 0), "vehicle"),
    ("NaN pose", lambda: clearance(V, SCENE, math.nan, 0, 0, 0), "x must be finite"),
    ("string pose", lambda: clearance(V, SCENE, 0, "0", 0, 0), "y must be a number"),
]


@pytest.mark.parametrize(("case", "call", "message"), BAD, ids=[c[0] for c in BAD])
def test_bad_input_refused(case, call, message):
    with pytest.raises(InputError, match=message):
        call()
