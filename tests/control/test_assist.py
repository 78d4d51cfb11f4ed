"""The knob assist (hitchpark.assist / hitchpark.control.assist): the curvature it follows, the limits it keeps,
the jackknife and the obstacles it keeps away from, the input it refuses."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hitchpark.assist import OVERRIDES, AssistSettings, KnobAssist, max_curvature
from hitchpark.checks import InputError
from hitchpark.model import IDEAL, Plant, PlantSettings, State, VehicleTrailer, load_plant
from hitchpark.model.collision import swept_clearance
from hitchpark.model.inverse import front_steer_from_virtual, steady_hitch_from_virtual
from hitchpark.model.kinematics import full_rates
from hitchpark.model.plant import Measurement
from hitchpark.model.scene import Obstacle, Scene

V = VehicleTrailer()
FAULTS = load_plant(Path(__file__).resolve().parents[2] / "benchmarks" / "plants" / "faults_long.toml")
DT = 0.1


STRAIGHT = State(0.0, 0.0, 0.0, 0.0)


def drive(plant_settings, knob, speed, seconds, scene=None, start=STRAIGHT):
    """Run the assist on a plant for ``seconds``; knob(t), speed(t). The rows: commands, true states, steps."""
    assist = KnobAssist(V, AssistSettings(dt=DT, delay_steps=plant_settings.delay_steps), scene)
    plant = Plant(plant_settings, V, start, DT)
    steps, states, actual = [], [plant.configuration], []
    for _ in range(round(seconds / DT)):
        m = plant.sense()
        u = assist.step(m, knob(m.t), speed(m.t))
        assert plant.apply(u.command) is not None, f"the plant refused a jackknife at t = {m.t:.1f} s"
        steps.append(u)
        states.append(plant.configuration)
        actual.append((plant.front_steer, plant.rear_speed))
    return assist, plant, steps, np.array(states), np.array(actual)


def test_the_full_knob_is_the_tightest_steady_turn_within_the_margins():
    s = AssistSettings()
    kappa = max_curvature(V, math.radians(s.hitch_margin_deg), s.steer_margin)
    virtual = math.atan(V.trailer_length * kappa)
    hitch = steady_hitch_from_virtual(V, virtual)
    steer = float(front_steer_from_virtual(V, hitch, virtual))
    # One of the two margins binds, the other holds.
    at_hitch = math.isclose(hitch, V.max_hitch - math.radians(s.hitch_margin_deg), abs_tol=1e-9)
    at_steer = math.isclose(abs(steer), (1 - s.steer_margin) * V.max_steer, abs_tol=1e-9)
    assert at_hitch or at_steer
    assert hitch <= V.max_hitch - math.radians(s.hitch_margin_deg) + 1e-9
    assert abs(steer) <= (1 - s.steer_margin) * V.max_steer + 1e-9
    # A longer trailer holds a wider turn at most; the fixed gain is the same curvature per knob for any trailer.
    longer = VehicleTrailer(trailer_length=5.0)
    assert max_curvature(longer, math.radians(10), 0.15) < kappa
    fixed = AssistSettings(curvature_per_knob=0.1)
    assert KnobAssist(V, fixed).curvature_of(0.5) == KnobAssist(longer, fixed).curvature_of(0.5) == 0.05


@pytest.mark.parametrize("knob", [0.5, -1.0])
def test_a_held_knob_gives_the_curvature_it_asks_in_steady_state(knob):
    assist, _, steps, states, actual = drive(IDEAL, lambda t: knob, lambda t: 1.0, 40.0)
    asked = knob * assist.kappa_max
    _, yaw_rate_t, v_t = full_rates(V, states[-1, 3], actual[-1, 1], actual[-1, 0])
    assert yaw_rate_t / v_t == pytest.approx(asked, rel=0.01)
    assert states[-1, 3] == pytest.approx(steady_hitch_from_virtual(V, math.atan(V.trailer_length * asked)), abs=1e-3)
    assert steps[-1].override == "none"
    assert knob * states[-1, 2] < 0  # reversing, a left knob (k > 0) swings the trailer's heading clockwise


def _limits_kept(plant_settings, steps, states):
    s = AssistSettings()
    steer = np.array([u.front_steer for u in steps])
    speed = np.array([u.rear_speed for u in steps])
    assert np.all(np.isfinite(steer)) and np.all(np.isfinite(speed))
    assert np.all(np.abs(steer) <= V.max_steer + 1e-12)
    assert np.all(np.abs(np.diff(np.r_[0.0, steer])) <= V.max_steer_rate * DT + 1e-12)
    assert np.all(np.abs(np.diff(np.r_[0.0, speed])) <= V.max_accel * DT + 1e-12)
    assert np.all(speed <= 0.0) and np.all(speed >= -s.max_speed - 1e-12)
    # Above the request only while braking towards it at the acceleration limit.
    request = np.array([u.speed_request for u in steps])
    over = np.flatnonzero(-speed > request + 1e-9)
    assert np.all(np.isclose(np.diff(np.r_[0.0, speed])[over], V.max_accel * DT))
    assert np.max(np.abs(states[:, 3])) < V.max_hitch


profiles = st.lists(st.tuples(st.floats(-1.0, 1.0), st.floats(0.0, 1.5), st.floats(0.3, 4.0)), min_size=1, max_size=6)


def _piecewise(segments, which):
    ends = np.cumsum([seg[2] for seg in segments])
    return lambda t: segments[min(int(np.searchsorted(ends, t, side="right")), len(segments) - 1)][which]


@settings(max_examples=6, deadline=None)
@given(segments=profiles, faults=st.booleans())
def test_random_knob_and_speed_sequences_never_break_a_limit(segments, faults):
    plant_settings = FAULTS if faults else PlantSettings()
    _, _, steps, states, _ = drive(plant_settings, _piecewise(segments, 0), _piecewise(segments, 1), 12.0)
    _limits_kept(plant_settings, steps, states)


@pytest.mark.slow
@pytest.mark.parametrize("plant_settings", [PlantSettings(), FAULTS], ids=["default", "faults"])
@pytest.mark.parametrize("side", [1.0, -1.0])
def test_full_lock_held_for_a_minute_never_passes_the_jackknife_limit(plant_settings, side):
    _, plant, steps, states, _ = drive(plant_settings, lambda t: side, lambda t: 1.0, 60.0)
    _limits_kept(plant_settings, steps, states)
    margin = math.radians(AssistSettings().jackknife_margin_deg)
    assert np.max(np.abs(states[:, 3])) < plant.vehicle.max_hitch - margin / 2
    assert side * states[-1, 3] > 0  # the hitch where the knob asks
    # It turned: the trailer's heading swung by more than a half turn.
    assert abs(states[-1, 2] - states[0, 2]) > math.pi


def test_a_wall_behind_ends_stopped_for_the_obstacle_without_touching_it():
    # The trailer's rear is 1 m behind its axle: 8 m of room to the wall at x = -9.
    wall = Scene((Obstacle("wall", ((-10.0, -6.0), (-9.0, -6.0), (-9.0, 6.0), (-10.0, 6.0))),))
    _, plant, steps, states, _ = drive(PlantSettings(), lambda t: 0.2 * math.sin(t), lambda t: 1.0, 25.0, wall)
    assert steps[-1].override == "stopped_for_obstacle"
    assert plant.rear_speed == 0.0
    least, _ = swept_clearance(plant.vehicle, wall, states)
    assert least >= AssistSettings().min_clearance_m
    assert {u.override for u in steps} <= set(OVERRIDES)


def test_once_stopped_for_an_obstacle_it_stays_stopped_until_the_driver_lets_go_or_turns_the_knob():
    wall = Scene((Obstacle("wall", ((-10.0, -6.0), (-9.0, -6.0), (-9.0, 6.0), (-10.0, 6.0))),))
    assist, plant, steps, _, _ = drive(PlantSettings(), lambda t: 0.0, lambda t: 1.0, 25.0, wall)
    assert steps[-1].override == "stopped_for_obstacle" and plant.rear_speed == 0.0
    m = plant.sense()
    # A reading 0.5 m clearer of the wall (noise, say) does not let the car creep on, nor does a small knob change.
    clearer = type(m)(m.t, State(m.state.x + 0.5, m.state.y, m.state.yaw, m.state.hitch), m.front_steer, 0.0)
    assert assist.step(clearer, 0.1, 1.0).rear_speed == 0.0
    assert assist.step(clearer, 0.1, 1.0).override == "stopped_for_obstacle"
    # Another request: the pedal let go and pressed again, or the knob turned by 0.2; the guard looks again.
    assert assist.step(clearer, 0.1, 0.0).rear_speed == 0.0
    assert assist.step(clearer, 0.1, 1.0).rear_speed < 0.0
    assist.step(m, 0.0, 1.0)  # stopped again at the true reading (the guard's own stop)
    assert assist.step(clearer, 0.0, 1.0).rear_speed == 0.0
    assert assist.step(clearer, 0.25, 1.0).rear_speed < 0.0


def test_the_estimates_doubt_counts_against_the_obstacle():
    """With an estimator in the loop the reading is an estimate and the truth within its doubt: the assist's guard
    allows for it as the maneuvers' guard does. A reading 0.1 m clearer of a wall than the guard keeps lets the car
    reverse; told the reading may be 0.15 m off, the assist stops it; 0.05 m off, it reverses slower."""
    wall = Scene((Obstacle("wall", ((-10.0, -6.0), (-9.0, -6.0), (-9.0, 6.0), (-10.0, 6.0))),))
    s = AssistSettings(dt=DT)
    need = s.min_clearance_m + s.margin_m
    reading = Measurement(0.0, State(-9.0 + V.trailer_rear + need + 0.1, 0.0, 0.0, 0.0), 0.0, 0.0)
    exact, slowed, stopped = (
        KnobAssist(V, s, wall).step(replace(reading, doubt=(d, 0.0, 0.0, 0.0)), 0.0, 1.0) for d in (0.0, 0.05, 0.15)
    )
    assert exact.rear_speed < 0.0 and slowed.rear_speed < 0.0
    assert stopped.rear_speed == 0.0 and stopped.override == "stopped_for_obstacle"
    assert exact.speed_cap > slowed.speed_cap > 0.0 == stopped.speed_cap
    assert slowed.override == "slowed_for_obstacle"


@pytest.mark.parametrize(
    "knob, speed, message",
    [
        (1.5, 1.0, "knob must be"),
        (math.nan, 1.0, "knob must be"),
        (0.0, -0.5, "speed_request must be"),
        (0.0, math.inf, "speed_request must be"),
        ("left", 1.0, "knob must be"),
    ],
)
def test_bad_input_is_refused_on_one_line(knob, speed, message):
    assist = KnobAssist(V)
    m = Plant(PlantSettings(), V, State(0.0, 0.0, 0.0, 0.0), DT).sense()
    with pytest.raises(InputError, match=message) as err:
        assist.step(m, knob, speed)
    assert "\n" not in str(err.value)
    with pytest.raises(InputError, match="measurement"):
        assist.step((0.0, 0.0, 0.0, 0.0), 0.0, 1.0)
    with pytest.raises(InputError, match=r"assist\.hitch_gain"):
        AssistSettings(hitch_gain=-1.0)
