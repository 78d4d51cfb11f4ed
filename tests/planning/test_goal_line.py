"""The planner's goal-line window (PlannerSettings.goal_line_from_m .. goal_line_m) and its arrival test."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hitchpark.checks import InputError
from hitchpark.model import VehicleTrailer
from hitchpark.model.state import Pose, State, to_goal_frame
from hitchpark.planning import PlannerSettings, plan
from hitchpark.planning.settings import arrived


def test_arrival_is_near_the_window_heading_along_it_with_the_hitch_straight():
    s = PlannerSettings(goal_line_from_m=4.0, goal_line_m=8.0)
    gx = np.array([3.6, 3.8, 6.0, 8.2, 8.4, 0.0])
    assert arrived(s, gx, 0.0, 0.0, 0.0).tolist() == [False, True, True, True, False, False]
    assert not arrived(s, 6.0, 0.31, 0.0, 0.0)
    assert not arrived(s, 6.0, 0.0, math.radians(3.1), 0.0)
    assert not arrived(s, 6.0, 0.0, 0.0, math.radians(3.1))
    point = PlannerSettings()
    assert arrived(point, 0.2, 0.2, 0.0, 0.0) and not arrived(point, 0.3, 0.2, 0.0, 0.0)


def test_a_window_that_ends_before_it_starts_is_refused():
    with pytest.raises(InputError, match="goal_line_from_m must be <="):
        PlannerSettings(goal_line_from_m=5.0, goal_line_m=4.0)


def test_a_plan_to_the_window_ends_on_the_goal_line_within_it():
    s = PlannerSettings(goal_line_from_m=4.0, goal_line_m=8.0)
    found = plan(VehicleTrailer(), State(12.0, 4.0, math.radians(20.0), 0.0), Pose(), None, s)
    assert found.found
    end = found.states[-1]
    gx, gy, gyaw = (float(v) for v in to_goal_frame(Pose(), end[0], end[1], end[2]))
    assert 4.0 - s.goal_tolerance_m <= gx <= 8.0 + s.goal_tolerance_m
    assert abs(gy) <= s.goal_tolerance_m and abs(gyaw) <= s.goal_tolerance_yaw
    assert abs(end[3]) <= s.goal_tolerance_hitch
