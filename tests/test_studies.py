"""The inverse-kinematics validation study of Section 3.2 (hitchpark.app.ik_study)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from hitchpark.app.ik_study import TABLE2_VEHICLE, default_virtual_profile, inverse_kinematics_study
from hitchpark.io import to_jsonable
from hitchpark.model import VehicleTrailer


@pytest.fixture(scope="module")
def study():
    return inverse_kinematics_study()


def test_table2_vehicle():
    assert (TABLE2_VEHICLE.wheelbase, TABLE2_VEHICLE.hitch_offset, TABLE2_VEHICLE.trailer_length) == (
        3.0,
        1.0,
        2.5,
    )


def test_study_defaults_are_table2_reversing(study):
    assert study.vehicle == TABLE2_VEHICLE
    assert study.rear_speed == -1.0
    tr = study.trajectory
    assert len(tr) == 401
    assert tr["t"][-1] == pytest.approx(20.0, abs=1e-9)


def test_actual_virtual_steer_tracks_the_desired_one(study):
    assert study.max_steer_error < 1e-9
    tr = study.trajectory
    # The profile is not trivial: it really steers both ways.
    assert tr["desired_virtual_steer"].max() > 0.2
    assert tr["desired_virtual_steer"].min() < -0.05


def test_full_model_trailer_follows_trailer_only_model(study):
    assert study.max_pose_error < 1e-9
    tr = study.trajectory
    np.testing.assert_allclose(tr["yaw_trailer"], tr["yaw_trailer_only"], atol=1e-9)
    # The trailer travelled: reversing at about 1 m/s for 20 s.
    assert math.hypot(tr["x_trailer"][-1], tr["y_trailer"][-1]) > 10.0


def test_error_properties_read_the_columns(study):
    tr = study.trajectory
    expected = np.max(np.abs(tr["actual_virtual_steer"] - tr["desired_virtual_steer"]))
    assert study.max_steer_error == expected
    gap = np.hypot(tr["x_trailer"] - tr["x_trailer_only"], tr["y_trailer"] - tr["y_trailer_only"])
    assert study.max_pose_error == np.max(gap)


def test_to_dict_is_json_ready(study):
    data = json.loads(json.dumps(to_jsonable(study.to_dict()), allow_nan=False))
    assert data["vehicle"]["wheelbase"] == 3.0
    assert data["rear_speed"] == -1.0
    assert data["max_virtual_steer_error_rad"] == study.max_steer_error
    assert data["max_trailer_position_error_m"] == study.max_pose_error
    assert set(data["trajectory"]) >= {
        "t",
        "desired_virtual_steer",
        "actual_virtual_steer",
        "front_steer",
        "hitch",
    }


def test_default_profile_shape():
    assert default_virtual_profile(0.0) == 0.0
    assert default_virtual_profile(5.0) == pytest.approx(0.2)
    assert default_virtual_profile(18.0) == pytest.approx(-0.1)
    values = default_virtual_profile(np.array([0.0, 5.0, 18.0]))
    np.testing.assert_allclose(values, [0.0, 0.2, -0.1], atol=1e-15)


@pytest.mark.parametrize(
    ("vehicle", "start_hitch", "rear_speed"),
    [
        (VehicleTrailer(), 0.3, -1.0),
        (TABLE2_VEHICLE, -0.2, -0.5),
        (VehicleTrailer(hitch_offset=0.4), 0.0, -1.0),
    ],
)
def test_study_holds_for_other_vehicles_and_starts(vehicle, start_hitch, rear_speed):
    result = inverse_kinematics_study(vehicle, rear_speed=rear_speed, duration=6.0, start_hitch=start_hitch)
    assert result.trajectory["hitch"][0] == start_hitch
    assert result.max_steer_error < 1e-9
    assert result.max_pose_error < 1e-9


def test_study_takes_a_custom_profile():
    result = inverse_kinematics_study(duration=4.0, profile=lambda t: 0.1 * np.sin(t))
    tr = result.trajectory
    np.testing.assert_allclose(tr["desired_virtual_steer"], 0.1 * np.sin(tr["t"]), atol=1e-15)
    assert result.max_steer_error < 1e-9


def test_study_needs_a_hitch_offset():
    with pytest.raises(ValueError, match="hitch_offset"):
        inverse_kinematics_study(VehicleTrailer(hitch_offset=0.0))
