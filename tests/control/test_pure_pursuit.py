"""Forward repositioning (Section 5, hitchpark.control.pure_pursuit): steering and the end of the stage."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from hitchpark.control import NMPCSettings
from hitchpark.control.pure_pursuit import (
    PurePursuitSettings,
    forward_done,
    forward_steer_limit,
    pure_pursuit_steer,
)
from hitchpark.maneuver import ManeuverSettings, ProcessSettings, park
from hitchpark.model import IDEAL, Pose, VehicleTrailer, full_rhs, rear_axle_pose, step_full
from hitchpark.model.simulate import State

SETTINGS = PurePursuitSettings()
GOALS = [Pose(), Pose(5.0, -3.0, math.radians(30.0)), Pose(-12.0, 4.0, math.radians(-135.0))]


def state_in(goal: Pose, x: float, y: float, yaw: float, hitch: float) -> np.ndarray:
    """A full-model state given by its trailer pose in the parking frame of ``goal``."""
    c, s = math.cos(goal.yaw), math.sin(goal.yaw)
    return np.array([goal.x + c * x - s * y, goal.y + s * x + c * y, yaw + goal.yaw, hitch])


@pytest.mark.parametrize("goal", GOALS)
@pytest.mark.parametrize("x", [-5.0, 0.0, 8.0])
def test_on_the_line_and_aligned_goes_straight(table4, goal, x):
    assert pure_pursuit_steer(table4, goal, SETTINGS, state_in(goal, x, 0.0, 0.0, 0.0)) == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("goal", GOALS)
@pytest.mark.parametrize("offset", [0.2, 1.0, 2.5, 10.0])
def test_steers_back_towards_the_line(table4, goal, offset):
    left = pure_pursuit_steer(table4, goal, SETTINGS, state_in(goal, 4.0, offset, 0.0, 0.0))
    right = pure_pursuit_steer(table4, goal, SETTINGS, state_in(goal, 4.0, -offset, 0.0, 0.0))
    assert left < 0.0 < right  # left of the line (y > 0) steers right, and the other way round
    assert left == pytest.approx(-right, abs=1e-12)  # mirror image


def test_the_pure_pursuit_law(table4):
    """delta_f = atan(2 L sin(alpha) / l_d), alpha the bearing of the look-ahead point on the line."""
    ld = SETTINGS.lookahead
    state = np.array([3.0, 0.4, 0.1, -0.05])
    _, y_r, yaw_v = rear_axle_pose(table4, *state)
    alpha = math.atan2(-y_r, math.sqrt(ld**2 - y_r**2)) - yaw_v
    expected = math.atan(2 * table4.wheelbase * math.sin(alpha) / ld)
    assert pure_pursuit_steer(table4, Pose(), SETTINGS, state) == pytest.approx(expected, abs=1e-12)
    # Far from the line the look-ahead point is the foot of the perpendicular, at the real distance |y|.
    state = np.array([0.0, 10.0, 0.0, 0.0])
    _, y_r, yaw_v = rear_axle_pose(table4, *state)
    expected = math.atan(2 * table4.wheelbase * math.sin(-math.pi / 2 - yaw_v) / abs(y_r))
    assert pure_pursuit_steer(table4, Pose(), SETTINGS, state) == pytest.approx(expected, abs=1e-12)
    # Facing away from the line's direction: full lock (the forward limit) towards it.
    facing_back = np.array([0.0, 1.0, math.pi - 0.3, 0.0])
    assert pure_pursuit_steer(table4, Pose(), SETTINGS, facing_back) == pytest.approx(forward_steer_limit(table4))


def test_forward_steer_limit_holds_the_hitch_inside_max_hitch(table4):
    """At the limit steer the steady forward hitch is max_hitch - 1 deg: the hitch rate there is zero."""
    limit = forward_steer_limit(table4)
    assert 0.0 < limit < table4.max_steer
    h = table4.max_hitch - math.radians(1.0)
    rates = full_rhs(table4, np.array([0.0, 0.0, 0.0, h]), np.array([1.0, limit]))
    assert rates[3] == pytest.approx(0.0, abs=1e-12)
    # A tighter steer would settle beyond the limit: at max_steer the hitch keeps growing at max_hitch.
    assert full_rhs(table4, np.array([0.0, 0.0, 0.0, table4.max_hitch]), np.array([1.0, table4.max_steer]))[3] > 0


STAGED = ProcessSettings(kind="staged")  # the forward stage of the 3-stage process (Fig. 7)


@pytest.mark.parametrize(
    ("settings", "plant"),
    [(ManeuverSettings(nmpc=NMPCSettings(kind="paper")), IDEAL), (ManeuverSettings(process=STAGED), None)],
    ids=["paper", "full"],
)
@pytest.mark.parametrize("start", [(4.62, -2.06, 132.24, 15.86), (10.0, 0.0, 180.0, 0.0), (-8.22, -12.17, 147.0, 30.6)])
def test_forward_stage_neither_jackknifes_nor_stalls(table4, start, settings, plant):
    """Starts where an uncapped pursuit jackknifed or drove straight away from the line: they park.

    In the paper's process (plain pure pursuit, the ideal plant) and in the full one (the realistic car).
    """
    x, y, yaw, hitch = start
    result = park(table4, State(x, y, math.radians(yaw), math.radians(hitch)), settings=settings, plant=plant)
    assert result.success, result.reason
    assert any(s.kind == "forward" for s in result.stages)
    assert result.max_abs_hitch_deg < math.degrees(table4.max_hitch)


@given(
    x=st.floats(-30, 30),
    y=st.floats(-30, 30),
    yaw=st.floats(-math.pi, math.pi),
    hitch=st.floats(-1.2, 1.2),
    max_steer=st.floats(0.05, 1.2),
    lookahead=st.floats(0.5, 10.0),
)
def test_steer_never_exceeds_the_limit(x, y, yaw, hitch, max_steer, lookahead):
    vehicle = VehicleTrailer(max_steer=max_steer)
    steer = pure_pursuit_steer(vehicle, Pose(), PurePursuitSettings(lookahead=lookahead), np.array([x, y, yaw, hitch]))
    assert math.isfinite(steer)
    assert abs(steer) <= max_steer


def test_closed_loop_converges_to_the_line(table4):
    """Driving forward with pure pursuit from 1.5 m off the line: the vehicle and trailer settle on it."""
    goal = GOALS[1]
    state = state_in(goal, 0.0, 1.5, math.radians(-10.0), math.radians(15.0))
    for _ in range(300):  # 30 m
        state = step_full(table4, state, SETTINGS.speed, pure_pursuit_steer(table4, goal, SETTINGS, state), 0.1)
    c, s = math.cos(goal.yaw), math.sin(goal.yaw)
    x_r, y_r, yaw_v = rear_axle_pose(table4, *state)
    assert abs(-s * (x_r - goal.x) + c * (y_r - goal.y)) < 0.01
    assert abs(math.remainder(yaw_v - goal.yaw, math.tau)) < math.radians(0.5)
    assert abs(state[3]) < math.radians(1.0)


# --- forward_done: all three conditions --------------------------------------------------------


@pytest.mark.parametrize("goal", GOALS)
def test_forward_done_needs_all_three_conditions(goal):
    s = SETTINGS
    far = s.distance_threshold + 0.5
    small_hitch, small_yaw = 0.5 * s.hitch_threshold, 0.5 * s.orientation_threshold
    assert forward_done(goal, s, state_in(goal, far, 0.3, small_yaw, small_hitch))
    assert forward_done(goal, s, state_in(goal, far, -0.3, -small_yaw, -small_hitch))
    # Each condition missed on its own keeps the stage going.
    assert not forward_done(goal, s, state_in(goal, far, 0.0, 0.0, 1.5 * s.hitch_threshold))
    assert not forward_done(goal, s, state_in(goal, far, 0.0, 0.0, -1.5 * s.hitch_threshold))
    assert not forward_done(goal, s, state_in(goal, s.distance_threshold - 0.5, 0.0, 0.0, 0.0))
    assert not forward_done(goal, s, state_in(goal, far, 0.0, 1.5 * s.orientation_threshold, 0.0))
    assert not forward_done(goal, s, state_in(goal, far, 0.0, -1.5 * s.orientation_threshold, 0.0))
    # The distance counts along the goal heading: far away behind or beside the space is not enough.
    assert not forward_done(goal, s, state_in(goal, -far, 0.0, 0.0, 0.0))
    assert not forward_done(goal, s, state_in(goal, 0.0, 3 * far, 0.0, 0.0))


def test_forward_done_thresholds_come_from_the_settings():
    s = PurePursuitSettings(distance_threshold=2.0, hitch_threshold=0.2, orientation_threshold=0.3)
    state = np.array([3.0, 0.0, 0.25, 0.15])
    assert forward_done(Pose(), s, state)
    assert not forward_done(Pose(), SETTINGS, state)


# --- settings -------------------------------------------------------------------------------------

FIELDS = ("lookahead", "speed", "hitch_threshold", "distance_threshold", "orientation_threshold", "max_distance")


@pytest.mark.parametrize("field", FIELDS)
@pytest.mark.parametrize("value", [0.0, -1.0, math.nan, math.inf, True, "3"])
def test_settings_reject_non_positive_values(field, value):
    with pytest.raises(ValueError, match=f"forward.{field}"):
        PurePursuitSettings(**{field: value})


def test_settings_defaults_are_positive():
    for field in FIELDS:
        assert getattr(SETTINGS, field) > 0
    assert SETTINGS.hitch_threshold < math.radians(5.0)
