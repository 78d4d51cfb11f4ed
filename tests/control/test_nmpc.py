"""The receding-horizon trailer NMPC (Section 4, hitchpark.control.nmpc): steps, frames, failures."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from hitchpark.control import NMPCSettings, TrailerNMPC
from hitchpark.model import (
    Pose,
    VehicleTrailer,
    front_steer_from_virtual,
    rear_speed_from_trailer_speed,
    step_full,
    to_goal_frame,
    virtual_steer_bounds,
    wrap_angle,
)
from hitchpark.model.inverse import virtual_steer_from_front
from hitchpark.model.kinematics import trailer_speed_from_rear_speed
from hitchpark.model.state import clamp

Q4, R4, P4 = np.diag([1.0, 10.0, 10.0]), np.diag([0.0, 0.1]), np.diag([1.0, 10.0, 10.0])

# (x, y, yaw, hitch) in the parking frame: the four scenario starts and one near the goal.
STATES = [
    (10.0, 3.5, 0.0, 0.0),
    (6.0, -3.5, 0.0, math.radians(-20.0)),
    (6.0, 6.0, math.radians(90.0), 0.0),
    (11.96, -1.42, math.radians(39.26), math.radians(16.86)),
    (1.5, 0.3, math.radians(5.0), math.radians(10.0)),
]

GOAL = Pose(5.0, -3.0, math.radians(30.0))

finite = st.floats(-1e3, 1e3)
angles = st.floats(-4 * math.pi, 4 * math.pi)


def world(goal: Pose, x: float, y: float, yaw: float) -> tuple[float, float, float]:
    """Parking-frame pose -> world pose: the inverse of ``to_goal_frame``."""
    c, s = math.cos(goal.yaw), math.sin(goal.yaw)
    return goal.x + c * x - s * y, goal.y + s * x + c * y, yaw + goal.yaw


def horizon_cost(states: np.ndarray, inputs: np.ndarray) -> float:
    """Eq. (49) of a predicted trajectory with the Table 4 weights."""
    stage = sum(x @ Q4 @ x + u @ R4 @ u for x, u in zip(states[:-1], inputs, strict=True))
    return float(stage + states[-1] @ P4 @ states[-1])


@pytest.fixture(scope="module")
def controllers() -> dict[str, TrailerNMPC]:
    vehicle = VehicleTrailer()
    return {
        name: TrailerNMPC(
            vehicle, NMPCSettings(kind="paper", solver=solver, transcription=transcription, fallback_solver=None)
        )
        for name, solver, transcription in (
            ("sqp/ms", "sqp", "multiple_shooting"),
            ("sqp/ss", "sqp", "single_shooting"),
            ("ipopt/ms", "ipopt", "multiple_shooting"),
            ("ipopt/ss", "ipopt", "single_shooting"),
        )
    }


# --- frames -------------------------------------------------------------------------------


def test_wrap_angle_range_and_value():
    a = np.concatenate([np.linspace(-25.0, 25.0, 20001), np.arange(-8, 9) * np.pi, [-np.pi, np.pi, 0.0, -0.0]])
    w = wrap_angle(a)
    assert np.all(w >= -np.pi) and np.all(w < np.pi)
    np.testing.assert_allclose(np.cos(w), np.cos(a), atol=1e-12)
    np.testing.assert_allclose(np.sin(w), np.sin(a), atol=1e-12)
    assert float(wrap_angle(np.pi)) == -np.pi  # the half-open end
    assert float(wrap_angle(0.3)) == pytest.approx(0.3)


@given(st.floats(-1e6, 1e6), st.floats(-50.0, 50.0), st.floats(-50.0, 50.0), st.floats(-3.0, 3.0))
def test_the_scalar_paths_give_what_the_array_paths_give(angle, x, y, yaw):
    """The control loop's floats skip NumPy (wrap_angle, to_goal_frame, clamp): the same answers."""
    scalar, array = wrap_angle(angle), float(wrap_angle(np.array([angle]))[0])
    assert isinstance(scalar, float) and -math.pi <= scalar < math.pi
    assert scalar == pytest.approx(array, abs=1e-12) or abs(abs(scalar - array) - 2 * math.pi) < 1e-9
    goal = Pose(1.5, -2.0, 0.7)
    floats = to_goal_frame(goal, x, y, yaw)
    arrays = to_goal_frame(goal, np.array([x]), np.array([y]), np.array([yaw]))
    for a, b in zip(floats, arrays, strict=True):
        assert isinstance(a, float)
        assert a == pytest.approx(float(b[0]), abs=1e-9) or abs(abs(a - float(b[0])) - 2 * math.pi) < 1e-9
    assert clamp(x, -1.0, 2.0) == float(np.clip(x, -1.0, 2.0))
    assert math.isnan(clamp(math.nan, -1.0, 2.0))
    hitch, steer = yaw / 3.0, yaw / 5.0  # Eqs. (18) and (56) in math for floats, in NumPy for arrays
    v = VehicleTrailer()
    assert trailer_speed_from_rear_speed(v, hitch, -0.8, steer) == pytest.approx(
        float(trailer_speed_from_rear_speed(v, np.array([hitch]), -0.8, np.array([steer]))[0]), abs=1e-12
    )
    assert virtual_steer_from_front(v, hitch, steer) == pytest.approx(
        float(virtual_steer_from_front(v, np.array([hitch]), np.array([steer]))[0]), abs=1e-12
    )


def test_wrap_angle_just_below_minus_pi():
    assert float(wrap_angle(np.nextafter(-np.pi, -4.0))) < np.pi


@given(x=finite, y=finite, yaw=angles, gx=finite, gy=finite, gyaw=angles)
def test_to_goal_frame_round_trip(x, y, yaw, gx, gy, gyaw):
    goal = Pose(gx, gy, gyaw)
    lx, ly, lyaw = to_goal_frame(goal, x, y, yaw)
    assert -math.pi <= float(lyaw) <= math.pi
    bx, by, byaw = world(goal, float(lx), float(ly), float(lyaw))
    assert bx == pytest.approx(x, abs=1e-9) and by == pytest.approx(y, abs=1e-9)
    assert math.cos(byaw - yaw) == pytest.approx(1.0, abs=1e-12)
    # Distances are kept.
    assert math.hypot(lx, ly) == pytest.approx(math.hypot(x - gx, y - gy), rel=1e-12, abs=1e-9)


def test_to_goal_frame_examples_and_arrays():
    goal = Pose(1.0, 2.0, math.pi / 2)
    np.testing.assert_allclose(to_goal_frame(goal, 1.0, 2.0, math.pi / 2), (0.0, 0.0, 0.0), atol=1e-15)
    np.testing.assert_allclose(to_goal_frame(goal, 1.0, 5.0, math.pi), (3.0, 0.0, math.pi / 2), atol=1e-15)
    np.testing.assert_allclose(to_goal_frame(goal, 0.0, 2.0, 0.0), (0.0, 1.0, -math.pi / 2), atol=1e-15)
    xs, _, yaws = to_goal_frame(goal, np.array([1.0, 1.0]), np.array([2.0, 5.0]), np.array([0.0, math.pi]))
    np.testing.assert_allclose(xs, [0.0, 3.0], atol=1e-15)
    np.testing.assert_allclose(yaws, [-math.pi / 2, math.pi / 2], atol=1e-15)


def test_pose_rejects_non_finite_and_round_trips():
    for bad in ({"x": math.nan}, {"y": math.inf}, {"yaw": -math.inf}):
        with pytest.raises(ValueError, match=f"goal {next(iter(bad))}"):
            Pose(**bad)
    assert Pose.from_dict(GOAL.to_dict()).yaw == pytest.approx(GOAL.yaw)
    assert GOAL.to_dict() == pytest.approx({"x": 5.0, "y": -3.0, "yaw_deg": 30.0})


# --- one step -------------------------------------------------------------------------------


@pytest.mark.parametrize("state", STATES)
def test_step_applies_bounded_u0_through_the_inverse_kinematics(controllers, state):
    nmpc = controllers["sqp/ms"]
    nmpc.reset()
    u = nmpc.step(*state)
    s, vehicle, hitch = nmpc.settings, nmpc.vehicle, state[3]
    assert u.ok and u.status
    assert not u.stop
    assert s.speed_min <= u.trailer_speed <= -s.stop_speed
    low, high = virtual_steer_bounds(vehicle, hitch, s.virtual_limit)
    assert low <= u.virtual_steer <= high
    assert u.front_steer == pytest.approx(front_steer_from_virtual(vehicle, hitch, u.virtual_steer), abs=1e-12)
    assert abs(u.front_steer) <= vehicle.max_steer
    assert u.rear_speed == pytest.approx(
        rear_speed_from_trailer_speed(vehicle, hitch, u.virtual_steer, u.trailer_speed), abs=1e-12
    )
    # The prediction starts at the state, follows Eq. (48) from U, costs what the solver says (Eq. 49).
    assert u.predicted_states.shape == (s.horizon + 1, 3) and u.predicted_inputs.shape == (s.horizon, 2)
    np.testing.assert_allclose(u.predicted_states[0], state[:3], atol=1e-9)
    for k in range(s.horizon):
        x, (v, d) = u.predicted_states[k], u.predicted_inputs[k]
        step = x + s.dt * np.array([v * math.cos(x[2]), v * math.sin(x[2]), v / vehicle.trailer_length * math.tan(d)])
        np.testing.assert_allclose(u.predicted_states[k + 1], step, atol=1e-7)
    assert u.cost == pytest.approx(horizon_cost(u.predicted_states, u.predicted_inputs), rel=1e-6)
    assert u.cost < horizon_cost(np.tile(state[:3], (s.horizon + 1, 1)), np.zeros((s.horizon, 2)))  # beats standing
    np.testing.assert_array_equal((u.predicted_inputs[:, 0] <= s.speed_max + 1e-8), True)
    np.testing.assert_array_equal((u.predicted_inputs[:, 0] >= s.speed_min - 1e-8), True)


@pytest.mark.parametrize("state", STATES)
def test_transcriptions_and_solvers_agree_on_u0(controllers, state):
    answers = {}
    for name, nmpc in controllers.items():
        nmpc.reset()
        u = nmpc.step(*state)
        assert u.ok, f"{name}: {u.status}"
        answers[name] = np.array([u.trailer_speed, u.virtual_steer])
    ref = answers["sqp/ms"]
    np.testing.assert_allclose(answers["sqp/ss"], ref, rtol=0, atol=1e-5)
    np.testing.assert_allclose(answers["ipopt/ms"], ref, rtol=0, atol=1e-5)
    np.testing.assert_allclose(answers["ipopt/ss"], ref, rtol=0, atol=1e-5)


@pytest.mark.parametrize("state", STATES)
def test_step_does_not_depend_on_the_world_frame(controllers, state):
    at_origin = controllers["sqp/ms"]
    at_origin.reset()
    u0 = at_origin.step(*state)
    at_origin.reset()
    u1 = at_origin.step(*world(GOAL, *state[:3]), state[3], GOAL)  # the same controller serves any goal
    assert u1.ok and u0.ok
    for field in ("trailer_speed", "virtual_steer", "rear_speed", "front_steer", "cost"):
        assert getattr(u1, field) == pytest.approx(getattr(u0, field), rel=1e-7, abs=1e-8), field
    np.testing.assert_allclose(u1.predicted_states[:, :2], u0.predicted_states[:, :2], atol=1e-7)


def test_at_the_goal_the_answer_is_zero_speed(controllers):
    nmpc = controllers["sqp/ms"]
    nmpc.reset(front_steer=0.1)
    u = nmpc.step(0.0, 0.0, 0.0, 0.0)
    assert u.ok and u.stop
    assert abs(u.trailer_speed) < nmpc.settings.stop_speed
    assert u.rear_speed == 0.0
    assert u.cost == pytest.approx(0.0, abs=1e-6)


def test_closed_loop_reduces_the_cost():
    """Receding horizon from the parallel start: the optimal cost falls at every step until the stop."""
    vehicle = VehicleTrailer()
    nmpc = TrailerNMPC(vehicle)
    state = np.array([10.0, 3.5, 0.0, 0.0])
    costs = []
    for _ in range(200):
        u = nmpc.step(*state)
        assert u.ok
        if u.stop:
            break
        costs.append(u.cost)
        state = step_full(vehicle, state, u.rear_speed, u.front_steer, nmpc.settings.dt)
    else:
        pytest.fail("no stop within 200 steps")
    assert len(costs) > 50
    assert costs[-1] < 0.01 * costs[0]
    assert np.all(np.diff(costs) < 1e-6 * costs[0])


def test_controller_needs_a_hitch_offset():
    with pytest.raises(ValueError, match="hitch_offset"):
        TrailerNMPC(VehicleTrailer(hitch_offset=0.0))


# --- failures: a stop, never a bad command --------------------------------------------------------


@pytest.mark.parametrize(
    ("solver", "options"), [("sqp", {"max_iter": 0}), ("ipopt", {"ipopt.max_iter": 0})], ids=["sqp", "ipopt"]
)
def test_solver_failure_commands_a_stop(solver, options):
    nmpc = TrailerNMPC(
        VehicleTrailer(), NMPCSettings(kind="paper", solver=solver, fallback_solver=None, solver_options=options)
    )
    assert nmpc.fallback is None
    u = nmpc.step(10.0, 3.5, 0.0, math.radians(10.0))
    assert nmpc.solver.stats()["success"] is False  # the options do make it fail
    assert u.ok is False and u.stop is True
    assert "Maximum_Iterations_Exceeded" in u.status
    assert u.rear_speed == 0.0 and u.trailer_speed == 0.0
    assert math.isfinite(u.front_steer) and abs(u.front_steer) <= nmpc.vehicle.max_steer
    assert math.isfinite(u.virtual_steer)


def test_fallback_solver_rescues_a_failing_primary():
    nmpc = TrailerNMPC(
        VehicleTrailer(),
        NMPCSettings(kind="paper", solver="sqp", fallback_solver="ipopt", solver_options={"max_iter": 0}),
    )
    u = nmpc.step(10.0, 3.5, 0.0, 0.0)
    assert nmpc.solver.stats()["success"] is False
    assert u.ok and not u.stop and u.trailer_speed < 0.0


class BrokenSolver:
    """A stand-in for a CasADi nlpsol that answers NaN while claiming success, or raises."""

    def __init__(self, mode: str):
        self.mode, self.calls = mode, 0

    def __call__(self, **kwargs):
        self.calls += 1
        if self.mode == "raise":
            raise RuntimeError("Error in Function::call for 'trailer_nmpc': NaN detected\nmore detail")
        return {"x": np.full(len(kwargs["x0"]), np.nan), "f": np.nan}

    def stats(self):
        return {"success": True, "return_status": "Solve_Succeeded"}


@pytest.mark.parametrize(("mode", "status"), [("nan", "non-finite"), ("raise", "solver error")])
def test_broken_solver_after_good_steps_holds_the_steer_and_stops(monkeypatch, mode, status):
    vehicle = VehicleTrailer()
    nmpc = TrailerNMPC(vehicle)
    state = np.array([6.0, -3.5, 0.0, math.radians(-20.0)])
    for _ in range(8):
        good = nmpc.step(*state)
        assert good.ok and not good.stop
        state = step_full(vehicle, state, good.rear_speed, good.front_steer, nmpc.settings.dt)
    assert good.front_steer != 0.0
    broken, broken_fallback = BrokenSolver(mode), BrokenSolver(mode)
    monkeypatch.setattr(nmpc, "solver", broken)
    monkeypatch.setattr(nmpc, "fallback", broken_fallback)
    u = nmpc.step(*state)
    assert (broken.calls, broken_fallback.calls) == (1, 2)  # primary, fallback, then the fallback from a cold start
    assert u.ok is False and u.stop is True
    assert status in u.status and "\n" not in u.status
    command = (u.trailer_speed, u.virtual_steer, u.rear_speed, u.front_steer)
    assert all(math.isfinite(v) for v in command)
    assert u.rear_speed == 0.0 and u.trailer_speed == 0.0
    assert u.front_steer == good.front_steer  # held: no jump of the wheel
    monkeypatch.undo()
    again = nmpc.step(*state)  # the real solver is back: the controller recovers from a cold start
    assert again.ok and not again.stop
