"""RK4 plant integration (hitchpark.model.integrate)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hitchpark.model import VehicleTrailer, full_rhs, rk4, step_full
from hitchpark.model.integrate import PLANT_SUBSTEPS


@pytest.mark.parametrize("substeps", [1, 3, 10])
def test_rk4_on_linear_ode_is_the_fourth_order_taylor_polynomial(substeps):
    """For x' = a x one RK4 step multiplies by 1 + z + z^2/2 + z^3/6 + z^4/24, z = a h."""
    a, dt = -1.3, 0.4
    z = a * dt / substeps
    factor = 1 + z + z**2 / 2 + z**3 / 6 + z**4 / 24
    result = rk4(lambda x: a * x, np.array([2.0]), dt, substeps=substeps)
    assert result[0] == pytest.approx(2.0 * factor**substeps, rel=1e-14)
    assert result[0] == pytest.approx(2.0 * math.exp(a * dt), rel=1e-3)


def test_rk4_error_falls_as_fourth_power_of_step(table4):
    state = np.array([0.0, 0.0, 0.1, 0.4])

    def rhs(x):
        return full_rhs(table4, x, [-1.0, 0.6])

    reference = rk4(rhs, state, 2.0, substeps=2000)
    errors = [np.max(np.abs(rk4(rhs, state, 2.0, substeps=n) - reference)) for n in (5, 10, 20)]
    ratios = [errors[0] / errors[1], errors[1] / errors[2]]
    for ratio in ratios:
        assert 12.0 < ratio < 20.0  # 2^4 = 16


def test_rk4_does_not_modify_its_input(table4):
    state = np.array([1.0, 2.0, 0.3, -0.2])
    copy = state.copy()
    out = step_full(table4, state, -1.0, 0.5, 0.1)
    np.testing.assert_array_equal(state, copy)
    assert not np.array_equal(out, state)


def test_zero_speed_leaves_the_state_alone(table4):
    state = np.array([1.0, 2.0, 0.3, -0.2])
    np.testing.assert_array_equal(step_full(table4, state, 0.0, 0.7, 0.1), state)


@settings(max_examples=60)
@given(
    rear_speed=st.floats(-1.0, 1.0),
    front_steer=st.floats(-0.75, 0.75),
    yaw=st.floats(-math.pi, math.pi),
    hitch=st.floats(-math.radians(70.0), math.radians(70.0)),
)
def test_default_substeps_reach_the_documented_accuracy(rear_speed, front_steer, yaw, hitch):
    """integrate.py: at dt = 0.1 s and |V_R| <= 1 m/s the default sub-steps leave a local error < 1e-12 m."""
    vehicle = VehicleTrailer()
    state = np.array([3.0, -4.0, yaw, hitch])
    coarse = step_full(vehicle, state, rear_speed, front_steer, 0.1)
    fine = step_full(vehicle, state, rear_speed, front_steer, 0.1, substeps=20 * PLANT_SUBSTEPS)
    np.testing.assert_allclose(coarse, fine, rtol=0, atol=1e-12)
