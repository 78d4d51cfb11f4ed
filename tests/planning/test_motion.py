"""The motion primitives (hitchpark.planning.motion): the plant's model, reverse primitives in a batch."""

import numpy as np
import pytest

from hitchpark.model import VehicleTrailer
from hitchpark.model.integrate import step_full
from hitchpark.planning import PlannerSettings
from hitchpark.planning.motion import PrimitiveBatch

VEHICLE = VehicleTrailer()
SETTINGS = PlannerSettings(max_expansions=50_000)  # generous: tests assert behaviour, never timings


def test_a_held_steer_primitive_is_the_plant_model():
    """A forward primitive whose steer starts at its command holds it: RK4 of the full model, as the plant."""
    batch = PrimitiveBatch(VEHICLE, 1.0, 10, 3)
    start = np.array([1.0, -2.0, 0.3, 0.2])
    commands = np.array([-0.4, 0.0, 0.6])
    motions = batch.run(start, commands, commands, np.ones(3))
    for motion, steer in zip(motions, commands, strict=True):
        assert np.all(motion[:, 4] == pytest.approx(steer, abs=1e-12))
        state = start
        for k in range(1, 11):
            state = step_full(VEHICLE, state, 1.0, steer, 0.1)
            assert np.allclose(motion[k, :4], state, atol=1e-6)


def test_the_reverse_primitives_alone_are_those_of_the_whole_batch():
    """The opening's reverse-only search integrates the reverse half of the commands in a batch of its own."""
    size = 7
    whole, reverse = PrimitiveBatch(VEHICLE, 1.5, 15, 2 * size), PrimitiveBatch(VEHICLE, 1.5, 15, size)
    commands = np.concatenate([np.linspace(-0.5, 0.5, size), np.linspace(-0.45, 0.45, size)])
    directions = np.concatenate([np.ones(size), -np.ones(size)])
    steer0 = np.linspace(-0.3, 0.2, 2 * size)
    start = np.array([3.0, -1.0, 0.4, 0.25])
    np.testing.assert_array_equal(
        reverse.run(start, steer0[size:], commands[size:], directions[size:]),
        whole.run(start, steer0, commands, directions)[size:],
    )
