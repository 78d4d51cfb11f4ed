"""Path tracking (control.path_tracking) and the guard (control.guard): segments, stopping, clearance."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hitchpark.control.guard import Guard
from hitchpark.control.path_tracking import END_TOLERANCE_M, PathTracker, TrackingSettings, direction_segments
from hitchpark.control.step import ControlStep
from hitchpark.model import VehicleTrailer
from hitchpark.model.plant import Measurement, Plant, PlantSettings
from hitchpark.model.scene import Obstacle, Scene
from hitchpark.model.state import Pose, State

V = VehicleTrailer()


@pytest.mark.parametrize(
    ("direction", "expected"),
    [
        ([-1, -1, -1], [(0, 2)]),
        ([1, 1, 1, -1, -1], [(0, 2), (2, 4)]),
        ([-1, -1, 1, 1, -1, -1], [(0, 1), (1, 3), (3, 5)]),
        ([1], []),
    ],
)
def test_direction_segments_share_the_row_where_direction_changes(direction, expected):
    assert direction_segments(np.array(direction)) == expected


def drive(tracker: PathTracker, start: State, steps: int = 2000) -> tuple[Plant, list[ControlStep]]:
    plant = Plant(PlantSettings(kind="ideal"), V, start, 0.1)
    m = plant.sense()
    tracker.reset()
    tracker.initial_steer(m, Pose())
    seen = []
    for _ in range(steps):
        m = plant.sense()
        u = tracker.act(m, Pose())
        seen.append(u)
        if u.stop:
            break
        assert plant.apply(u.command) is not None
    return plant, seen


@pytest.mark.parametrize("direction", [1, -1])
def test_a_straight_segment_is_driven_to_its_end_and_stops_there(direction):
    s = np.linspace(0.0, 6.0, 61)
    configs = np.column_stack([direction * s, np.zeros_like(s), np.zeros_like(s), np.zeros_like(s)])
    tracker = PathTracker(V, TrackingSettings(), 0.1, configs, direction)
    plant, steps = drive(tracker, State(0.0, 0.0, 0.0, 0.0))
    assert steps[-1].ok and steps[-1].stop
    assert all(math.copysign(1, u.rear_speed) == direction for u in steps[:-1])
    end = configs[-1]
    # The tracked point (rear axle forward, trailer axle in reverse) has moved the segment's length.
    assert abs(plant.state.x - end[0]) < END_TOLERANCE_M + 0.11  # one sample at the last, slow speed
    assert abs(plant.state.y) < 1e-9 and abs(plant.state.hitch) < 1e-9


def test_reverse_tracking_follows_an_arc_and_keeps_the_steer_within_limits():
    # A trailer-axle arc of radius 8 m, driven backwards from (0, 0) heading +x: the axle moves along -x, curving.
    radius, phi = 8.0, np.linspace(0.0, 0.8, 81)
    configs = np.column_stack([-radius * np.sin(phi), radius * (1 - np.cos(phi)), -phi, np.zeros_like(phi)])
    tracker = PathTracker(V, TrackingSettings(), 0.1, configs, -1)
    plant, steps = drive(tracker, State(0.0, 0.0, 0.0, 0.0))
    assert steps[-1].ok and steps[-1].stop
    assert max(abs(u.front_steer) for u in steps) <= V.max_steer
    assert tracker.deviation < 0.15
    assert math.hypot(plant.state.x - configs[-1, 0], plant.state.y - configs[-1, 1]) < 0.2


def test_the_tracker_gives_up_when_the_car_is_far_off_its_path():
    s = np.linspace(0.0, 5.0, 51)
    configs = np.column_stack([-s, np.zeros_like(s), np.zeros_like(s), np.zeros_like(s)])
    tracker = PathTracker(V, TrackingSettings(max_deviation_m=0.3), 0.1, configs, -1)
    m = Measurement(0.0, State(0.0, 0.5, 0.0, 0.0), 0.0, 0.0)
    u = tracker.act(m, Pose())
    assert not u.ok and u.stop and u.rear_speed == 0.0 and "deviated" in u.status


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
