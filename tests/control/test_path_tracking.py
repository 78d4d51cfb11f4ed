"""Path tracking (hitchpark.control.path_tracking): segments, driving to the end and stopping, giving up."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hitchpark.control.path_tracking import END_TOLERANCE_M, PathTracker, TrackingSettings, direction_segments
from hitchpark.control.step import ControlStep
from hitchpark.model import VehicleTrailer
from hitchpark.model.plant import Measurement, Plant, PlantSettings
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
