"""The full-model NMPC (hitchpark.ocp.full, FullNMPC): limits on the whole horizon, goal, delay, failure."""

from __future__ import annotations

import math
from dataclasses import replace

import casadi as ca
import numpy as np
import pytest

from hitchpark import InputError
from hitchpark.control import FullNMPC, NMPCSettings
from hitchpark.model import Command, Measurement, Pose, State, VehicleTrailer

V = VehicleTrailer()
SETTINGS = NMPCSettings()
STARTS = [
    State(10.0, 3.5, 0.0, 0.0),
    State(11.96, -1.42, math.radians(39.26), math.radians(16.86)),
    State(6.0, -3.5, 0.0, math.radians(-20.0)),
    State(8.0, 2.0, math.radians(-30.0), math.radians(50.0)),
]


@pytest.fixture(scope="module")
def nmpc():
    return FullNMPC(V, SETTINGS)


def world(goal, x, y, yaw):
    c, s = math.cos(goal.yaw), math.sin(goal.yaw)
    return goal.x + c * x - s * y, goal.y + s * x + c * y, yaw + goal.yaw


@pytest.mark.parametrize("start", STARTS)
@pytest.mark.parametrize("steer", [0.0, -0.5])
def test_every_limit_holds_on_the_whole_horizon(nmpc, start, steer):
    nmpc.reset()
    u = nmpc.act(Measurement(0.0, start, steer, -0.3), Pose())
    assert u.ok, u.status
    xs, us = u.predicted_states, u.predicted_inputs
    tol = 1e-6
    assert np.all(np.abs(xs[1:, 3]) <= V.max_hitch - SETTINGS.hitch_margin + tol)
    assert np.all(np.abs(xs[:, 4]) <= V.max_steer + tol)
    assert np.all((xs[1:, 5] >= SETTINGS.speed_min - tol) & (xs[1:, 5] <= tol))
    assert np.all(np.abs(us[:, 0]) <= V.max_steer_rate + tol) and np.all(np.abs(us[:, 1]) <= V.max_accel + tol)
    # The command moves the wheels and the speed no faster than the limits allow in one sample.
    assert abs(u.front_steer - steer) <= V.max_steer_rate * SETTINGS.dt + 1e-9
    assert abs(u.rear_speed + 0.3) <= V.max_accel * SETTINGS.dt + 1e-9
    assert abs(u.front_steer) <= V.max_steer and u.rear_speed <= 0.0


def test_the_goal_is_a_parameter_of_the_step(nmpc):
    goal = Pose(-40.0, 25.0, math.radians(120.0))
    start = STARTS[1]
    nmpc.reset()
    u0 = nmpc.act(Measurement(0.0, start, 0.1, 0.0), Pose())
    nmpc.reset()
    moved = State(*world(goal, start.x, start.y, start.yaw), start.hitch)
    u1 = nmpc.act(Measurement(0.0, moved, 0.1, 0.0), goal)
    assert u0.ok and u1.ok
    assert u1.front_steer == pytest.approx(u0.front_steer, abs=1e-7)
    assert u1.rear_speed == pytest.approx(u0.rear_speed, abs=1e-7)


def test_commands_in_flight_are_predicted_before_solving(nmpc):
    m = Measurement(0.0, STARTS[0], 0.0, -0.5)
    in_flight = (Command(-0.6, 0.05), Command(-0.7, 0.1))
    x = nmpc._state(m, Pose(), in_flight)
    # The steer and speed moved by the commands (each within one sample's rate), the trailer backed up.
    assert x[4] == pytest.approx(0.1) and x[5] == pytest.approx(-0.7)
    assert x[0] < STARTS[0].x - 0.1


def test_initial_steer_is_within_the_limit_and_keeps_the_warm_start_clear(nmpc):
    steer = nmpc.initial_steer(Measurement(0.0, STARTS[1], 0.0, 0.0), Pose())
    assert steer is not None and abs(steer) <= V.max_steer + 1e-9
    assert nmpc._last_inputs is None


def test_solver_failure_commands_a_stop_with_the_steer_held():
    broken = FullNMPC(V, replace(SETTINGS, solver="ipopt", fallback_solver=None, solver_options={"ipopt.max_iter": 0}))
    u = broken.act(Measurement(0.0, STARTS[1], 0.2, -0.4), Pose())
    assert not u.ok and u.stop and u.rear_speed == 0.0 and math.isfinite(u.front_steer)


def test_a_non_finite_warm_start_is_not_handed_to_the_solver_the_step_stops(monkeypatch):
    """fatrop given a NaN start iterates without end; the controller stops instead, steer held, and
    recovers once its starts are finite again."""
    nmpc = FullNMPC(V, SETTINGS)
    measurement = Measurement(0.0, STARTS[1], 0.2, -0.4)
    good = nmpc.act(measurement, Pose())
    assert good.ok
    guess = nmpc._initial_guess

    def broken(*args, **kwargs):
        w = np.array(guess(*args, **kwargs), dtype=float)
        w[len(w) // 2] = math.nan
        return w

    monkeypatch.setattr(nmpc, "_initial_guess", broken)
    nmpc.recorder = []
    u = nmpc.act(measurement, Pose())
    assert not u.ok and u.stop and u.rear_speed == 0.0
    assert "non-finite solver input" in u.status
    assert u.front_steer == good.front_steer  # held: no jump of the wheel
    assert nmpc.recorder == []  # nor recorded for bench, which would replay it to fatrop
    monkeypatch.undo()
    assert nmpc.act(measurement, Pose()).ok
    assert len(nmpc.recorder) == 1


def test_non_finite_or_jackknifed_measurements_are_refused(nmpc):
    with pytest.raises(InputError, match="x must be finite"):  # a non-finite state cannot even be made
        State(math.nan, 0.0, 0.0, 0.0)
    u = nmpc.act(Measurement(0.0, State(1.0, 0.0, 0.0, math.radians(75.0)), 0.0, 0.0), Pose())
    assert not u.ok and u.rear_speed == 0.0  # past the jackknife limit: a stop, not a plan


def test_settings_per_kind_and_solver_options_in_equality():
    full, paper = NMPCSettings(), NMPCSettings(kind="paper")
    assert (len(full.Q), len(full.R), full.solver) == (6, 2, "riccati_c")
    assert (len(paper.Q), paper.horizon, paper.solver) == (3, 10, "riccati_c")
    single = NMPCSettings(kind="paper", transcription="single_shooting")
    assert single.solver == "sqp"  # fatrop needs the stages of multiple shooting
    with pytest.raises(InputError, match=r"needs nmpc\.transcription 'multiple_shooting'"):
        NMPCSettings(kind="paper", transcription="single_shooting", solver="fatrop_c")
    assert NMPCSettings(solver_options={"max_iter": 5}) != NMPCSettings()
    with pytest.raises(InputError, match=r"nmpc\.Q must be a list of 6"):
        NMPCSettings(Q=(1.0, 1.0, 1.0))
    with pytest.raises(InputError, match=r"nmpc\.solver must be one of"):
        NMPCSettings(solver="magic")
    with pytest.raises(InputError, match="not accepted by"):
        FullNMPC(V, NMPCSettings(solver_options={"no_such_option": 1}))


# --- the prediction grid stays put in time: the first step shortens as the samples pass ------------------


def test_the_first_prediction_step_lasts_the_nlps_last_parameter_and_weighs_its_part_of_a_step():
    from hitchpark.ocp.full import FullParkingProblem
    from hitchpark.solvers.transcription import MultipleShooting, SingleShooting

    problem = FullParkingProblem(V, SETTINGS)
    ms = MultipleShooting(problem)
    nlp = ms.nlp
    f_g = ca.Function("fg", [nlp["x"], nlp["p"]], [nlp["f"], nlp["g"]])
    x0 = np.array([3.0, 0.5, 0.1, 0.05, 0.02, -0.5])
    u0 = np.array([0.1, 0.2])
    n_p = nlp["p"].numel()
    for h0 in (0.1, 0.2, 0.3):
        x1 = np.asarray(problem.discrete_dynamics(ca.DM(x0), ca.DM(u0), h0)).ravel()
        inputs = np.zeros((problem.horizon, 2))
        inputs[0] = u0
        states = np.zeros((problem.horizon + 1, 6))
        states[0], states[1] = x0, x1
        w = ms.guess(x0, inputs, states)
        p = np.concatenate([x0, np.zeros(n_p - 7), [h0]])
        g = np.asarray(f_g(w, p)[1]).ravel()
        np.testing.assert_allclose(g[6:12], 0.0, atol=1e-14)  # the first gap closes over h0 exactly
        assert abs(g[12:18]).max() > 1e-3  # (X_2 = 0 is not where X_1 goes: the gaps are really evaluated)
    # All zero but U_0: the cost is the first stage's, h0 / 0.3 of a whole step's.
    only_u0 = np.vstack([u0, np.zeros((problem.horizon - 1, 2))])
    zero = ms.guess(np.zeros(6), only_u0, np.zeros((problem.horizon + 1, 6)))
    first = [float(f_g(zero, np.concatenate([np.zeros(n_p - 1), [h]]))[0]) for h in (0.1, 0.3)]
    assert first[0] == pytest.approx(first[1] / 3.0, rel=1e-12) and first[1] > 0.0
    # Single shooting rolls its states out over the first step that p holds.
    single = SingleShooting(FullParkingProblem(V, replace(SETTINGS, solver="ipopt", transcription="single_shooting")))
    w = np.zeros(2 * problem.horizon)
    w[:2] = u0
    for h0 in (0.1, 0.3):
        states, _ = single.unpack(w, np.concatenate([x0, [h0]]))
        x1 = np.asarray(problem.discrete_dynamics(ca.DM(x0), ca.DM(u0), h0)).ravel()
        np.testing.assert_allclose(states[1], x1, atol=1e-14)


def test_the_prediction_grid_stays_put_while_the_samples_pass():
    """With 0.1 s samples and 0.3 s prediction steps, the first step lasts 0.3, 0.2, 0.1, 0.3 ... s; the warm
    start is the last plan itself (its first step shortened) or the plan moved on by exactly one step."""
    from hitchpark.model.plant import Plant, PlantSettings

    nmpc = FullNMPC(V, SETTINGS)
    nmpc.recorder = []
    plant = Plant(PlantSettings(), V, STARTS[0], SETTINGS.dt)
    tr = nmpc.transcription
    last, moved = None, {0: 0, 1: 0}
    for _ in range(24):
        step = nmpc.act(plant.sense(), Pose())
        assert step.ok, step.status
        problem = nmpc.recorder[-1]
        h0 = problem.p[-1]
        if last is None:
            assert h0 == 0.3  # a new grid: a whole first step
        else:
            warm_states, warm_inputs = tr.unpack(problem.w0, problem.p)
            lo, hi = tr.unpack(problem.lbx, problem.p)[1], tr.unpack(problem.ubx, problem.p)[1]
            if last[0] > 0.15:  # the grid stays: the first step a sample shorter, the plan as it was
                assert h0 == pytest.approx(last[0] - 0.1, abs=1e-12)
                np.testing.assert_array_equal(warm_states[1:], last[1][1:])
                np.testing.assert_array_equal(warm_inputs, np.clip(last[2], lo, hi))
            else:  # the grid moves on by one whole step
                assert h0 == pytest.approx(0.3, abs=1e-12)
                np.testing.assert_array_equal(warm_states[1:-1], last[1][2:])
                np.testing.assert_array_equal(warm_inputs[:-1], np.clip(last[2][1:], lo[:-1], hi[:-1]))
            moved[int(last[0] < 0.15)] += 1
        np.testing.assert_array_equal(warm_states[0] if last else problem.w0[:6], problem.p[:6])  # X_0 measured
        last = (h0, step.predicted_states, step.predicted_inputs)
        assert plant.apply(step.command) is not None
    assert moved == {0: 16, 1: 7}  # 23 samples after the first: (stay, stay, move) ... stay, stay
