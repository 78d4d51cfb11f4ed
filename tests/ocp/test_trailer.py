"""The trailer-parking OCP (Eqs. 47-57, hitchpark.ocp) and its transcriptions."""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from hitchpark.control import NMPCSettings
from hitchpark.model import VehicleTrailer, front_steer_from_virtual, trailer_rhs, virtual_steer_bounds
from hitchpark.ocp.trailer import TrailerParkingProblem
from hitchpark.solvers.transcription import MultipleShooting, SingleShooting, make_transcription

# Table 4.
Q4 = np.diag([1.0, 10.0, 10.0])
R4 = np.diag([0.0, 0.1])
P4 = np.diag([1.0, 10.0, 10.0])

states = st.tuples(st.floats(-20, 20), st.floats(-20, 20), st.floats(-math.pi, math.pi)).map(np.array)
inputs = st.tuples(st.floats(-1, 0), st.floats(-0.5, 0.5)).map(np.array)


@pytest.fixture
def problem(table4) -> TrailerParkingProblem:
    return TrailerParkingProblem(table4)


def as_float(value) -> float:
    return float(np.asarray(ca.DM(value)).item())


# --- settings (Table 4) ------------------------------------------------------------------------


def test_defaults_are_table4():
    s = NMPCSettings(kind="paper")
    assert s.dt == 0.1
    assert s.horizon == 10
    assert s.Q == (1.0, 10.0, 10.0)
    assert s.P == (1.0, 10.0, 10.0)
    assert s.R == (0.0, 0.1)
    assert (s.speed_min, s.speed_max) == (-1.0, 0.0)
    assert s.virtual_limit == 0.5
    assert s.solver == "riccati_c"  # not the paper's (it names none); chosen by `hitchpark bench`
    assert s.transcription in ("multiple_shooting", "single_shooting")


def test_weights_are_stored_as_float_tuples():
    s = NMPCSettings(kind="paper", Q=[1, 2, 3], R=np.array([0, 1]), P=(4, 5, 6))
    assert s.Q == (1.0, 2.0, 3.0) and s.R == (0.0, 1.0) and s.P == (4.0, 5.0, 6.0)
    assert all(isinstance(v, float) for v in (*s.Q, *s.R, *s.P))


BAD_SETTINGS = [
    ({"dt": 0.0}, "nmpc.dt"),
    ({"dt": -0.1}, "nmpc.dt"),
    ({"dt": math.nan}, "nmpc.dt"),
    ({"dt": math.inf}, "nmpc.dt"),
    ({"dt": "0.1"}, "nmpc.dt"),
    ({"horizon": 0}, "nmpc.horizon"),
    ({"horizon": 2.5}, "nmpc.horizon"),
    ({"horizon": True}, "nmpc.horizon"),
    ({"max_steps": 0}, "nmpc.max_steps"),
    ({"Q": (1.0, -10.0, 10.0)}, "nmpc.Q"),
    ({"Q": (math.nan, 10.0, 10.0)}, "nmpc.Q"),
    ({"Q": (1.0, 10.0)}, "nmpc.Q"),
    ({"P": (1.0, 10.0, 10.0, 1.0)}, "nmpc.P"),
    ({"P": (1.0, 10.0, -1e-3)}, "nmpc.P"),
    ({"R": (0.0, 0.1, 0.1)}, "nmpc.R"),
    ({"R": (-1.0, 0.1)}, "nmpc.R"),
    ({"speed_max": 0.5}, "speed_max"),
    ({"speed_min": 0.0}, "speed_min"),
    ({"speed_min": -1.0, "speed_max": -2.0}, "speed_max"),
    ({"speed_max": -0.1}, "nmpc.speed_max"),  # zero speed must stay admissible, or the stage never stops
    ({"speed_min": -1e300}, "nmpc.speed_min"),
    ({"dt": 1e300}, "nmpc.dt"),
    ({"horizon": 100_000_000}, "nmpc.horizon"),
    ({"Q": (0.0, 10.0, 10.0)}, "nmpc.Q"),  # Eq. (49): Q, P > 0
    ({"P": (1.0, 0.0, 10.0)}, "nmpc.P"),
    ({"speed_min": math.nan}, "nmpc.speed_min"),
    ({"virtual_limit": 0.0}, "nmpc.virtual_limit"),
    ({"virtual_limit": 2.0}, "nmpc.virtual_limit"),
    ({"stop_speed": 0.0}, "nmpc.stop_speed"),
    ({"solver": "fmincon"}, "nmpc.solver"),
    ({"fallback_solver": "fmincon"}, "nmpc.fallback_solver"),
    ({"relaxed_solver": "fmincon"}, "nmpc.relaxed_solver"),
    ({"relaxed_solver": "fatrop_c"}, "nmpc.relaxed_solver"),  # structured: it cannot take a relaxed problem
    ({"transcription": "collocation"}, "nmpc.transcription"),
]


@pytest.mark.parametrize(("changes", "field"), BAD_SETTINGS, ids=[str(c) for c, _ in BAD_SETTINGS])
def test_bad_settings_raise_naming_the_field(changes, field):
    with pytest.raises(ValueError, match=field.replace(".", r"\.")):
        NMPCSettings(kind="paper", **changes)


def test_problem_needs_a_hitch_offset():
    with pytest.raises(ValueError, match="hitch_offset"):
        TrailerParkingProblem(VehicleTrailer(hitch_offset=0.0))


# --- Eq. (48): the Euler step of Eq. (47) ----------------------------------------------------


@given(x=states, u=inputs)
def test_discrete_dynamics_is_the_euler_step(x, u):
    vehicle = VehicleTrailer()
    problem = TrailerParkingProblem(vehicle, NMPCSettings(kind="paper", dt=0.05))
    got = np.asarray(problem.discrete_dynamics(x, u), dtype=float).ravel()
    np.testing.assert_allclose(got, x + 0.05 * np.asarray(trailer_rhs(vehicle, x, u)), rtol=0, atol=1e-12)
    v, steer, yaw = u[0], u[1], x[2]
    by_hand = x + 0.05 * np.array([v * math.cos(yaw), v * math.sin(yaw), v / vehicle.trailer_length * math.tan(steer)])
    np.testing.assert_allclose(got, by_hand, rtol=0, atol=1e-12)


def test_discrete_dynamics_symbolic_and_numeric_agree(problem):
    xs, us = ca.SX.sym("x", 3), ca.SX.sym("u", 2)
    g = ca.Function("g", [xs, us], [problem.discrete_dynamics(xs, us)])
    rng = np.random.default_rng(7)
    for _ in range(20):
        x = rng.uniform([-10, -10, -math.pi], [10, 10, math.pi])
        u = rng.uniform([-1, -0.5], [0, 0.5])
        num = np.asarray(problem.discrete_dynamics(x, u), dtype=float).ravel()
        np.testing.assert_allclose(np.asarray(g(x, u)).ravel(), num, rtol=0, atol=1e-12)


def test_zero_speed_does_not_move(problem):
    x = np.array([3.0, -2.0, 0.7])
    np.testing.assert_array_equal(np.asarray(problem.discrete_dynamics(x, np.array([0.0, 0.4]))).ravel(), x)


# --- Eq. (49): the quadratic cost --------------------------------------------------------------


@given(x=states, u=inputs)
def test_costs_are_the_table4_quadratic_forms(x, u):
    problem = TrailerParkingProblem(VehicleTrailer())
    assert as_float(problem.stage_cost(ca.DM(x), ca.DM(u))) == pytest.approx(
        x @ Q4 @ x + u @ R4 @ u, rel=1e-12, abs=1e-12
    )
    assert as_float(problem.terminal_cost(ca.DM(x))) == pytest.approx(x @ P4 @ x, rel=1e-12, abs=1e-12)


def test_costs_follow_the_settings(table4):
    s = NMPCSettings(kind="paper", Q=(2.0, 3.0, 4.0), R=(0.5, 0.25), P=(5.0, 6.0, 7.0))
    problem = TrailerParkingProblem(table4, s)
    x, u = np.array([1.0, -2.0, 0.5]), np.array([-0.5, 0.2])
    assert as_float(problem.stage_cost(ca.DM(x), ca.DM(u))) == pytest.approx(2 + 12 + 1 + 0.125 + 0.01)
    assert as_float(problem.terminal_cost(ca.DM(x))) == pytest.approx(5 + 24 + 1.75)
    # The parked state costs nothing; R's zero speed weight leaves the speed free (Table 4).
    zero = ca.DM.zeros(3)
    assert as_float(TrailerParkingProblem(table4).stage_cost(zero, ca.DM([-1.0, 0.0]))) == 0.0


# --- Eqs. (50), (56)-(57): input bounds ------------------------------------------------------


@pytest.mark.parametrize("hitch_deg", [-70.0, -33.0, -15.0, 0.0, 5.0, 15.0, 40.0, 70.0])
def test_input_bounds_are_speed_and_virtual_steer_bounds(problem, table4, hitch_deg):
    hitch = math.radians(hitch_deg)
    u_min, u_max = problem.input_bounds(hitch)
    low, high = virtual_steer_bounds(table4, hitch, 0.5)
    np.testing.assert_array_equal(u_min, [-1.0, low])
    np.testing.assert_array_equal(u_max, [0.0, high])
    assert low <= high
    if abs(hitch_deg) <= 40.0:  # beyond ~47 deg the two ranges of Eq. (57) no longer meet; the steer limit wins
        assert -0.5 <= low and high <= 0.5
    # Any virtual steer within the bounds maps (Eq. 45) to a front steer within the steer limit.
    for d_t in np.linspace(low, high, 21):
        assert abs(front_steer_from_virtual(table4, hitch, d_t)) <= table4.max_steer + 1e-9


def test_input_bounds_table3_example(table2):
    """Section 4.2's example: Table 2 vehicle, hitch 15 deg -> [-2.2512, 28.6479] deg."""
    problem = TrailerParkingProblem(table2, NMPCSettings(kind="paper", virtual_limit=0.5))
    u_min, u_max = problem.input_bounds(math.radians(15.0))
    assert math.degrees(u_min[1]) == pytest.approx(-2.2512, abs=1e-4)
    assert math.degrees(u_max[1]) == pytest.approx(28.6479, abs=1e-4)


def test_input_bounds_follow_the_settings(table4):
    problem = TrailerParkingProblem(table4, NMPCSettings(kind="paper", speed_min=-0.4, virtual_limit=0.2))
    u_min, u_max = problem.input_bounds(0.0)
    np.testing.assert_allclose(u_min, [-0.4, -0.2])
    np.testing.assert_allclose(u_max, [0.0, 0.2])


# --- transcriptions: layouts of Eqs. (51)-(55) and multiple shooting ----------------------------


@pytest.mark.parametrize("kind", ["multiple_shooting", "single_shooting"])
def test_transcription_layout_and_round_trip(table4, kind):
    problem = TrailerParkingProblem(table4, NMPCSettings(kind="paper", horizon=6, transcription=kind))
    tr = make_transcription(problem)
    assert isinstance(tr, MultipleShooting if kind == "multiple_shooting" else SingleShooting)
    n_w = 6 * 5 + 3 if kind == "multiple_shooting" else 6 * 2
    n_g = 3 * 7 if kind == "multiple_shooting" else 0
    assert tr.nlp["x"].numel() == n_w
    assert tr.nlp["g"].numel() == n_g and len(tr.lbg) == len(tr.ubg) == n_g
    assert np.all(tr.lbg == 0) and np.all(tr.ubg == 0)  # the dynamics as equalities

    x0 = np.array([4.0, 1.0, 0.3])
    us = np.column_stack([np.linspace(-1, -0.2, 6), np.linspace(-0.3, 0.3, 6)])
    w = tr.guess(x0, us)
    assert w.shape == (n_w,)
    xs, us_back = tr.unpack(w, x0)
    np.testing.assert_array_equal(us_back, us)
    assert xs.shape == (7, 3)
    np.testing.assert_allclose(xs[0], x0)
    for k in range(6):  # the guess is the Euler rollout
        np.testing.assert_allclose(xs[k + 1], np.asarray(problem.discrete_dynamics(xs[k], us[k])).ravel(), atol=1e-12)
    # The cost of the guess is Eq. (49) of its rollout.
    f = ca.Function("f", [tr.nlp["x"], tr.nlp["p"]], [tr.nlp["f"]])
    expected = sum(xs[k] @ Q4 @ xs[k] + us[k] @ R4 @ us[k] for k in range(6)) + xs[6] @ P4 @ xs[6]
    assert as_float(f(w, x0)) == pytest.approx(expected, rel=1e-12)

    lb, ub, _, _ = tr.bounds(np.array([-1.0, -0.1]), np.array([0.0, 0.2]))
    assert lb.shape == ub.shape == (n_w,)
    inputs_lb, inputs_ub = tr.unpack(lb, x0)[1], tr.unpack(ub, x0)[1]
    np.testing.assert_array_equal(inputs_lb, np.tile([-1.0, -0.1], (6, 1)))
    np.testing.assert_array_equal(inputs_ub, np.tile([0.0, 0.2], (6, 1)))
    if kind == "multiple_shooting":  # states are free
        assert np.sum(np.isinf(lb)) == np.sum(np.isinf(ub)) == 3 * 7


def test_path_constraints_become_rows_of_g(table4):
    problem = TrailerParkingProblem(table4, NMPCSettings(kind="paper", horizon=4))
    problem.path_constraints.append(lambda x, u, k: (x[1], -0.5, 0.5))
    ms = MultipleShooting(problem)
    assert ms.nlp["g"].numel() == 3 * 5 + 4
    np.testing.assert_array_equal(ms.lbg[-4:], -0.5)
    np.testing.assert_array_equal(ms.ubg[-4:], 0.5)
    ss = SingleShooting(problem)
    assert ss.nlp["g"].numel() == 4
    np.testing.assert_array_equal(ss.lbg, -0.5)
