"""A planned path as the NMPC's reference (ocp.reference) and the tracking OCP (ocp.full)."""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hitchpark.model import VehicleTrailer
from hitchpark.model.state import Pose
from hitchpark.ocp.full import FullParkingProblem
from hitchpark.ocp.reference import BLEND_M, PathReference
from hitchpark.ocp.settings import NMPCSettings

V = VehicleTrailer()


def arc_to_line(goal: Pose, gap_y: float = 0.0, turns: int = 0) -> np.ndarray:
    """A reverse path in the goal's frame: a quarter circle onto the goal line ending 2 m out, ``gap_y``
    beside it, its yaw shifted by ``turns`` whole turns; then in the world frame of ``goal``."""
    r = 6.0
    a = np.linspace(math.pi / 2, 0.0, 80)
    x = 2.0 + r * np.sin(a)
    y = gap_y + r * (1.0 - np.cos(a))
    yaw = a + 2.0 * math.pi * turns  # reversing along the arc: the heading is a, 0 on the line
    c, s = math.cos(goal.yaw), math.sin(goal.yaw)
    return np.column_stack([goal.x + c * x - s * y, goal.y + s * x + c * y, yaw + goal.yaw, np.zeros_like(x)])


def drive_to(ref: PathReference, index: int) -> None:
    """Move the closest point along the path to ``points[index]``, as a car driving it would."""
    for i in range(0, index + 1, 10):
        ref.locate(*ref.points[i, :2])
    ref.locate(*ref.points[index, :2])


def test_the_reference_ends_exactly_at_the_goal_at_rest():
    goal = Pose(3.0, -2.0, 0.7)
    ref = PathReference(arc_to_line(goal, gap_y=0.2), goal, 0.6, 1.0, 0.3, 10)
    np.testing.assert_allclose(ref.points[-1], np.zeros(5), atol=1e-12)
    drive_to(ref, len(ref.points) - 1)
    far = ref.window(np.zeros(6))  # at the goal: the goal at rest, every step
    np.testing.assert_allclose(far, np.zeros((10, 6)), atol=1e-12)


def test_the_gap_to_the_line_closes_gradually_over_the_last_metres_of_the_plan():
    goal = Pose()
    ref = PathReference(arc_to_line(goal, gap_y=0.2), goal, 0.6, 1.0, 0.3, 10)
    plain = PathReference(arc_to_line(goal, gap_y=0.0), goal, 0.6, 1.0, 0.3, 10)
    assert len(ref.points) == len(plain.points)
    on_line = ref.points[:, 0] <= 2.0 + 1e-9
    assert np.all(np.abs(ref.points[on_line, 1]) < 1e-12)  # the straight approach: on the line
    assert np.max(np.hypot(*np.diff(ref.points[:, :2], axis=0).T)) < 0.06  # no jump anywhere
    shift = ref.points[:, 1] - plain.points[:, 1]  # the gap, closed by a smooth step
    seam = int(np.argmax(on_line))
    blend = ref.s >= ref.s[seam] - BLEND_M - 0.05
    np.testing.assert_allclose(shift[~blend], 0.2, atol=1e-9)  # before: the plan's own path
    np.testing.assert_allclose(shift[seam:], 0.0, atol=1e-9)
    assert np.all(np.diff(shift[blend]) <= 1e-12) and np.max(np.abs(np.diff(shift))) < 0.2 * 1.5 * 0.05 / BLEND_M + 1e-3


@settings(max_examples=25, deadline=None)
@given(st.integers(-2, 2), st.floats(-math.pi, math.pi))
def test_the_yaw_is_continuous_ends_at_zero_and_the_measured_yaw_moves_to_its_branch(turns, goal_yaw):
    goal = Pose(1.0, 2.0, goal_yaw)
    ref = PathReference(arc_to_line(goal, turns=turns), goal, 0.6, 1.0, 0.3, 10)
    assert abs(ref.points[-1, 2]) < 1e-12 and np.all(np.abs(np.diff(ref.points[:, 2])) < 0.1)
    ref.locate(ref.points[10, 0], ref.points[10, 1])
    wrapped = math.remainder(ref.points[10, 2], 2 * math.pi)
    assert ref.branch(wrapped) == pytest.approx(ref.points[10, 2], abs=1e-9)


def test_the_window_moves_along_the_path_in_time_and_brakes_to_stop_at_the_goal():
    goal = Pose()
    ref = PathReference(arc_to_line(goal), goal, 0.6, 1.0, 0.3, 10)
    start = ref.points[0]
    w = ref.window(np.array([start[0], start[1], start[2], 0.0, 0.0, 0.0]))
    travelled = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(w[:, :2], axis=0).T))])
    np.testing.assert_allclose(np.diff(travelled), 0.6 * 0.3, rtol=0.02)  # cruise: 0.18 m per step
    assert np.all(w[:, 5] == pytest.approx(-0.6))
    # Near the end it brakes at half max_accel and stops at the goal.
    index = int(np.searchsorted(ref.s, ref.length - 0.2))
    drive_to(ref, index)
    end = ref.points[index]
    w = ref.window(np.array([end[0], end[1], end[2], 0.0, 0.0, 0.0]))
    assert -w[0, 5] <= math.sqrt(2 * 0.5 * 1.0 * 0.2) + 1e-9
    np.testing.assert_allclose(w[-1], np.zeros(6), atol=1e-12)


def test_the_closest_point_never_moves_back():
    goal = Pose()
    ref = PathReference(arc_to_line(goal), goal, 0.6, 1.0, 0.3, 10)
    ref.locate(*ref.points[100, :2])
    ahead = ref.progress
    ref.locate(*ref.points[20, :2])
    assert ref.progress == ahead and ref.deviation > 1.0
    ref.reset()
    assert ref.progress == 0.0


def test_a_path_must_be_rows_of_four():
    with pytest.raises(ValueError, match="rows"):
        PathReference(np.zeros((3, 2)), Pose(), 0.6, 1.0, 0.3, 10)


def test_the_tracking_cost_weighs_the_error_along_and_across_the_reference_heading():
    s = NMPCSettings(kind="full")
    plain = FullParkingProblem(V, s)
    track = FullParkingProblem(V, s, tracking=True)
    assert track.n_p == 6 and plain.n_p == 0
    x, u = np.array([0.3, -0.2, 0.1, 0.05, 0.2, -0.5]), np.array([0.1, -0.2])
    # A reference at rest at the goal: the parking cost.
    assert float(track.stage_cost(ca.DM(x), ca.DM(u), ca.DM(np.zeros(6)))) == pytest.approx(
        float(plain.stage_cost(ca.DM(x), ca.DM(u)))
    )
    assert float(track.terminal_cost(ca.DM(x), ca.DM(np.zeros(6)))) == pytest.approx(
        float(plain.terminal_cost(ca.DM(x)))
    )
    # 1 m behind a reference heading 90 deg is 1 m along it: weighed Q[0], not Q[1].
    q = s.Q
    assert q is not None
    ref = np.array([0.0, 1.0, math.pi / 2, 0.0, 0.0, 0.0])
    cost = float(track.stage_cost(ca.DM(ref + np.array([0.0, -1.0, 0, 0, 0, 0])), ca.DM(np.zeros(2)), ca.DM(ref)))
    assert cost == pytest.approx(q[0])
    cost = float(track.stage_cost(ca.DM(ref + np.array([1.0, 0.0, 0, 0, 0, 0])), ca.DM(np.zeros(2)), ca.DM(ref)))
    assert cost == pytest.approx(q[1])
