"""Inverse kinematics (Section 3, Eqs. 42-46) and virtual-steer bounds (Section 4.2, Eqs. 56-57)."""

from __future__ import annotations

import dataclasses
import math

import casadi as ca
import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from hitchpark.checks import InputError
from hitchpark.model import (
    VehicleTrailer,
    actual_virtual_steer,
    front_steer_from_virtual,
    full_rhs,
    rear_speed_from_trailer_speed,
    rk4,
    trailer_rhs,
    trailer_speed_from_rear_speed,
    trailer_speed_from_virtual,
    vehicle_yaw_rate_from_virtual,
    virtual_steer_bounds,
    virtual_steer_from_front,
)
from hitchpark.model.inverse import front_steer_from_virtual_tangent

ANGLE_TOL = 1e-9


def degrees_between(low: float, high: float) -> st.SearchStrategy[float]:
    """Angles drawn in degrees, returned in radians."""
    return st.floats(low, high, allow_nan=False).map(math.radians)


vehicles = st.builds(
    VehicleTrailer,
    wheelbase=st.floats(1.5, 5.0),
    hitch_offset=st.floats(0.2, 2.5),
    trailer_length=st.floats(1.0, 8.0),
    max_steer=st.floats(0.1, 1.2),
    trailer_front=st.just(0.5),
)
hitches = degrees_between(-70.0, 70.0)
speeds = st.floats(-2.0, 2.0)


@st.composite
def hitch_and_virtual_steer(draw, margin_deg: float = 1.0):
    """A hitch angle in [-70, 70] deg and a virtual steer, both |hitch - virtual| and |virtual| < 90 deg."""
    hitch = draw(hitches)
    offset = draw(degrees_between(-90.0 + margin_deg, 90.0 - margin_deg))  # hitch - virtual steer
    virtual = hitch - offset
    assume(abs(virtual) < math.radians(90.0 - margin_deg))
    return hitch, virtual


# --- Eq. (45) and Eq. (56) -----------------------------------------------------------------


@given(vehicle=vehicles, hitch=hitches, front=degrees_between(-89.0, 89.0))
def test_front_to_virtual_to_front_round_trip(vehicle, hitch, front):
    virtual = virtual_steer_from_front(vehicle, hitch, front)  # Eq. (56)
    assert abs(hitch - virtual) < math.pi / 2
    assert front_steer_from_virtual(vehicle, hitch, virtual) == pytest.approx(front, abs=ANGLE_TOL)  # Eq. (45)


@given(vehicle=vehicles, pair=hitch_and_virtual_steer())
def test_virtual_to_front_to_virtual_round_trip(vehicle, pair):
    hitch, virtual = pair
    front = front_steer_from_virtual(vehicle, hitch, virtual)  # Eq. (45)
    assert abs(front) < math.pi / 2
    assert virtual_steer_from_front(vehicle, hitch, front) == pytest.approx(virtual, abs=ANGLE_TOL)  # Eq. (56)


@given(vehicle=vehicles, pair=hitch_and_virtual_steer())
def test_eq45_equals_its_simplified_form(vehicle, pair):
    """NOTES.md: tan(delta_f) = (L / L_H) tan(hitch - delta_T)."""
    hitch, virtual = pair
    L, L_H = vehicle.wheelbase, vehicle.hitch_offset
    expected = math.atan(L / L_H * math.tan(hitch - virtual))
    assert front_steer_from_virtual(vehicle, hitch, virtual) == pytest.approx(expected, abs=ANGLE_TOL)


@given(vehicle=vehicles, pair=hitch_and_virtual_steer())
def test_eq45_from_the_tangent_is_eq45_from_the_angle(vehicle, pair):
    """The same operations once the tangent is taken: equal to the last bit, on floats, arrays and symbols."""
    hitch, virtual = pair
    assert front_steer_from_virtual_tangent(vehicle, hitch, math.tan(virtual)) == front_steer_from_virtual(
        vehicle, hitch, virtual
    )
    hitches_, virtuals = np.array([hitch, -hitch, 0.0]), np.array([virtual, -virtual, 0.0])
    np.testing.assert_array_equal(
        front_steer_from_virtual_tangent(vehicle, hitches_, np.tan(virtuals)),
        front_steer_from_virtual(vehicle, hitches_, virtuals),
    )
    h, t = ca.SX.sym("h"), ca.SX.sym("t")
    symbolic = ca.Function("eq45", [h, t], [front_steer_from_virtual_tangent(vehicle, h, t)])
    assert float(symbolic(hitch, math.tan(virtual))) == pytest.approx(
        front_steer_from_virtual(vehicle, hitch, virtual), abs=1e-15
    )


def test_eq45_from_the_tangent_refuses_what_eq45_refuses(table4):
    with pytest.raises(InputError, match="tan_virtual"):
        front_steer_from_virtual_tangent(table4, 0.1, math.nan)
    with pytest.raises(InputError, match="hitch_offset"):
        front_steer_from_virtual_tangent(VehicleTrailer(hitch_offset=0.0), 0.1, 0.2)


@given(vehicle=vehicles, hitch=hitches, front=degrees_between(-89.0, 89.0))
def test_eq56_equals_its_simplified_form(vehicle, hitch, front):
    """NOTES.md: delta_T = hitch - atan((L_H / L) tan(delta_f))."""
    L, L_H = vehicle.wheelbase, vehicle.hitch_offset
    expected = hitch - math.atan(L_H / L * math.tan(front))
    assert virtual_steer_from_front(vehicle, hitch, front) == pytest.approx(expected, abs=ANGLE_TOL)


def test_eq56_literal_ratio_agrees_for_moderate_angles(table2):
    """Eq. (56) as printed (single-argument arctangent of the ratio) where its denominator is positive."""
    L, L_H = table2.wheelbase, table2.hitch_offset
    for hitch in np.radians([-40.0, -10.0, 0.0, 15.0, 45.0]):
        for front in (-0.75, -0.2, 0.0, 0.3, 0.75):
            s, c, t = math.sin(hitch), math.cos(hitch), math.tan(front)
            literal = math.atan((L * s - L_H * c * t) / (L * c + L_H * s * t))
            assert virtual_steer_from_front(table2, hitch, front) == pytest.approx(literal, abs=1e-12)


def test_mappings_broadcast_over_arrays(table2):
    hitch = np.radians([-30.0, 0.0, 15.0, 60.0])
    front = np.array([0.5, -0.2, 0.75, -0.75])
    virtual = virtual_steer_from_front(table2, hitch, front)
    assert virtual.shape == (4,)
    np.testing.assert_allclose(front_steer_from_virtual(table2, hitch, virtual), front, atol=1e-12)


def test_zero_virtual_steer_at_zero_hitch_needs_zero_front_steer(table4):
    assert front_steer_from_virtual(table4, 0.0, 0.0) == 0.0
    assert virtual_steer_from_front(table4, 0.0, 0.0) == 0.0


def test_on_axle_hitch_pins_virtual_steer_to_the_hitch_angle():
    vehicle = VehicleTrailer(hitch_offset=0.0)
    for front in (-0.7, 0.0, 0.4):
        assert virtual_steer_from_front(vehicle, 0.3, front) == pytest.approx(0.3, abs=1e-15)
    with pytest.raises(ValueError, match="hitch_offset"):
        front_steer_from_virtual(vehicle, 0.3, 0.1)
    with pytest.raises(ValueError, match="hitch_offset"):
        vehicle_yaw_rate_from_virtual(vehicle, 0.3, 0.1, -1.0)


# --- Eq. (44) and Eq. (18) -----------------------------------------------------------------


@given(vehicle=vehicles, pair=hitch_and_virtual_steer(), rear_speed=speeds)
def test_rear_speed_inverts_eq44(vehicle, pair, rear_speed):
    hitch, virtual = pair
    trailer_speed = trailer_speed_from_virtual(vehicle, hitch, virtual, rear_speed)  # Eq. (44)
    back = rear_speed_from_trailer_speed(vehicle, hitch, virtual, trailer_speed)
    assert back == pytest.approx(rear_speed, rel=1e-12, abs=1e-12)


@given(vehicle=vehicles, pair=hitch_and_virtual_steer(), trailer_speed=speeds)
def test_trailer_speed_to_rear_speed_and_back(vehicle, pair, trailer_speed):
    hitch, virtual = pair
    rear_speed = rear_speed_from_trailer_speed(vehicle, hitch, virtual, trailer_speed)
    again = trailer_speed_from_virtual(vehicle, hitch, virtual, rear_speed)
    assert again == pytest.approx(trailer_speed, rel=1e-9, abs=1e-12)


@given(vehicle=vehicles, pair=hitch_and_virtual_steer(), rear_speed=speeds)
def test_eq44_agrees_with_forward_model_eq18(vehicle, pair, rear_speed):
    hitch, virtual = pair
    front = front_steer_from_virtual(vehicle, hitch, virtual)  # Eq. (45)
    forward = trailer_speed_from_rear_speed(vehicle, hitch, rear_speed, front)  # Eq. (18)
    inverse = trailer_speed_from_virtual(vehicle, hitch, virtual, rear_speed)  # Eq. (44)
    assert forward == pytest.approx(inverse, rel=1e-9, abs=1e-12)


# --- the full model under inverse kinematics is the trailer-only model ----------------------


def full_inputs_from_virtual(vehicle, hitch, trailer_speed, virtual):
    """(V_R, delta_f) that realise the trailer input (V_T, delta_T) at this hitch angle."""
    front = front_steer_from_virtual(vehicle, hitch, virtual)  # Eq. (45)
    rear = rear_speed_from_trailer_speed(vehicle, hitch, virtual, trailer_speed)  # Eq. (44) solved
    return rear, front


@given(
    vehicle=vehicles,
    pair=hitch_and_virtual_steer(margin_deg=5.0),
    pose=st.tuples(st.floats(-50, 50), st.floats(-50, 50), degrees_between(-180.0, 180.0)),
    trailer_speed=speeds,
)
def test_full_model_rhs_equals_trailer_model_rhs(vehicle, pair, pose, trailer_speed):
    hitch, virtual = pair
    rear, front = full_inputs_from_virtual(vehicle, hitch, trailer_speed, virtual)
    full = full_rhs(vehicle, np.array([*pose, hitch]), [rear, front])
    trailer = trailer_rhs(vehicle, np.array(pose), [trailer_speed, virtual])  # Eq. (47)
    np.testing.assert_allclose(full[:3], trailer, rtol=1e-9, atol=1e-12)
    # The vehicle yaw rate is the one Eq. (43) asks for.
    assert full[2] + full[3] == pytest.approx(
        vehicle_yaw_rate_from_virtual(vehicle, hitch, virtual, trailer_speed), rel=1e-9, abs=1e-12
    )


@given(
    vehicle=vehicles,
    pair=hitch_and_virtual_steer(margin_deg=5.0),
    yaw=degrees_between(-180.0, 180.0),
    trailer_speed=st.one_of(st.floats(-2.0, -0.05), st.floats(0.05, 2.0)),
)
def test_eq46_reads_back_the_virtual_steer(vehicle, pair, yaw, trailer_speed):
    hitch, virtual = pair
    rear, front = full_inputs_from_virtual(vehicle, hitch, trailer_speed, virtual)
    assert actual_virtual_steer(vehicle, yaw, hitch, rear, front) == pytest.approx(virtual, abs=ANGLE_TOL)


@settings(max_examples=25)
@given(
    vehicle=vehicles,
    trailer_speed=st.floats(-1.0, -0.1),
    virtual=st.floats(-0.5, 0.5),
    start_hitch=st.floats(-0.5, 0.5),
    start_yaw=degrees_between(-180.0, 180.0),
)
def test_integrated_full_model_follows_trailer_model(vehicle, trailer_speed, virtual, start_hitch, start_yaw):
    """Reverse driving with a constant virtual input: continuous inverse kinematics on the full model."""

    def rhs(z):
        full, trailer = z[:4], z[4:]
        rear, front = full_inputs_from_virtual(vehicle, full[3], trailer_speed, virtual)
        return np.concatenate(
            (full_rhs(vehicle, full, [rear, front]), trailer_rhs(vehicle, trailer, [trailer_speed, virtual]))
        )

    z = np.array([1.0, -2.0, start_yaw, start_hitch, 1.0, -2.0, start_yaw])
    for _ in range(30):
        z = rk4(rhs, z, 0.1)
        np.testing.assert_allclose(z[:3], z[4:], rtol=0, atol=1e-9)
    # The trailer went somewhere: |V_T| * 3 s of travel.
    assert math.hypot(z[4] - 1.0, z[5] + 2.0) > 0.25


# --- Table 3 and the bounds of Eq. (57) ---------------------------------------------------------


def test_table3_mapped_bounds(table2):
    vehicle = dataclasses.replace(table2, max_steer=0.75)
    hitch = math.radians(15.0)
    lb1 = math.degrees(virtual_steer_from_front(vehicle, hitch, 0.75))
    ub1 = math.degrees(virtual_steer_from_front(vehicle, hitch, -0.75))
    assert lb1 == pytest.approx(-2.2512, abs=5e-5)
    assert ub1 == pytest.approx(32.2512, abs=5e-5)


def test_table3_intersected_bounds(table2):
    vehicle = dataclasses.replace(table2, max_steer=0.75)
    low, high = virtual_steer_bounds(vehicle, math.radians(15.0), 0.5)
    assert isinstance(low, float)
    assert isinstance(high, float)
    assert math.degrees(low) == pytest.approx(-2.2512, abs=5e-5)
    assert math.degrees(high) == pytest.approx(28.6479, abs=5e-5)


@given(
    vehicle=vehicles,
    hitch=hitches,
    virtual_limit=st.floats(0.05, 1.4),
    fraction=st.floats(0.0, 1.0),
)
def test_virtual_steer_in_bounds_is_steerable(vehicle, hitch, virtual_limit, fraction):
    low, high = virtual_steer_bounds(vehicle, hitch, virtual_limit)
    assert low <= high
    virtual = low + fraction * (high - low)
    for candidate in (low, virtual, high):
        assert abs(front_steer_from_virtual(vehicle, hitch, candidate)) <= vehicle.max_steer + 1e-12


@given(vehicle=vehicles, hitch=hitches, virtual_limit=st.floats(0.05, 1.4))
def test_bounds_are_the_intersection_or_collapse_to_nearest_end(vehicle, hitch, virtual_limit):
    lb1 = virtual_steer_from_front(vehicle, hitch, vehicle.max_steer)  # Eq. (56) is decreasing in delta_f
    ub1 = virtual_steer_from_front(vehicle, hitch, -vehicle.max_steer)
    assert lb1 < ub1
    low, high = virtual_steer_bounds(vehicle, hitch, virtual_limit)
    if lb1 > virtual_limit:  # steer-feasible range entirely above the virtual range
        assert low == high == pytest.approx(lb1, abs=1e-15)
    elif ub1 < -virtual_limit:  # entirely below
        assert low == high == pytest.approx(ub1, abs=1e-15)
    else:  # Eq. (57)
        assert low == pytest.approx(max(lb1, -virtual_limit), abs=1e-15)
        assert high == pytest.approx(min(ub1, virtual_limit), abs=1e-15)


def test_bounds_collapse_at_large_hitch_angles(table4):
    for hitch, nearest_front in (
        (math.radians(70.0), table4.max_steer),
        (math.radians(-70.0), -table4.max_steer),
    ):
        low, high = virtual_steer_bounds(table4, hitch, 0.5)
        assert low == high
        assert low == pytest.approx(virtual_steer_from_front(table4, hitch, nearest_front))
        assert abs(low) > 0.5  # outside the virtual range: the vehicle's steering limit wins
        assert abs(front_steer_from_virtual(table4, hitch, low)) == pytest.approx(table4.max_steer)


def test_bounds_broadcast_over_hitch_arrays(table2):
    hitch = np.radians([-70.0, -15.0, 0.0, 15.0, 70.0])
    low, high = virtual_steer_bounds(table2, hitch, 0.5)
    assert low.shape == high.shape == (5,)
    for k, h in enumerate(hitch):
        assert (low[k], high[k]) == pytest.approx(virtual_steer_bounds(table2, float(h), 0.5))


@pytest.mark.parametrize("limit", [0.0, -0.5, math.nan, math.inf])
def test_bounds_reject_bad_virtual_limit(table2, limit):
    with pytest.raises(ValueError, match="virtual_limit"):
        virtual_steer_bounds(table2, 0.1, limit)


def test_bounds_need_a_hitch_offset():
    with pytest.raises(ValueError, match="hitch_offset"):
        virtual_steer_bounds(VehicleTrailer(hitch_offset=0.0), 0.1, 0.5)


def test_lists_and_python_ints_are_numbers_too(table4):
    # Found by the fuzz suite: a tuple of speeds and an int past NumPy's int64 used to raise TypeError.
    assert rear_speed_from_trailer_speed(table4, 0.0, 0.0, (1, 2)) == pytest.approx([1.0, 2.0])
    assert math.isfinite(virtual_steer_from_front(table4, 0.0, -(2**63) - 1))
    with pytest.raises(InputError, match="hitch_angle must be finite"):
        virtual_steer_bounds(table4, [0.1, math.nan], 0.5)
