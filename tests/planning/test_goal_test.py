"""The planner's goal test (hitchpark.planning.settings.arrived)."""

import math

import numpy as np

from hitchpark.model import VehicleTrailer
from hitchpark.planning import PlannerSettings
from hitchpark.planning.settings import arrived

VEHICLE = VehicleTrailer()
SETTINGS = PlannerSettings(max_expansions=50_000)  # generous: tests assert behaviour, never timings


def test_the_goal_test_asks_for_the_yaws_only_when_some_configuration_is_near():
    """``arrived`` given a function for the yaws: the tolerances' answer (near the goal or its line, the
    yaw wrapped, the hitch), each deciding some, and the function is not called when no configuration is
    near the goal."""
    s = PlannerSettings()
    rng = np.random.default_rng(4)
    calls, decided = [], np.zeros(3, dtype=int)

    def later(yaw):
        def give():
            calls.append(1)
            return yaw

        return give

    for shape in [(), (7,), (3, 40)]:
        for spread in (0.05, 0.3, 30.0):  # near the goal to far from it
            gx, gy = rng.normal(0.0, spread, shape), rng.normal(0.0, spread, shape)
            yaw = rng.normal(0.0, 0.08, shape) + 2.0 * math.pi * rng.integers(-2, 3, shape)
            hitch = rng.normal(0.0, 0.08, shape)
            near = np.hypot(gx - np.clip(gx, s.goal_line_from_m, s.goal_line_m), gy) <= s.goal_tolerance_m
            heading = np.abs(np.angle(np.exp(1j * yaw))) <= s.goal_tolerance_yaw
            straight = np.abs(hitch) <= s.goal_tolerance_hitch
            calls.clear()
            got = arrived(s, gx, gy, later(yaw), hitch)
            np.testing.assert_array_equal(got, near & heading & straight)
            np.testing.assert_array_equal(arrived(s, gx, gy, yaw, hitch), got)
            assert np.shape(got) == shape
            assert len(calls) == int(np.any(near))
            decided += [np.sum(~near), np.sum(near & ~heading), np.sum(near & heading & ~straight)]
    assert np.all(decided > 0)
    # The answer has the inputs' shape broadcast, whichever is larger, near the goal or not.
    for gx in (9.0, 0.0):
        assert arrived(s, np.full(3, gx), 0.0, 0.0, 0.0).shape == (3,)
        assert arrived(s, gx, 0.0, np.zeros((2, 3)), 0.0).shape == (2, 3)
        assert arrived(s, gx, 0.0, 0.0, np.zeros(4)).shape == (4,)
