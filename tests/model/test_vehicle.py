"""VehicleTrailer parameters and the TOML vehicle file (hitchpark.model.vehicle)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from hitchpark.model import VehicleTrailer, front_steer_from_virtual, load_vehicle, vehicle_from_dict


def test_defaults_are_table4(table4):
    assert table4.wheelbase == 2.896
    assert table4.hitch_offset == 1.159
    assert table4.trailer_length == 2.693
    assert table4.max_steer == 0.75
    assert table4.max_hitch == pytest.approx(math.radians(70.0), abs=1e-15)


def test_integers_are_accepted_and_stored_as_floats():
    vehicle = VehicleTrailer(wheelbase=3, hitch_offset=1, trailer_length=5)
    assert vehicle.wheelbase == 3.0
    assert isinstance(vehicle.wheelbase, float)
    assert isinstance(vehicle.hitch_offset, float)


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("wheelbase", 0.0),
        ("wheelbase", -2.9),
        ("wheelbase", math.nan),
        ("wheelbase", math.inf),
        ("wheelbase", True),
        ("wheelbase", "2.9"),
        ("wheelbase", None),
        ("trailer_length", 0.0),
        ("trailer_length", -1.0),
        ("trailer_length", math.nan),
        ("trailer_length", -math.inf),
        ("hitch_offset", -0.1),
        ("hitch_offset", math.nan),
        ("hitch_offset", math.inf),
        ("hitch_offset", False),
        ("hitch_offset", "1"),
        ("max_steer", 0.0),
        ("max_steer", -0.5),
        ("max_steer", math.pi / 2),
        ("max_steer", math.radians(95.0)),
        ("max_steer", math.nan),
        ("max_steer", "0.75"),
        ("max_hitch", 0.0),
        ("max_hitch", math.pi / 2),
        ("max_hitch", math.inf),
        ("vehicle_width", 0.0),
        ("trailer_width", -1.0),
        ("front_overhang", math.nan),
        ("rear_overhang", True),
        ("trailer_rear", -0.1),
        ("trailer_front", 0.0),
    ],
)
def test_bad_values_raise_naming_the_field(field, value):
    with pytest.raises(ValueError, match=field):
        VehicleTrailer(**{field: value})


def test_trailer_body_must_end_before_the_hitch():
    with pytest.raises(ValueError, match="trailer_front"):
        VehicleTrailer(trailer_length=2.0, trailer_front=2.0)


def test_on_axle_hitch_is_a_valid_vehicle_but_not_invertible():
    vehicle = VehicleTrailer(hitch_offset=0.0)
    assert vehicle.hitch_offset == 0.0
    with pytest.raises(ValueError, match="hitch_offset"):
        vehicle.require_hitch_offset()
    with pytest.raises(ValueError, match="hitch_offset"):
        front_steer_from_virtual(vehicle, 0.1, 0.05)
    VehicleTrailer().require_hitch_offset()  # L_H > 0: no error


def test_vehicle_is_frozen(table4):
    with pytest.raises(dataclasses.FrozenInstanceError):
        table4.wheelbase = 3.0  # type: ignore[misc]
    assert table4.wheelbase == 2.896


def test_replace_returns_a_checked_copy(table4):
    longer = dataclasses.replace(table4, trailer_length=4.0)
    assert longer.trailer_length == 4.0
    assert table4.trailer_length == 2.693
    with pytest.raises(ValueError, match="trailer_length"):
        dataclasses.replace(table4, trailer_length=-4.0)


def test_to_dict_round_trips_through_vehicle_from_dict():
    vehicle = VehicleTrailer(wheelbase=3.1, hitch_offset=0.8, max_steer=0.6)
    data = vehicle.to_dict()
    assert data["wheelbase"] == 3.1
    assert vehicle_from_dict(data) == vehicle


def test_vehicle_from_dict_starts_from_base():
    base = VehicleTrailer(wheelbase=3.3)
    vehicle = vehicle_from_dict({"trailer_length": 4.0}, base)
    assert vehicle.wheelbase == 3.3
    assert vehicle.trailer_length == 4.0


def test_vehicle_from_dict_rejects_unknown_field():
    with pytest.raises(ValueError, match="wheel_base"):
        vehicle_from_dict({"wheel_base": 3.0})


# --- load_vehicle ------------------------------------------------------------------------------


def test_load_vehicle_round_trip(tmp_path):
    path = tmp_path / "car.toml"
    path.write_text("wheelbase = 3.2\nhitch_offset = 0.9\nmax_steer = 0.6\ntrailer_length = 4\n", encoding="utf-8")
    vehicle = load_vehicle(path)
    assert vehicle == VehicleTrailer(wheelbase=3.2, hitch_offset=0.9, max_steer=0.6, trailer_length=4.0)
    assert vehicle.max_hitch == VehicleTrailer().max_hitch  # untouched fields keep their defaults


def test_load_vehicle_reads_a_vehicle_table(tmp_path):
    path = tmp_path / "car.toml"
    path.write_text("[vehicle]\nwheelbase = 2.5\n", encoding="utf-8")
    assert load_vehicle(str(path)).wheelbase == 2.5


def test_load_vehicle_starts_from_base(tmp_path):
    path = tmp_path / "car.toml"
    path.write_text("hitch_offset = 1.5\n", encoding="utf-8")
    vehicle = load_vehicle(path, base=VehicleTrailer(wheelbase=3.0))
    assert (vehicle.wheelbase, vehicle.hitch_offset) == (3.0, 1.5)


def test_load_vehicle_misspelt_field(tmp_path):
    path = tmp_path / "car.toml"
    path.write_text("wheelbase = 3.0\nhitch_ofset = 1.0\n", encoding="utf-8")
    with pytest.raises(ValueError, match="hitch_ofset"):
        load_vehicle(path)


@pytest.mark.parametrize(
    ("text", "field"),
    [
        ("max_steer = 1.6\n", "max_steer"),
        ("wheelbase = -3.0\n", "wheelbase"),
        ('trailer_length = "long"\n', "trailer_length"),
    ],
)
def test_load_vehicle_bad_value(tmp_path, text, field):
    path = tmp_path / "car.toml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ValueError, match=field):
        load_vehicle(path)


def test_load_vehicle_missing_file(tmp_path):
    with pytest.raises(ValueError, match="cannot read vehicle file"):
        load_vehicle(tmp_path / "nope.toml")


def test_load_vehicle_directory(tmp_path):
    with pytest.raises(ValueError, match="cannot read vehicle file"):
        load_vehicle(tmp_path)


@pytest.mark.parametrize("content", [b"wheelbase = \n", b"wheelbase 3.0\n", b"[vehicle\n", b"\xff\xfe\x00bad"])
def test_load_vehicle_invalid_toml(tmp_path, content):
    path = tmp_path / "car.toml"
    path.write_bytes(content)
    with pytest.raises(ValueError, match="not valid TOML"):
        load_vehicle(path)


def test_numpy_numbers_are_accepted():
    v = VehicleTrailer(wheelbase=np.int64(3), max_steer=np.float32(0.5), trailer_length=np.float64(2.5))
    assert v.wheelbase == 3.0 and isinstance(v.wheelbase, float)
    assert v.max_steer == pytest.approx(0.5)
    with pytest.raises(ValueError, match="wheelbase"):
        VehicleTrailer(wheelbase=np.bool_(True))
