"""The estimator between the sensors and the controllers (hitchpark.control.estimator)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from hitchpark.checks import InputError
from hitchpark.control.estimator import Estimator, EstimatorSettings
from hitchpark.maneuver.settings import ManeuverSettings
from hitchpark.model import VehicleTrailer
from hitchpark.model.plant import Command, Measurement, Plant, PlantSettings
from hitchpark.model.state import State

V = VehicleTrailer()
DT = 0.1


def drive(plant_settings: PlantSettings, estimator: Estimator, steer: float, steps: int, vehicle=V):
    """Reverse at 0.5 m/s with ``steer`` asked; (true, read, estimated) configurations, one row per sample."""
    plant = Plant(plant_settings, vehicle, State(0.0, 0.0, 0.0, 0.0), DT)
    rows = []
    for _ in range(steps):
        m = plant.sense()
        seen = estimator.update(m)
        rows.append((plant.configuration, m.state.as_array(), seen.state.as_array()))
        plant.apply(Command(-0.5, steer))
    return [np.array(r) for r in zip(*rows, strict=True)]


def test_with_exact_sensors_the_readings_pass_through_untouched():
    estimator = Estimator(V, EstimatorSettings(), DT)
    m = Measurement(1.0, State(1.0, 2.0, 3.0, 0.4), 0.1, -0.5)
    assert estimator.update(m) is m
    assert not EstimatorSettings().filters and EstimatorSettings(hitch_noise_std_deg=0.5).filters


def test_a_noisy_hitch_is_read_at_least_twice_as_well_on_a_reverse_arc():
    noisy = PlantSettings(hitch_noise_std_deg=0.5, seed=3)
    true, read, seen = drive(noisy, Estimator(V, EstimatorSettings(hitch_noise_std_deg=0.5), DT), 0.1, 300)
    raw, filtered = read[50:, 3] - true[50:, 3], seen[50:, 3] - true[50:, 3]
    assert math.degrees(raw.std()) == pytest.approx(0.5, rel=0.2)
    assert filtered.std() < raw.std() / 2 and abs(filtered.mean()) < math.radians(0.1)
    # The exact sensors pass through: the pose is the reading's.
    assert np.array_equal(seen[:, :3], read[:, :3])


@pytest.mark.parametrize("steer", [0.3, 0.1, -0.2])
def test_the_estimate_is_better_than_the_reading_while_the_hitch_swings_and_the_lengths_are_off(steer):
    """The car's lengths 10% longer than the model's, its hitch sensor noisy: the model's prediction is off every
    sample while the hitch swings, and the estimate is still nearer the truth than the readings."""
    vehicle = {"hitch_offset": V.hitch_offset * 1.1, "trailer_length": V.trailer_length * 1.1}
    longer = PlantSettings(vehicle=vehicle, hitch_noise_std_deg=0.5, seed=5)
    estimator = Estimator(V, EstimatorSettings(hitch_noise_std_deg=0.5), DT)
    true, read, seen = drive(longer, estimator, steer, 120, vehicle=longer.resolve_vehicle(V))
    assert np.ptp(true[:, 3]) > math.radians(10.0)
    rms = lambda e: float(np.sqrt(np.mean(e**2)))  # noqa: E731
    assert rms(seen[10:, 3] - true[10:, 3]) < 0.6 * rms(read[10:, 3] - true[10:, 3])


def test_a_heading_through_pi_is_not_averaged_through_zero():
    estimator = Estimator(V, EstimatorSettings(yaw_noise_std_deg=1.0), DT)
    estimator.update(Measurement(0.0, State(0.0, 0.0, math.pi - 0.01, 0.0), 0.0, 0.0))
    seen = estimator.update(Measurement(0.0, State(0.0, 0.0, -math.pi + 0.01, 0.0), 0.0, 0.0))
    assert abs(abs(seen.state.yaw) - math.pi) < 0.011


def test_readings_at_one_time_average_and_the_settings_round_trip():
    estimator = Estimator(V, EstimatorSettings(hitch_noise_std_deg=0.5), DT)
    for hitch in (0.01, -0.01, 0.01, -0.01):  # standing still: four readings at t = 0
        seen = estimator.update(Measurement(0.0, State(0.0, 0.0, 0.0, hitch), 0.0, 0.0))
    assert seen.state.hitch == pytest.approx(0.0, abs=1e-12)
    s = ManeuverSettings.from_dict({"estimator": {"hitch_noise_std_deg": 0.5, "model_error": 0.2}})
    assert s.estimator == EstimatorSettings(hitch_noise_std_deg=0.5, model_error=0.2)
    assert ManeuverSettings.from_dict(s.to_dict()) == s


@pytest.mark.parametrize(
    ("table", "words"),
    [({"hitch_noise_std_deg": -1.0}, "estimator.hitch_noise_std_deg"), ({"gain": 0.5}, "gain")],
)
def test_bad_estimator_settings_are_refused_by_name(table, words):
    with pytest.raises(InputError, match=words):
        ManeuverSettings.from_dict({"estimator": table})


def test_the_doubt_bounds_the_estimates_error_and_needs_the_lengths_tolerance():
    """Reverse arcs with the car's lengths 10% off either way and a noisy hitch sensor: told the lengths' tolerance,
    the estimator's doubt covers the true hitch at every sample of every run; not told, it misses some (the model's
    error repeats, and only the tolerance bounds it). Exact components have no doubt."""
    missed_without = 0
    for seed in (5, 6, 7):
        for steer in (0.3, 0.1, -0.2):
            for scale in (1.1, 0.9):
                car = {"hitch_offset": V.hitch_offset * scale, "trailer_length": V.trailer_length * scale}
                plant = PlantSettings(vehicle=car, hitch_noise_std_deg=0.5, seed=seed)
                for tolerance in (0.1, 0.0):
                    model = replace(V, length_tolerance=tolerance)
                    estimator = Estimator(model, EstimatorSettings(hitch_noise_std_deg=0.5), DT)
                    sim = Plant(plant, plant.resolve_vehicle(V), State(0.0, 0.0, 0.0, 0.0), DT)
                    for _ in range(120):
                        seen = estimator.update(sim.sense())
                        assert seen.doubt[:3] == (0.0, 0.0, 0.0)
                        covered = abs(seen.state.hitch - sim.configuration[3]) <= seen.doubt[3]
                        assert covered or tolerance == 0.0, (seed, steer, scale, sim.t)
                        missed_without += not covered
                        sim.apply(Command(-0.5, steer))
    assert missed_without > 0


def test_the_doubt_starts_at_the_sensors_and_shrinks_as_readings_average():
    estimator = Estimator(V, EstimatorSettings(hitch_noise_std_deg=0.5), DT)
    first = estimator.update(Measurement(0.0, State(0.0, 0.0, 0.0, 0.0), 0.0, 0.0))
    assert first.doubt == pytest.approx((0.0, 0.0, 0.0, 3.0 * math.radians(0.5)))  # doubt_sigmas of the sensor
    for _ in range(1, 4):  # three more readings standing still: the noise's part as of four averaged
        seen = estimator.update(Measurement(0.0, State(0.0, 0.0, 0.0, 0.0), 0.0, 0.0))
    assert seen.doubt[3] == pytest.approx(3.0 * math.radians(0.5) / 2.0)
    assert Estimator(V, EstimatorSettings(), DT).update(first).doubt == first.doubt  # exact: passed through
