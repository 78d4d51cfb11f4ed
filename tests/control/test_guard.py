"""The guard between a stage's controller and the car (hitchpark.control.guard): stops, slows, looks ahead."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from hitchpark.control.guard import ESCAPE_MARGIN_M, Guard
from hitchpark.control.step import ControlStep
from hitchpark.model import VehicleTrailer
from hitchpark.model.kinematics import full_rhs
from hitchpark.model.plant import Measurement
from hitchpark.model.scene import Obstacle, Scene
from hitchpark.model.state import Pose, State

V = VehicleTrailer()


WALL = Scene((Obstacle("wall", ((-6.0, -5.0), (-5.0, -5.0), (-5.0, 5.0), (-6.0, 5.0))),))


def step(speed: float, predicted: np.ndarray | None = None) -> ControlStep:
    p = np.zeros((0, 0)) if predicted is None else predicted
    return ControlStep(
        trailer_speed=speed,
        virtual_steer=0.0,
        rear_speed=speed,
        front_steer=0.0,
        ok=True,
        stop=False,
        predicted_states=p,
    )


def test_guard_stops_a_command_that_is_too_close_and_slows_one_near_the_scene():
    guard = Guard(V, WALL, 0.2, 0.05, 0.1, 0)
    # The trailer's rear (1 m behind the axle) is 5 - 1 - x_t from the wall at x = -5.
    far = Measurement(0.0, State(6.0, 0.0, 0.0, 0.0), 0.0, -1.0)
    assert guard.check(far, Pose(), step(-1.0)).rear_speed == -1.0
    near = Measurement(0.0, State(-3.3, 0.0, 0.0, 0.0), 0.0, -1.0)  # 0.7 m from the wall
    slowed = guard.check(near, Pose(), step(-1.0))
    assert slowed.ok and -1.0 < slowed.rear_speed < 0.0
    touching = Measurement(0.0, State(-3.9, 0.0, 0.0, 0.0), 0.0, -0.1)  # 0.1 m from the wall
    stopped = guard.check(touching, Pose(), step(-0.1))
    assert not stopped.ok and stopped.stop and stopped.rear_speed == 0.0 and "guard" in stopped.status


def test_guard_looks_at_the_prediction():
    guard = Guard(V, WALL, 0.2, 0.05, 0.1, 0)
    m = Measurement(0.0, State(0.0, 0.0, 0.0, 0.0), 0.0, -1.0)
    ahead = np.array([[0.0, 0.0, 0.0, 0.0], [-2.0, 0.0, 0.0, 0.0], [-3.95, 0.0, 0.0, 0.0]])  # goal frame = world
    assert not guard.check(m, Pose(), step(-1.0, ahead)).ok


def test_guard_speed_grows_with_room_from_zero():
    guard = Guard(V, WALL, 0.2, 0.05, 0.1, 1)
    rooms = np.linspace(0.0, 3.0, 31)
    speeds = [guard.max_speed(r) for r in rooms]
    assert speeds[0] == 0.0 and np.all(np.diff(speeds) > 0)
    for room, v in zip(rooms, speeds, strict=True):  # it can stop within the room: lag, then braking at a/2
        a = 0.5 * V.max_accel
        assert 2.0 * (2 * 0.1 * v + v * v / (2 * a)) == pytest.approx(room, abs=1e-9)


KERB = Scene((Obstacle("kerb", ((-30.0, 3.0), (30.0, 3.0), (30.0, 4.0), (-30.0, 4.0))),))


def beside_the_kerb(guard: Guard, room: float) -> State:
    """A straight rig heading +x with ``room`` metres more than the guard's clearance from the kerb at y = 3."""
    now = float(guard.checker.clearances(np.zeros((1, 4)))[0])
    return State(0.0, now - guard.need - room, 0.0, 0.0)


@pytest.mark.parametrize("speed", [-1.0, 1.0])
def test_along_the_scene_the_guard_does_not_hold_the_car_to_a_crawl(speed):
    """Two centimetres from its clearance, straight along a kerb, nothing comes nearer while the car stops: the
    bound alone (any way the bodies might move) would allow 0.05 m/s."""
    guard = Guard(V, KERB, 0.2, 0.03, 0.1, 1)
    state = beside_the_kerb(guard, 0.02)
    assert guard.max_speed(0.02) < 0.06
    got = guard.check(Measurement(0.0, state, 0.0, speed), Pose(), step(speed))
    assert got.ok and got.rear_speed == speed


@pytest.mark.parametrize("steer", [-0.3, 0.3])
@pytest.mark.parametrize("room", [0.05, 0.2, 0.6])
def test_turning_towards_the_scene_the_guard_allows_what_stops_in_time(steer, room):
    """Turning towards or away from the kerb: the speed allowed stops the car (the lag, then braking at a/2) with
    every body keeping the clearance, the steer held; towards it, less than the asked speed."""
    guard = Guard(V, KERB, 0.2, 0.03, 0.1, 1)
    state = beside_the_kerb(guard, room)
    asked = 1.5
    got = guard.check(Measurement(0.0, state, steer, asked), Pose(), replace(step(asked), front_steer=steer))
    assert got.ok and 0.0 < got.rear_speed <= asked
    travel = guard.stopping_travel(got.rear_speed)
    x = np.array([state.x, state.y, state.yaw, state.hitch])
    n = 400
    for _ in range(n):  # a finer roll-out than the guard's, Euler
        x = x + travel / n * full_rhs(V, x, np.array([1.0, steer]))
        assert guard.checker.clearances(x[None])[0] >= guard.need - 1e-3
    if steer > 0.0:  # a left turn swings the car's front towards the kerb
        assert got.rear_speed < asked


def test_a_controller_that_predicts_keeps_the_bound():
    """The NMPC's horizon is checked itself, and its speed keeps the bound: along the kerb, two centimetres from
    its clearance, it is held to what the bound allows where a tracker would go on."""
    guard = Guard(V, KERB, 0.2, 0.03, 0.1, 1)
    state = beside_the_kerb(guard, 0.02)
    along = np.array([[state.x + d, state.y, 0.0, 0.0] for d in (0.0, -0.1, -0.2)])  # goal frame = world
    got = guard.check(Measurement(0.0, state, 0.0, -1.0), Pose(), step(-1.0, along))
    assert got.ok and got.rear_speed == pytest.approx(-guard.max_speed(0.02))
    assert guard.check(Measurement(0.0, state, 0.0, -1.0), Pose(), step(-1.0)).rear_speed == -1.0


def test_a_stage_that_begins_too_near_keeps_what_it_begins_with_less_the_margin():
    """A car stopped 1 cm inside the guard's clearance (a stop's overshoot) can drive along the kerb or away
    from it; it may not come nearer than it began less ESCAPE_MARGIN_M, nor below min_clearance_m."""
    guard = Guard(V, KERB, 0.2, 0.03, 0.1, 1)
    inside = beside_the_kerb(guard, -0.01)  # 0.22 m from the kerb: the guard's 0.23 would stop anything
    m = Measurement(0.0, inside, 0.0, 0.0)
    assert not guard.check(m, Pose(), step(-0.3)).ok  # before the stage begins: stopped, as before
    kept = guard.begin(m)
    assert kept == pytest.approx(guard.need - 0.01 - ESCAPE_MARGIN_M) and guard.floor <= kept < guard.need
    along = guard.check(m, Pose(), step(-0.3))
    assert along.ok and along.rear_speed < 0.0  # along the kerb it moves
    nearer = State(inside.x, inside.y + ESCAPE_MARGIN_M + 0.005, 0.0, 0.0)  # 2.5 cm nearer than it began
    assert not guard.check(Measurement(0.1, nearer, 0.0, -0.3), Pose(), step(-0.3)).ok
    # Begun at least ESCAPE_MARGIN_M clear of the guard's clearance: the guard's clearance, as always.
    assert guard.begin(Measurement(0.0, beside_the_kerb(guard, 0.5), 0.0, 0.0)) == guard.need
    # Begun nearer than min_clearance_m: nothing below it.
    assert guard.begin(Measurement(0.0, beside_the_kerb(guard, -0.1), 0.0, 0.0)) == guard.floor


def test_the_guard_allows_for_the_estimates_doubt():
    """3 cm clear of the guard's clearance by the estimate, a straight rig along the kerb: without a doubt it goes on;
    with 1 deg of doubt in the hitch the car's front corner may be nearer, and the guard stops it. The clearance it
    keeps is the least of the hitch as estimated and moved by its doubt either side."""
    guard = Guard(V, KERB, 0.2, 0.03, 0.1, 1)
    state = beside_the_kerb(guard, 0.03)
    sure = Measurement(0.0, state, 0.0, -0.3)
    doubtful = replace(sure, doubt=(0.0, 0.0, 0.0, np.radians(1.0)))
    assert guard.check(sure, Pose(), step(-0.3)).ok
    stopped = guard.check(doubtful, Pose(), step(-0.3))
    assert not stopped.ok and stopped.rear_speed == 0.0 and "too close" in stopped.status
    x = np.array([[state.x, state.y, state.yaw, state.hitch + d] for d in np.radians([-1.0, 0.0, 1.0])])
    estimated, least = guard.clearances(x[1:2], doubtful.doubt)
    assert estimated[0] == guard.checker.clearances(x[1:2])[0]
    assert least[0] == guard.checker.clearances(x).min() < guard.need < estimated[0]


def test_a_stage_that_begins_doubtful_may_move_away_not_nearer():
    """Begun where the doubt puts a body below min_clearance_m (the estimate itself clear of it), the stage keeps what
    its doubtful clearance begins with less the margin: along the kerb it moves, towards it it does not; an estimate
    below min_clearance_m stops it whatever the doubt."""
    guard = Guard(V, KERB, 0.2, 0.03, 0.1, 1)
    doubt = (0.0, 0.0, 0.0, np.radians(2.0))
    start = beside_the_kerb(guard, 0.0)
    m = Measurement(0.0, start, 0.0, 0.0, doubt)
    kept = guard.begin(m)
    now = float(guard.clearances(np.array([[start.x, start.y, start.yaw, start.hitch]]), doubt)[1][0])
    assert now < guard.floor  # the doubt puts the car's front corner below the floor
    assert kept == pytest.approx(now - ESCAPE_MARGIN_M)
    along = np.array([[start.x + d, start.y, 0.0, 0.0] for d in (0.0, -0.1, -0.2)])
    assert guard.check(m, Pose(), step(-0.3, along)).ok
    nearer = along + np.array([0.0, ESCAPE_MARGIN_M + 0.005, 0.0, 0.0])
    assert not guard.check(m, Pose(), step(-0.3, nearer)).ok
    below = State(start.x, start.y + guard.need - guard.floor + 0.005, 0.0, 0.0)  # the estimate 0.5 cm inside
    guard.begin(Measurement(0.0, below, 0.0, 0.0, doubt))
    assert not guard.check(Measurement(0.0, below, 0.0, 0.0, doubt), Pose(), step(-0.3)).ok
