"""The plant (hitchpark.model.plant): actuators, delay, sensors, jackknife refusal, settings."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hitchpark import InputError
from hitchpark.model import (
    Command,
    Plant,
    PlantSettings,
    State,
    VehicleTrailer,
    load_plant,
    step_full,
)

V = VehicleTrailer()
START = State(10.0, 3.5, 0.0, 0.0)


def test_ideal_plant_is_the_held_command_on_the_full_model():
    plant = Plant(PlantSettings(kind="ideal"), V, START, 0.1)
    acting = plant.apply(Command(-1.0, 0.3))
    assert acting == Command(-1.0, 0.3)
    np.testing.assert_allclose(plant.state.as_array(), step_full(V, START.as_array(), -1.0, 0.3, 0.1), atol=1e-12)
    assert (plant.front_steer, plant.rear_speed) == (0.3, -1.0)


def test_steer_ramps_at_the_rate_limit_then_lags_exponentially():
    s = PlantSettings(steer_rate_max=0.5, steer_time_constant=0.2)
    plant = Plant(s, V, START, 0.1)
    steer = [0.0]
    for _ in range(20):
        plant.apply(Command(0.0, 0.4))
        steer.append(plant.front_steer)
    # Rate-limited until the error is r * tau = 0.1 rad, reached at t1 = 0.3 / 0.5 = 0.6 s ...
    np.testing.assert_allclose(steer[:7], 0.05 * np.arange(7), atol=1e-12)
    # ... then e(t) = 0.1 exp(-(t - t1) / tau).
    t = np.arange(7, 21) * 0.1
    np.testing.assert_allclose(steer[7:], 0.4 - 0.1 * np.exp(-(t - 0.6) / 0.2), atol=1e-12)


def test_pure_rate_limit_without_lag_and_speed_at_the_acceleration_limit():
    plant = Plant(PlantSettings(steer_time_constant=0.0, accel_max=2.0), V, START, 0.1)
    plant.apply(Command(-1.0, 0.03))
    assert plant.front_steer == pytest.approx(0.03, abs=1e-12)  # within one step's rate budget
    assert plant.rear_speed == pytest.approx(-0.2)
    for _ in range(10):
        plant.apply(Command(-1.0, 0.03))
    assert plant.rear_speed == -1.0


@settings(max_examples=60, deadline=None)
@given(
    commands=st.lists(st.tuples(st.floats(-1.0, 1.0), st.floats(-2.0, 2.0)), min_size=1, max_size=25),
    rate=st.floats(0.1, 2.0),
    tau=st.floats(0.0, 0.5),
)
def test_actual_steer_never_beyond_its_limit_or_its_rate(commands, rate, tau):
    plant = Plant(PlantSettings(steer_rate_max=rate, steer_time_constant=tau), V, State(0.0, 0.0, 0.0, 0.0), 0.1)
    prev = plant.front_steer
    for speed, steer in commands:
        if plant.apply(Command(speed, steer)) is None:
            break
        assert abs(plant.front_steer) <= V.max_steer + 1e-12
        assert abs(plant.front_steer - prev) <= rate * 0.1 * (1 + 1e-9) + 1e-15
        prev = plant.front_steer


def test_delay_acts_on_the_command_issued_steps_ago():
    plant = Plant(PlantSettings(kind="ideal", delay_steps=2), V, START, 0.1)
    acted = [plant.apply(Command(-1.0, 0.1 * k)) for k in range(1, 5)]
    assert [a.front_steer for a in acted] == pytest.approx([0.0, 0.0, 0.1, 0.2])
    assert [c.front_steer for c in plant.pending()] == pytest.approx([0.3, 0.4])


def test_noise_is_seeded_by_seed_and_start_and_bias_is_added():
    s = PlantSettings(hitch_noise_std_deg=0.5, position_noise_std_m=0.02, hitch_bias_deg=1.0, seed=4)
    a = [Plant(s, V, START, 0.1).sense().state for _ in range(2)]
    assert a[0] == a[1]
    other = Plant(s, V, State(10.0, 3.5, 0.0, 1e-9), 0.1).sense().state
    assert other != a[0]
    errors = []
    plant = Plant(s, V, START, 0.1)
    for _ in range(4000):
        m = plant.sense()
        errors.append(math.degrees(m.state.hitch - START.hitch))
    assert np.mean(errors) == pytest.approx(1.0, abs=0.05)
    assert np.std(errors) == pytest.approx(0.5, rel=0.05)


def test_a_step_that_would_jackknife_is_not_applied():
    plant = Plant(PlantSettings(kind="ideal"), V, State(0.0, 0.0, 0.0, math.radians(69.9)), 0.1)
    before = plant.state
    assert plant.apply(Command(-1.0, -0.75)) is None
    assert plant.state == before and plant.t == 0.0 and plant.pending() == ()


def test_plant_vehicle_takes_the_controller_fields_not_given():
    s = PlantSettings(vehicle={"hitch_offset": 1.3})
    real = s.resolve_vehicle(V)
    assert real.hitch_offset == 1.3 and real.trailer_length == V.trailer_length


def test_load_plant_file_and_table(tmp_path):
    f = tmp_path / "p.toml"
    f.write_text("[plant]\ndelay_steps = 1\nhitch_noise_std_deg = 0.5\n[plant.vehicle]\ntrailer_length = 3.0\n")
    p = load_plant(f)
    assert (p.delay_steps, p.hitch_noise_std_deg, p.vehicle) == (1, 0.5, {"trailer_length": 3.0})
    assert PlantSettings.from_dict(p.to_dict()) == p


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ('kind = "fast"', "plant.kind"),
        ("steer_rate_max = 0", "plant.steer_rate_max"),
        ("delay_steps = -1", "plant.delay_steps"),
        ("delay_steps = 1.5", "plant.delay_steps"),
        ("hitch_noise_std_deg = nan", "plant.hitch_noise_std_deg"),
        ("wheel = 3", "unknown key plant.wheel"),
        ("[vehicle]\nwheelbase = -1", "wheelbase"),
        ("[vehicle]\nlength = 1", "unknown key plant.vehicle.length"),
    ],
)
def test_bad_plant_files_are_refused_on_one_line(tmp_path, text, match):
    f = tmp_path / "p.toml"
    f.write_text(text + "\n")
    with pytest.raises(InputError, match=match) as info:
        load_plant(f)
    assert "\n" not in str(info.value)
