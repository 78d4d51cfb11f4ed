"""A vehicle whose lengths are known to a tolerance (VehicleTrailer.length_tolerance): the bodies the collision
checks, the planner's points and the guard cover every hitch offset and trailer length within it."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from hitchpark.checks import InputError
from hitchpark.control.guard import Guard
from hitchpark.control.step import ControlStep
from hitchpark.model import VehicleTrailer
from hitchpark.model.checker import SceneChecker, body_geometries
from hitchpark.model.collision import body_shapes, swept_clearance
from hitchpark.model.plant import Measurement, PlantSettings
from hitchpark.model.scene import Area, Obstacle, Scene
from hitchpark.model.state import Pose, State
from hitchpark.planning.discs import POINT_SPACING, Discs

V = VehicleTrailer()
# A yard with a wall, a post and a tight boundary: bodies come near all three.
YARD = Scene(
    (
        Obstacle("wall", [[9.0, -4.0], [9.5, -4.0], [9.5, 4.0], [9.0, 4.0]]),
        Obstacle("post", [[3.0, 2.6], [3.3, 2.6], [3.3, 2.9], [3.0, 2.9]]),
    ),
    Area([[-4.0, -3.5], [12.0, -3.5], [12.0, 3.5], [-4.0, 3.5]]),
)


def scaled(vehicle: VehicleTrailer, g: float) -> VehicleTrailer:
    """The vehicle with L_H and L_T scaled by ``g`` (its tolerance 0)."""
    return replace(
        vehicle, hitch_offset=g * vehicle.hitch_offset, trailer_length=g * vehicle.trailer_length, length_tolerance=0.0
    )


def configs(seed: int, n: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.column_stack(
        [rng.uniform(-3, 6, n), rng.uniform(-3, 3, n), rng.uniform(-math.pi, math.pi, n), rng.uniform(-1.0, 1.0, n)]
    )


@pytest.mark.parametrize("f", [0.05, 0.1, 0.2])
def test_the_clearance_is_the_least_over_the_lengths_range(f):
    """Not more than any vehicle's within the range (a safe bound), and hardly less than the least of them."""
    tolerant = replace(V, length_tolerance=f)
    cfg = configs(1, 400)
    got = SceneChecker(tolerant, YARD).clearances(cfg)
    least = np.full(len(cfg), np.inf)
    for g in np.linspace(1 - f, 1 + f, 41):
        least = np.minimum(least, SceneChecker(scaled(V, g), YARD).clearances(cfg))
    assert np.all(got <= least + 1e-9)
    # between the sampled scales the true least is lower still, by at most half their spacing of movement
    step = 2 * f * (V.trailer_length + V.hitch_offset) / 40
    assert np.all(got >= least - step / 2 - 1e-9)
    assert np.any(got < SceneChecker(V, YARD).clearances(cfg) - 0.05)  # it matters somewhere


def test_a_vanishing_tolerance_is_the_vehicle_itself():
    """Continuity at 0: the hulls of a tolerance of 1e-9 are the bodies themselves (to 1e-8 m), and the planner's
    points the vehicle's own outline points (each of them a scaled copy of one of them)."""
    cfg = configs(2, 200)
    tiny = replace(V, length_tolerance=1e-9)
    assert np.allclose(SceneChecker(tiny, YARD).clearances(cfg), SceneChecker(V, YARD).clearances(cfg), atol=1e-8)
    x, y = Discs(tiny).centres(cfg[:5])
    x0, y0 = Discs(V).centres(cfg[:5])
    for i in range(5):
        gaps = np.min(np.hypot(x[i][:, None] - x0[i][None], y[i][:, None] - y0[i][None]), axis=1)
        assert gaps.max() < 1e-6


def test_body_shapes_name_the_bodies_over_the_range():
    tolerant = replace(V, length_tolerance=0.1)
    shapes = body_shapes(tolerant, (0.0, 0.0, 0.0, 0.0))
    assert set(shapes) == set(body_shapes(V, (0.0, 0.0, 0.0, 0.0)))
    # hitch straight: the vehicle body spans from 0.9 to 1.1 of the lengths, its rear 1 m behind its rear axle
    x_min, _, x_max, _ = shapes["vehicle"].bounds
    front = V.wheelbase + V.front_overhang
    assert x_min == pytest.approx(0.9 * (V.trailer_length + V.hitch_offset) - V.rear_overhang)
    assert x_max == pytest.approx(1.1 * (V.trailer_length + V.hitch_offset) + front)
    assert shapes["drawbar"].length == pytest.approx(1.1 * V.trailer_length - V.trailer_front)
    assert shapes["trailer"].equals(body_shapes(V, (0.0, 0.0, 0.0, 0.0))["trailer"])


@settings(max_examples=25, deadline=None)
@given(
    f=st.floats(0.01, 0.5),
    state=st.tuples(st.floats(-5, 5), st.floats(-5, 5), st.floats(-math.pi, math.pi), st.floats(-1.2, 1.2)),
)
def test_the_planners_points_cover_the_bodies_over_the_range(f, state):
    """Every point lies on a body, and every point of a body's outline within half the spacing of one."""
    tolerant = replace(V, length_tolerance=f)
    discs = Discs(tolerant)
    x, y = discs.centres(np.array([state]))
    points = shapely.points(np.column_stack([x[0], y[0]]))
    bodies = body_geometries(tolerant, np.array([state]))[0]
    on_a_body = np.min([shapely.distance(points, b) for b in bodies], axis=0)
    assert on_a_body.max() < 1e-9
    for body in bodies:
        outline = shapely.boundary(body) if body.geom_type == "Polygon" else body
        samples = shapely.get_coordinates(shapely.segmentize(outline, 0.01))
        gaps = np.min(np.hypot(samples[:, None, 0] - x[0][None], samples[:, None, 1] - y[0][None]), axis=1)
        assert gaps.max() <= POINT_SPACING / 2 + 1e-9


def test_the_swept_clearance_moves_in_small_enough_steps_for_the_longest_lengths():
    """A motion is cut so that no point of the longest vehicle moves more than the step between sub-samples."""
    tolerant = replace(V, length_tolerance=0.2)
    turn = np.array([[0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.8, -0.8]])  # trailer turns in place, the car sweeps
    wide = np.array([[10.5, -1.0], [11.5, -1.0], [11.5, 1.0], [10.5, 1.0]])
    far_post = Scene((Obstacle("post", wide),))
    got, _ = swept_clearance(tolerant, far_post, turn)
    least = min(swept_clearance(scaled(V, g), far_post, turn)[0] for g in np.linspace(0.8, 1.2, 9))
    assert got <= least + 1e-9


@pytest.mark.parametrize("hitch_offset", [0.0, 0.5, 1.05])
def test_a_vehicle_with_no_tow_bar_or_a_short_one(hitch_offset):
    """No tow bar (L_H = 0, or within the body), or one that is within the body at the short end of the range."""
    vehicle = replace(V, hitch_offset=hitch_offset, length_tolerance=0.1)
    got = SceneChecker(vehicle, YARD).clearances(configs(3, 50))
    least = np.min([SceneChecker(scaled(vehicle, g), YARD).clearances(configs(3, 50)) for g in (0.9, 1.0, 1.1)], 0)
    assert np.all(np.isfinite(got)) and np.all(got <= least + 1e-9)


def test_the_plants_vehicle_is_exact():
    believed = replace(V, length_tolerance=0.1)
    real = PlantSettings(vehicle={"trailer_length": 2.9623}).resolve_vehicle(believed)
    assert real.length_tolerance == 0.0 and real.trailer_length == 2.9623
    assert PlantSettings().resolve_vehicle(believed) == replace(believed, length_tolerance=0.0)


@pytest.mark.parametrize("bad", [-0.1, 0.6, math.nan])
def test_a_tolerance_out_of_range_is_refused(bad):
    with pytest.raises(InputError, match="length_tolerance"):
        VehicleTrailer(length_tolerance=bad)


def test_the_guard_stops_a_car_that_may_be_longer_than_it_believes():
    """Heading for a wall 0.35 m beyond the believed car's nose: the exact guard lets it go on (slowly), the one
    told the lengths may be 10% longer stops it: that car's nose may be 0.04 m from it."""
    wall = Scene((Obstacle("wall", [[9.0, -4.0], [9.5, -4.0], [9.5, 4.0], [9.0, 4.0]]),))
    nose = V.trailer_length + V.hitch_offset + V.wheelbase + V.front_overhang  # straight, trailer axle at x = 0
    measurement = Measurement(0.0, State(9.0 - 0.35 - nose, 0.0, 0.0, 0.0), 0.0, 0.3)
    forward = ControlStep(trailer_speed=0.3, virtual_steer=0.0, rear_speed=0.3, front_steer=0.0, ok=True, stop=False)
    exact = Guard(V, wall, 0.2, 0.03, 0.1, 0).check(measurement, Pose(), forward)
    doubtful = Guard(replace(V, length_tolerance=0.1), wall, 0.2, 0.03, 0.1, 0).check(measurement, Pose(), forward)
    assert exact.ok and 0.0 < exact.rear_speed <= 0.3
    assert not doubtful.ok and doubtful.stop and doubtful.rear_speed == 0.0 and "guard" in doubtful.status
