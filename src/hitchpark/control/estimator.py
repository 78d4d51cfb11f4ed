"""A filter between the sensors and the controllers: the configuration the controllers act on.

A hitch-angle sensor reads within a fraction of a degree (a noise of 0.5 deg is the fault plant's). Half a
degree of hitch moves the car's front corners 3-4 cm, so a controller that acts on each reading as it comes
steers at the noise, and the guard stops the car whenever a reading puts a body nearer the scene than it is.
Measured on the fault plant: of the 13 starts of ``campground_angled`` that did not park, 12 park with the
noise taken out of the plant (docs/places.md).

:class:`Estimator` is a Kalman filter per component of the configuration (x_t, y_t, yaw_t, hitch), with the
model as its prediction:

* **Predict** over the time since the last reading with the model (Eqs. 19-24, RK4), at the mean of the actual
  speed and steer the car reported then and now (those sensors are exact, :class:`~hitchpark.model.plant.
  Measurement`). The prediction's variance grows by the square of ``model_error`` times the component's
  predicted change (the model's lengths may be off by that fraction: the vehicle's ``length_tolerance``), and
  of ``drift`` per sample.
* **Correct** towards the reading with the gain ``P / (P + r)``, ``r`` the sensor's variance: the
  ``*_noise_std`` settings, the controller's belief about its sensors (their datasheet), not the plant's.

Several readings at one time (a stage's start, the steer set standing) are several corrections. A component
whose sensor is exact (its std 0) is the reading itself: with every std 0, the default, the controllers see
the readings as they are, bit for bit. :func:`~hitchpark.maneuver.park` (and so ``park``, ``reproduce`` and
``sweep``) puts it in its loop from the settings' ``[estimator]`` table; the knob assist reads the sensors as
they are.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..checks import Real, check_fields, checked
from ..model.integrate import rk4
from ..model.kinematics import full_rhs
from ..model.plant import Measurement
from ..model.state import State, wrap_angle
from ..model.vehicle import VehicleTrailer

__all__ = ["Estimator", "EstimatorSettings"]


@dataclass(frozen=True)
class EstimatorSettings:
    """What the controller believes about its sensors and its model (the ``[estimator]`` table).

    Parameters
    ----------
    hitch_noise_std_deg, yaw_noise_std_deg : float
        Standard deviation of the hitch-angle / trailer-yaw sensor's noise [deg]; 0: exact, not filtered.
    position_noise_std_m : float
        Standard deviation of the trailer axle's measured x and y [m]; 0: exact, not filtered.
    model_error : float
        The fraction of the model's predicted change over a sample that may be wrong. Twice the lengths' doubt
        of the fault plant (10%): that error repeats sample after sample, which the variance of independent
        errors understates. Over reverse arcs with the lengths 10% long and 0.5 deg of noise, 0.2 read the
        hitch best of 0.1, 0.2, 0.3, 0.5 and 1 (``tests/control/test_estimator.py``).
    drift_deg, drift_m : float
        What an angle [deg] / a position [m] may change per sample that the model does not predict at all.
    """

    hitch_noise_std_deg: float = checked(0.0, Real(0.0, 10.0, unit="deg"))
    yaw_noise_std_deg: float = checked(0.0, Real(0.0, 10.0, unit="deg"))
    position_noise_std_m: float = checked(0.0, Real(0.0, 5.0, unit="m"))
    model_error: float = checked(0.2, Real(0.0, 1.0))
    drift_deg: float = checked(0.02, Real(0.0, 10.0, unit="deg"))
    drift_m: float = checked(0.002, Real(0.0, 1.0, unit="m"))

    def __post_init__(self) -> None:
        check_fields(self, "estimator.")

    @property
    def filters(self) -> bool:
        """Whether any sensor is noisy (else the estimator passes the readings through)."""
        return self.hitch_noise_std_deg > 0.0 or self.yaw_noise_std_deg > 0.0 or self.position_noise_std_m > 0.0


class Estimator:
    """The filter of the module text, for one maneuver (:meth:`update` each reading, in time order)."""

    def __init__(self, vehicle: VehicleTrailer, settings: EstimatorSettings, dt: float):
        self.vehicle, self.settings, self.dt = vehicle, settings, dt
        s = settings
        std = np.array(
            [
                s.position_noise_std_m,
                s.position_noise_std_m,
                math.radians(s.yaw_noise_std_deg),
                math.radians(s.hitch_noise_std_deg),
            ]
        )
        self.r = std**2
        self.noisy = self.r > 0.0
        drift = np.array([s.drift_m, s.drift_m, math.radians(s.drift_deg), math.radians(s.drift_deg)])
        self.q_drift = drift**2
        self.x: np.ndarray | None = None
        self.p = np.zeros(4)
        self.t = -math.inf
        self.inputs = np.zeros(2)  # the actual speed and steer at the last reading

    def reset(self) -> None:
        """Forget the estimate: the next reading starts it afresh."""
        self.x = None

    def predict(self, x: np.ndarray, inputs: np.ndarray, dt: float) -> np.ndarray:
        """The model's configuration ``dt`` seconds on from ``x`` at ``inputs`` (speed, steer) held: RK4."""
        return np.asarray(rk4(lambda y: full_rhs(self.vehicle, y, inputs), x, dt, substeps=1), dtype=float)

    def update(self, m: Measurement) -> Measurement:
        """The measurement with the configuration estimated from every reading so far, this one last."""
        if not self.noisy.any():
            return m
        z = m.state.as_array()
        inputs = np.array([m.rear_speed, m.front_steer])
        if self.x is None:
            x, p = z.copy(), self.r.copy()
        else:
            x, p = self.x, self.p
            dt = m.t - self.t
            if dt > 0.0:
                ahead = self.predict(x, 0.5 * (self.inputs + inputs), dt)
                change = ahead - x
                x = ahead
                p = p + (self.settings.model_error * change) ** 2 + self.q_drift * (dt / self.dt)
            gain = np.where(self.noisy, p / np.where(self.noisy, p + self.r, 1.0), 1.0)
            residual = z - x
            residual[2:] = wrap_angle(residual[2:])
            x = np.where(self.noisy, x + gain * residual, z)
            p = np.where(self.noisy, (1.0 - gain) * p, 0.0)
        self.x, self.p, self.t, self.inputs = x, p, m.t, inputs
        return replace(m, state=State.from_array(x))
