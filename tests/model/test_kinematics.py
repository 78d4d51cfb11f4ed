"""Full model (Eqs. 19-24) and trailer-only model (Eq. 47).

Three kinds of check: closed-form answers (turning circle, steady hitch angle,
straight line), an independent first-principles model integrated with SciPy, and
agreement of the NumPy and CasADi evaluations of the same equations.
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from hitchpark.model import (
    FULL_INPUT,
    FULL_STATE,
    TRAILER_INPUT,
    TRAILER_STATE,
    VehicleTrailer,
    full_rates,
    full_rhs,
    hitch_point,
    rear_axle_pose,
    rk4,
    step_full,
    trailer_rhs,
    trailer_speed_from_rear_speed,
)
from hitchpark.model.simulate import State, simulate


def fit_circle(x: np.ndarray, y: np.ndarray) -> tuple[float, float, float]:
    """Least-squares circle through points: x^2 + y^2 = 2 a x + 2 b y + c; returns (a, b, radius)."""
    design = np.column_stack([2.0 * x, 2.0 * y, np.ones_like(x)])
    (a, b, c), *_ = np.linalg.lstsq(design, x**2 + y**2, rcond=None)
    return float(a), float(b), math.sqrt(c + a * a + b * b)


def steady_hitch(vehicle: VehicleTrailer, steer: float) -> float:
    """Hitch angle at which the trailer turns with the vehicle (Eq. 24 = Eq. 21).

    sin h - (L_H / R) cos h = L_T / R with R = L / tan(steer). For steer > 0,
    sqrt(1 + (L_H/R)^2) sin(h - atan(L_H/R)) = L_T / R, so
    h = atan(L_H / R) + asin(L_T / sqrt(R^2 + L_H^2)); the map is odd in the steer.
    """
    radius = vehicle.wheelbase / math.tan(abs(steer))
    L_H, L_T = vehicle.hitch_offset, vehicle.trailer_length
    h = math.atan(L_H / radius) + math.asin(L_T / math.hypot(radius, L_H))
    return math.copysign(h, steer)


def steady_residual(vehicle: VehicleTrailer, hitch: float, steer: float) -> float:
    """sin h - (L_H/L) cos h tan d - (L_T/L) tan d: zero at the steady hitch angle."""
    L, L_H, L_T = vehicle.wheelbase, vehicle.hitch_offset, vehicle.trailer_length
    t = math.tan(steer)
    return math.sin(hitch) - L_H / L * math.cos(hitch) * t - L_T / L * t


def test_names_of_states_and_inputs():
    assert FULL_STATE == ("x_trailer", "y_trailer", "yaw_trailer", "hitch")
    assert FULL_INPUT == ("rear_speed", "front_steer")
    assert TRAILER_STATE == ("x_trailer", "y_trailer", "yaw_trailer")
    assert TRAILER_INPUT == ("trailer_speed", "virtual_steer")


# --- analytic answers --------------------------------------------------------------------------


@pytest.mark.parametrize("hitch_offset", [1.159, 0.0])
@pytest.mark.parametrize("rear_speed", [1.0, -1.0])
@pytest.mark.parametrize("steer", [0.3, -0.65])
def test_rear_axle_moves_on_circle_of_radius_L_over_tan_delta(hitch_offset, rear_speed, steer):
    vehicle = VehicleTrailer(hitch_offset=hitch_offset)
    radius = vehicle.wheelbase / math.tan(steer)  # signed: > 0 turns left
    # Start at the steady hitch angle so that reversing stays clear of the jackknife limit.
    start = State(0.5, -1.0, 0.3, steady_hitch(vehicle, steer))
    result = simulate(vehicle, start, rear_speed, steer, duration=70.0, dt=0.2)
    assert result.reason == "completed"
    tr = result.trajectory
    assert tr["t"][-1] == pytest.approx(70.0)

    x, y, yaw_v = tr["x_rear"], tr["y_rear"], tr["yaw_vehicle"]
    centre_x = x[0] - radius * math.sin(yaw_v[0])
    centre_y = y[0] + radius * math.cos(yaw_v[0])
    distance = np.hypot(x - centre_x, y - centre_y)
    np.testing.assert_allclose(distance, abs(radius), rtol=0, atol=1e-9)

    a, b, fitted = fit_circle(x, y)
    assert fitted == pytest.approx(abs(radius), abs=1e-9)
    assert (a, b) == pytest.approx((centre_x, centre_y), abs=1e-9)
    # 70 m of travel is more than one lap of every circle here: the whole circle was traced.
    assert 70.0 > 2 * math.pi * abs(radius)
    # The vehicle yaw grows at V_R tan(delta) / L (Eq. 21).
    np.testing.assert_allclose(
        np.unwrap(yaw_v) - yaw_v[0], rear_speed * math.tan(steer) / vehicle.wheelbase * tr["t"], atol=1e-9
    )


@pytest.mark.parametrize(
    ("hitch_offset", "steer"), [(0.0, 0.3), (0.0, -0.6), (1.159, -0.3), (1.159, 0.6), (2.0, -0.65)]
)
def test_steady_forward_hitch_angle(hitch_offset, steer):
    vehicle = VehicleTrailer(hitch_offset=hitch_offset)
    expected = steady_hitch(vehicle, steer)

    # The closed form solves the steady-state equation ...
    assert steady_residual(vehicle, expected, steer) == pytest.approx(0.0, abs=1e-14)
    # ... is where the hitch angle stops changing in the model ...
    yaw_rate_v, yaw_rate_t, _ = full_rates(vehicle, expected, 1.0, steer)
    assert yaw_rate_t == pytest.approx(yaw_rate_v, abs=1e-14)
    if hitch_offset == 0.0:
        assert expected == pytest.approx(math.asin(vehicle.trailer_length * math.tan(steer) / vehicle.wheelbase))

    # ... and is what a long forward drive from a straight hitch settles to.
    result = simulate(vehicle, State(0.0, 0.0, 0.0, 0.0), 2.0, steer, duration=60.0, dt=0.2)
    assert result.reason == "completed"
    hitch = result.trajectory["hitch"]
    assert hitch[-1] == pytest.approx(expected, abs=1e-9)
    assert abs(hitch[-1]) > 0.1  # a real turn, not a trivial zero

    # At steady state the trailer axle also circles the vehicle's turn centre,
    # at radius sqrt(R^2 + L_H^2 - L_T^2) (right triangle at the trailer axle).
    radius = vehicle.wheelbase / abs(math.tan(steer))
    tr = result.trajectory
    tail = slice(len(tr) - 50, None)
    _, _, trailer_radius = fit_circle(tr["x_trailer"][tail], tr["y_trailer"][tail])
    expected_radius = math.sqrt(radius**2 + hitch_offset**2 - vehicle.trailer_length**2)
    assert trailer_radius == pytest.approx(expected_radius, rel=1e-7)


@pytest.mark.parametrize("rear_speed", [1.5, -0.8])
@pytest.mark.parametrize("hitch_offset", [0.0, 1.159])
def test_straight_driving_keeps_hitch_zero(rear_speed, hitch_offset):
    vehicle = VehicleTrailer(hitch_offset=hitch_offset)
    yaw = 0.7
    result = simulate(vehicle, State(2.0, -3.0, yaw, 0.0), rear_speed, 0.0, duration=10.0, dt=0.1)
    tr = result.trajectory
    assert result.reason == "completed"
    assert np.all(tr["hitch"] == 0.0)
    assert np.all(tr["yaw_trailer"] == yaw)
    travelled = rear_speed * tr["t"]
    np.testing.assert_allclose(tr["x_trailer"], 2.0 + travelled * math.cos(yaw), atol=1e-12)
    np.testing.assert_allclose(tr["y_trailer"], -3.0 + travelled * math.sin(yaw), atol=1e-12)
    assert math.hypot(tr["x_trailer"][-1] - 2.0, tr["y_trailer"][-1] + 3.0) == pytest.approx(abs(rear_speed) * 10.0)


def test_trailer_only_model_turns_on_circle_of_radius_L_T_over_tan_virtual_steer(table2):
    trailer_speed, virtual_steer = -1.0, 0.3
    state = np.array([1.0, 2.0, -0.4])
    points = [state]
    for _ in range(400):
        state = rk4(lambda x: trailer_rhs(table2, x, [trailer_speed, virtual_steer]), state, 0.1)
        points.append(state)
    pts = np.array(points)
    _, _, radius = fit_circle(pts[:, 0], pts[:, 1])
    assert radius == pytest.approx(table2.trailer_length / math.tan(virtual_steer), rel=1e-9)
    rate = trailer_rhs(table2, pts[0], [trailer_speed, virtual_steer])[2]
    assert rate == pytest.approx(trailer_speed / table2.trailer_length * math.tan(virtual_steer))  # Eq. (42)


# --- geometry -----------------------------------------------------------------------------------


def test_rear_axle_pose_follows_the_links(table4):
    x_t, y_t, yaw_t, hitch = 1.0, -2.0, 0.4, -0.3
    x_h, y_h = hitch_point(table4, x_t, y_t, yaw_t)
    assert math.hypot(x_h - x_t, y_h - y_t) == pytest.approx(table4.trailer_length)
    assert math.atan2(y_h - y_t, x_h - x_t) == pytest.approx(yaw_t)  # hitch ahead of the trailer axle
    x_r, y_r, yaw_v = rear_axle_pose(table4, x_t, y_t, yaw_t, hitch)
    assert yaw_v == pytest.approx(yaw_t + hitch)
    assert math.hypot(x_r - x_h, y_r - y_h) == pytest.approx(table4.hitch_offset)
    assert math.atan2(y_r - y_h, x_r - x_h) == pytest.approx(yaw_v)  # rear axle ahead of the hitch


def test_trailer_speed_from_rear_speed_is_the_trailer_axle_speed(table4):
    """Eq. (18): the speed in Eqs. (22)-(23) is the trailer-axle speed along its heading."""
    state = np.array([0.0, 0.0, 0.5, 0.4])
    rates = full_rhs(table4, state, [-0.9, 0.2])
    v_t = trailer_speed_from_rear_speed(table4, 0.4, -0.9, 0.2)
    assert rates[0] == pytest.approx(v_t * math.cos(0.5))
    assert rates[1] == pytest.approx(v_t * math.sin(0.5))
    assert v_t < 0  # reversing vehicle, reversing trailer at this small hitch angle


# --- independent cross-check ------------------------------------------------------------------


def first_principles_rhs(vehicle: VehicleTrailer, rear_speed: float, steer):
    """(X_R, Y_R, psi_1, psi_2) model from rigid-body kinematics, written without the paper's equations."""
    L, L_H, L_T = vehicle.wheelbase, vehicle.hitch_offset, vehicle.trailer_length

    def rhs(t, z):
        _, _, psi1, psi2 = z
        heading = np.array([math.cos(psi1), math.sin(psi1)])
        psi1_dot = rear_speed * math.tan(steer(t)) / L
        # Hitch point sits L_H behind the rear axle on the vehicle body.
        v_hitch = rear_speed * heading + psi1_dot * L_H * np.array([math.sin(psi1), -math.cos(psi1)])
        normal2 = np.array([-math.sin(psi2), math.cos(psi2)])
        psi2_dot = float(v_hitch @ normal2) / L_T  # the trailer axle cannot slip sideways
        return [rear_speed * heading[0], rear_speed * heading[1], psi1_dot, psi2_dot]

    return rhs


@pytest.mark.parametrize("hitch_offset", [0.0, 1.159])
@pytest.mark.parametrize("rear_speed", [1.0, -1.0])
def test_full_model_matches_first_principles_model(hitch_offset, rear_speed):
    vehicle = VehicleTrailer(hitch_offset=hitch_offset)
    L_H, L_T = vehicle.hitch_offset, vehicle.trailer_length

    def steer(t):
        return 0.25 * math.sin(0.6 * t) + 0.05

    x_t0, y_t0, psi2_0, hitch0 = 1.0, -2.0, 0.4, 0.2
    psi1_0 = psi2_0 + hitch0
    x_r0 = x_t0 + L_T * math.cos(psi2_0) + L_H * math.cos(psi1_0)
    y_r0 = y_t0 + L_T * math.sin(psi2_0) + L_H * math.sin(psi1_0)

    dt, n = 0.1, 120
    times = dt * np.arange(n + 1)
    ref = solve_ivp(
        first_principles_rhs(vehicle, rear_speed, steer),
        (0.0, times[-1]),
        [x_r0, y_r0, psi1_0, psi2_0],
        method="DOP853",
        t_eval=times,
        rtol=1e-11,
        atol=1e-12,
    )
    assert ref.success
    x_r, y_r, psi1, psi2 = ref.y
    x_t_ref = x_r - L_H * np.cos(psi1) - L_T * np.cos(psi2)
    y_t_ref = y_r - L_H * np.sin(psi1) - L_T * np.sin(psi2)

    def rhs(z):
        return np.concatenate(([1.0], full_rhs(vehicle, z[1:], [rear_speed, steer(z[0])])))

    z = np.array([0.0, x_t0, y_t0, psi2_0, hitch0])
    rows = [z]
    for _ in range(n):
        z = rk4(rhs, z, dt, substeps=20)
        rows.append(z)
    ours = np.array(rows)

    np.testing.assert_allclose(ours[:, 0], times, atol=1e-12)
    np.testing.assert_allclose(ours[:, 1], x_t_ref, atol=1e-8)
    np.testing.assert_allclose(ours[:, 2], y_t_ref, atol=1e-8)
    np.testing.assert_allclose(ours[:, 3], psi2, atol=1e-8)
    np.testing.assert_allclose(ours[:, 4], psi1 - psi2, atol=1e-8)
    # The run is not trivial: the hitch angle really moved.
    assert np.ptp(ours[:, 4]) > 0.1


def test_numpy_arrays_broadcast_like_single_columns(table4):
    rng = np.random.default_rng(7)
    states = rng.uniform(-1.0, 1.0, size=(4, 6))
    inputs = np.vstack([rng.uniform(-1, 1, 6), rng.uniform(-0.7, 0.7, 6)])
    together = full_rhs(table4, states, inputs)
    assert together.shape == (4, 6)
    for k in range(6):
        np.testing.assert_array_equal(together[:, k], full_rhs(table4, states[:, k], inputs[:, k]))
    trailer_together = trailer_rhs(table4, states[:3], inputs)
    assert trailer_together.shape == (3, 6)


def test_casadi_and_numpy_evaluate_the_same_equations(table4):
    x = ca.SX.sym("x", 4)
    u = ca.SX.sym("u", 2)
    full = ca.Function("full", [x, u], [full_rhs(table4, x, u)])
    xt = ca.SX.sym("xt", 3)
    ut = ca.SX.sym("ut", 2)
    trailer = ca.Function("trailer", [xt, ut], [trailer_rhs(table4, xt, ut)])
    state = np.array([0.3, -1.2, 0.8, -0.35])
    inputs = np.array([-0.7, 0.4])
    np.testing.assert_allclose(np.array(full(state, inputs)).ravel(), full_rhs(table4, state, inputs), atol=1e-14)
    np.testing.assert_allclose(
        np.array(trailer(state[:3], inputs)).ravel(), trailer_rhs(table4, state[:3], inputs), atol=1e-14
    )


def test_step_full_is_rk4_of_full_rhs(table4):
    state = np.array([0.0, 1.0, 0.2, 0.1])
    expected = rk4(lambda x: full_rhs(table4, x, [-1.0, 0.3]), state, 0.1, substeps=7)
    np.testing.assert_array_equal(step_full(table4, state, -1.0, 0.3, 0.1, substeps=7), expected)
