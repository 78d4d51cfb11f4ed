"""The closed loop on a realistic car (hitchpark.maneuver.process with the full NMPC and the default plant)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from hitchpark.io import to_jsonable
from hitchpark.maneuver import ManeuverResult, ManeuverSettings, Outcome, ProcessSettings, park
from hitchpark.model import PlantSettings, State, VehicleTrailer

V = VehicleTrailer()
FAULTS = PlantSettings(
    delay_steps=1,
    hitch_noise_std_deg=0.5,
    vehicle={"hitch_offset": 1.1 * V.hitch_offset, "trailer_length": 1.1 * 2.693},
)
STARTS = {
    "parallel": State(10.0, 3.5, 0.0, 0.0),
    "random": State(11.96, -1.42, math.radians(39.26), math.radians(16.86)),
}


@pytest.fixture(scope="module")
def results():
    out = {name: park(V, start) for name, start in STARTS.items()}
    out["faults"] = park(V, STARTS["random"], plant=FAULTS)
    return out


@pytest.mark.slow
@pytest.mark.parametrize("name", ["parallel", "random", "faults"])
def test_parks_on_a_realistic_car(results, name):
    r = results[name]
    assert r.success and r.outcome is Outcome.PARKED, (r.reason, r.detail)
    last = r.stages[-1]
    assert last.distance_error_m <= 0.05 and abs(last.final_hitch_deg) <= 3.0


@pytest.mark.parametrize("name", ["parallel", "random", "faults"])
def test_the_car_stays_within_its_limits(results, name):
    r = results[name]
    tr, real = r.trajectory, r.plant_vehicle
    dt = np.diff(tr["t"])
    assert np.all(np.abs(tr["front_steer"]) <= real.max_steer + 1e-12)
    assert np.all(np.abs(np.diff(tr["front_steer"])) <= r.plant.steer_rate_max * dt * (1 + 1e-9))
    assert np.all(np.abs(tr["hitch"]) <= real.max_hitch)
    # What the controllers commanded: within the steer limit and the rate they know of.
    assert np.all(np.abs(tr["front_steer_cmd"]) <= r.vehicle.max_steer + 1e-12)
    assert np.all(np.abs(np.diff(tr["front_steer_cmd"])) <= r.vehicle.max_steer_rate * dt * (1 + 1e-9))
    assert np.all(np.isfinite(tr["front_steer_cmd"])) and np.all(np.isfinite(tr["rear_speed_cmd"]))


@pytest.mark.parametrize("name", ["parallel", "random", "faults"])
def test_stages_switch_at_standstill_and_keep_their_direction(results, name):
    r = results[name]
    tr = r.trajectory
    for i, st in enumerate(r.stages):
        rows = slice(st.first_row, st.last_row)
        speeds = tr["rear_speed"][rows]
        assert tr["rear_speed"][st.first_row] == 0.0, f"stage {i} does not start at standstill"
        assert np.all(speeds <= 0.0) if st.kind == "reverse" else np.all(speeds >= 0.0)
    assert tr["rear_speed"][-1] == 0.0
    if r.settings.process.resolved(r.settings.nmpc.kind) == "staged":
        assert [s.kind for s in r.stages][:2] in (["reverse"], ["reverse", "forward"])


def test_the_controller_saw_the_noisy_hitch_and_success_is_on_the_true_state(results):
    tr = results["faults"].trajectory
    err = np.degrees(tr["hitch_measured"] - tr["hitch"])
    assert 0.3 < np.std(err) < 0.7
    np.testing.assert_array_equal(results["random"].trajectory["hitch_measured"], results["random"].trajectory["hitch"])


def test_a_noisy_maneuver_is_the_same_every_time(results):
    again = park(V, STARTS["random"], plant=FAULTS)
    for column in ("x_trailer", "hitch", "hitch_measured", "front_steer_cmd"):
        np.testing.assert_array_equal(again.trajectory[column], results["faults"].trajectory[column])


def test_maneuver_json_records_the_plant_and_round_trips(results):
    r = results["faults"]
    data = json.loads(json.dumps(to_jsonable(r.to_dict())))
    assert data["plant"]["vehicle"]["hitch_offset"] == pytest.approx(1.1 * V.hitch_offset)
    assert data["plant"]["delay_steps"] == 1
    back = ManeuverResult.from_dict(data)
    assert back.plant_vehicle == r.plant_vehicle and back.plant.delay_steps == 1
    assert back.reason == r.reason
    for column in ("front_steer", "front_steer_cmd", "rear_speed_cmd", "hitch_measured"):
        np.testing.assert_allclose(back.trajectory[column], r.trajectory[column], equal_nan=True)


def test_full_nmpc_on_the_ideal_plant_starts_each_stage_from_rest():
    """Regression: the ideal car read its last forward speed while standing, and the next reverse
    stage's full NMPC, starting from +1 m/s, found its problem infeasible."""
    staged = ManeuverSettings(process=ProcessSettings(kind="staged"))
    result = park(V, State(8.0, 2.0, 0.3, 0.1), settings=staged, plant=PlantSettings(kind="ideal"))
    assert [s.kind for s in result.stages][:3] == ["reverse", "forward", "reverse"]
    assert result.outcome is Outcome.PARKED, result.detail


@pytest.mark.slow
def test_told_the_sensors_noise_the_controllers_see_the_estimate_nearer_the_truth(results):
    """The car with faults, its controller told the hitch sensor's 0.5 deg: ``hitch_measured`` is then the
    estimate, and it is nearer the true hitch than the readings the same maneuver saw without the estimator (0.36
    against 0.49 deg RMS: the lengths 10% off, the model's prediction lags while the hitch swings)."""
    from hitchpark.control import EstimatorSettings

    told = ManeuverSettings(estimator=EstimatorSettings(hitch_noise_std_deg=0.5))
    filtered = park(V, STARTS["random"], settings=told, plant=FAULTS)
    assert filtered.success, (filtered.reason, filtered.detail)

    def rms(r: ManeuverResult) -> float:
        tr = r.trajectory
        return float(np.sqrt(np.mean((tr["hitch_measured"] - tr["hitch"]) ** 2)))

    assert rms(filtered) < 0.8 * rms(results["faults"])
    assert math.degrees(rms(results["faults"])) == pytest.approx(0.5, rel=0.2)  # the readings, as the sensor gives
