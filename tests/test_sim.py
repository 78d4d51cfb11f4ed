"""Open-loop simulation and the trajectory record (hitchpark.model.simulate)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from hitchpark.io import to_jsonable
from hitchpark.model import step_full
from hitchpark.model.simulate import BASE_COLUMNS, State, Trajectory, check_state, simulate

EXPECTED_COLUMNS = (
    "t",
    "x_trailer",
    "y_trailer",
    "yaw_trailer",
    "yaw_vehicle",
    "hitch",
    "x_rear",
    "y_rear",
    "rear_speed",
    "front_steer",
)


@pytest.fixture
def reversing(table4):
    return simulate(table4, State(1.0, 2.0, 0.3, 0.1), rear_speed=-0.8, front_steer=0.2, duration=3.0, dt=0.1)


def test_columns_are_exactly_the_base_columns(reversing):
    assert BASE_COLUMNS == EXPECTED_COLUMNS
    assert reversing.trajectory.names == EXPECTED_COLUMNS
    assert len(reversing.trajectory) == 31
    assert reversing.reason == "completed"


def test_time_column_and_commands(reversing):
    tr = reversing.trajectory
    np.testing.assert_allclose(tr["t"], 0.1 * np.arange(31), atol=1e-12)
    assert tr["t"][-1] == 3.0
    np.testing.assert_array_equal(tr["rear_speed"][:-1], -0.8)
    assert tr["rear_speed"][-1] == 0.0  # stopped at the end
    np.testing.assert_array_equal(tr["front_steer"], 0.2)
    # The first row is the start.
    assert (tr["x_trailer"][0], tr["y_trailer"][0], tr["yaw_trailer"][0], tr["hitch"][0]) == (
        1.0,
        2.0,
        0.3,
        0.1,
    )


def test_short_last_sample_ends_at_the_duration(table4):
    tr = simulate(table4, State(0, 0, 0, 0), -1.0, 0.1, duration=0.25, dt=0.1).trajectory
    np.testing.assert_allclose(tr["t"], [0.0, 0.1, 0.2, 0.25], atol=1e-15)


def test_rear_axle_columns_follow_the_links(reversing, table4):
    """Eqs. (25)-(28): rear axle = trailer axle + L_T e(psi_2) + L_H e(psi_1)."""
    tr = reversing.trajectory
    yaw_t, yaw_v = tr["yaw_trailer"], tr["yaw_vehicle"]
    np.testing.assert_allclose(yaw_v, yaw_t + tr["hitch"], atol=1e-15)
    L_T, L_H = table4.trailer_length, table4.hitch_offset
    np.testing.assert_allclose(tr["x_rear"], tr["x_trailer"] + L_T * np.cos(yaw_t) + L_H * np.cos(yaw_v), atol=1e-12)
    np.testing.assert_allclose(tr["y_rear"], tr["y_trailer"] + L_T * np.sin(yaw_t) + L_H * np.sin(yaw_v), atol=1e-12)


def test_each_row_command_from_its_state_reaches_the_next_row(reversing, table4):
    tr = reversing.trajectory
    states = tr.states()
    assert states.shape == (len(tr), 4)
    for k in range(len(tr) - 1):
        nxt = step_full(table4, states[k], tr["rear_speed"][k], tr["front_steer"][k], tr["t"][k + 1] - tr["t"][k])
        np.testing.assert_allclose(nxt, states[k + 1], rtol=0, atol=1e-12)


def test_rear_axle_speed_matches_the_command(reversing):
    """Finite differences of the rear-axle track move at |V_R| (Eqs. 19-20)."""
    tr = reversing.trajectory
    step = np.hypot(np.diff(tr["x_rear"]), np.diff(tr["y_rear"]))
    # The chord of an arc is a hair shorter than the arc.
    np.testing.assert_allclose(step / np.diff(tr["t"]), 0.8, rtol=1e-4)


def test_jackknife_stops_early(table4):
    result = simulate(table4, State(0.0, 0.0, 0.0, 0.0), rear_speed=-1.0, front_steer=0.5, duration=60.0, dt=0.1)
    tr = result.trajectory
    assert result.reason == "jackknife"
    assert tr["t"][-1] < 60.0
    assert np.all(np.abs(tr["hitch"]) <= table4.max_hitch)
    # The stop was needed: one more step with the command would have passed the limit.
    nxt = step_full(table4, tr.states()[-1], -1.0, 0.5, 0.1)
    assert abs(nxt[3]) > table4.max_hitch
    assert abs(tr["hitch"][-1]) > math.radians(60.0)
    assert tr["rear_speed"][-1] == 0.0


def test_forward_drive_from_jackknife_limit_is_allowed(table4):
    start = State(0.0, 0.0, 0.0, table4.max_hitch)
    result = simulate(table4, start, rear_speed=1.0, front_steer=0.0, duration=2.0)
    assert result.reason == "completed"
    assert abs(result.trajectory["hitch"][-1]) < table4.max_hitch


@pytest.mark.parametrize(
    ("kwargs", "word"),
    [
        ({"rear_speed": math.nan}, "speed"),
        ({"rear_speed": math.inf}, "speed"),
        ({"front_steer": math.nan}, "steer"),
        ({"front_steer": 0.76}, "steer"),
        ({"front_steer": -1.0}, "steer"),
        ({"duration": 0.0}, "duration"),
        ({"duration": -1.0}, "duration"),
        ({"duration": math.inf}, "duration"),
        ({"dt": 0.0}, "dt"),
        ({"dt": -0.1}, "dt"),
        ({"dt": math.nan}, "dt"),
    ],
)
def test_bad_inputs_raise(table4, kwargs, word):
    args = {"rear_speed": -1.0, "front_steer": 0.1, "duration": 1.0, "dt": 0.1, **kwargs}
    with pytest.raises(ValueError, match=word):
        simulate(table4, State(0, 0, 0, 0), **args)


@pytest.mark.parametrize(
    ("values", "word"),
    [
        ((math.nan, 0, 0, 0), "x"),
        ((0, math.inf, 0, 0), "y"),
        ((0, 0, math.nan, 0), "yaw"),
        ((0, 0, 0, math.nan), "hitch"),
        ((0, 0, 0, math.radians(70.5)), "hitch"),
        ((0, 0, 0, -math.radians(71.0)), "hitch"),
    ],
)
def test_bad_start_raises(table4, values, word):
    # A non-finite State is refused when it is made; one past the jackknife limit when it is used.
    with pytest.raises(ValueError, match=word):
        simulate(table4, State(*values), -1.0, 0.1, 1.0)
    with pytest.raises(ValueError, match=word):
        check_state(table4, State(*values))


def test_state_round_trips():
    state = State(1.5, -2.0, 0.4, -0.25)
    np.testing.assert_array_equal(State.from_array(state.as_array()).as_array(), state.as_array())
    data = state.to_dict()
    assert data["yaw_deg"] == pytest.approx(math.degrees(0.4))
    again = State.from_dict(data)
    assert again.as_array() == pytest.approx(state.as_array(), abs=1e-15)


def test_trajectory_dict_round_trip_with_nan():
    tr = Trajectory({"t": [0.0, 0.1, 0.2], "solve_time": [math.nan, 0.01, math.nan]})
    data = tr.to_dict()
    assert data == {"t": [0.0, 0.1, 0.2], "solve_time": [None, 0.01, None]}
    json.dumps(data, allow_nan=False)  # JSON-safe
    back = Trajectory.from_dict(data)
    assert back.names == ("t", "solve_time")
    np.testing.assert_array_equal(back["t"], tr["t"])
    assert np.isnan(back["solve_time"][0])
    assert np.isnan(back["solve_time"][2])
    assert back["solve_time"][1] == 0.01


def test_simulation_result_round_trips_through_json(reversing):
    data = json.loads(json.dumps(to_jsonable(reversing.to_dict()), allow_nan=False))
    assert set(data) == {"vehicle", "start", "reason", "trajectory"}
    assert data["vehicle"]["wheelbase"] == 2.896
    assert data["start"] == pytest.approx(
        {"x": 1.0, "y": 2.0, "yaw_deg": math.degrees(0.3), "hitch_deg": math.degrees(0.1)}
    )
    back = Trajectory.from_dict(data["trajectory"])
    assert back.names == EXPECTED_COLUMNS
    for name in EXPECTED_COLUMNS:
        np.testing.assert_array_equal(back[name], reversing.trajectory[name])


def test_trajectory_rejects_ragged_columns():
    with pytest.raises(ValueError, match="length"):
        Trajectory({"t": [0.0, 1.0], "x": [1.0]})


def test_trajectory_access(reversing):
    tr = reversing.trajectory
    assert "hitch" in tr
    assert "speed" not in tr
    assert len(Trajectory({})) == 0


def test_trajectory_csv(tmp_path, reversing):
    path = tmp_path / "run.csv"
    reversing.trajectory.to_csv(str(path))
    header = path.read_text(encoding="utf-8").splitlines()[0]
    assert header.split(",") == list(EXPECTED_COLUMNS)
    table = np.loadtxt(path, delimiter=",", skiprows=1)
    np.testing.assert_allclose(table[:, EXPECTED_COLUMNS.index("hitch")], reversing.trajectory["hitch"], rtol=1e-15)
