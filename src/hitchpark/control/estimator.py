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

The estimate carries its **doubt** (``Measurement.doubt``): how far each component may be from the truth, what
the guard allows for (:class:`~hitchpark.control.guard.Guard`). The estimate's error is the gain-weighted sum of
the model's errors and the readings' noise (after a correction, ``(1 - K)`` times the predicted error plus ``K``
times the reading's), and the doubt bounds each part apart:

* **the model's**, which repeats and so does not average out: the vehicle's ``length_tolerance`` says how far the
  real L_H and L_T may be from the model's, and each prediction is also made with both scaled by ``1 - f`` and
  ``1 + f``, and from the estimate moved by its bound either side (the error grows through the model, in reverse
  above all): the farthest of these from the prediction is the bound before the correction, ``1 - K`` of it
  after. Measured on the fault plant (lengths 10% long, 0.5 deg of noise) the estimate's hitch ran up to 1.6 deg
  off at large hitch angles in reverse, three times the sensor's noise: a doubt that ignores the lengths would
  leave the guard blind to it;
* **the noise's**: its variance through the same corrections (``(1 - K)^2`` and ``K^2`` times the reading's, the
  ``drift`` added each sample), counted ``doubt_sigmas`` standard deviations.

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
    doubt_sigmas : float
        How many standard deviations of the estimate's noise its doubt allows (the module text).
    """

    hitch_noise_std_deg: float = checked(0.0, Real(0.0, 10.0, unit="deg"))
    yaw_noise_std_deg: float = checked(0.0, Real(0.0, 10.0, unit="deg"))
    position_noise_std_m: float = checked(0.0, Real(0.0, 5.0, unit="m"))
    model_error: float = checked(0.2, Real(0.0, 1.0))
    drift_deg: float = checked(0.02, Real(0.0, 10.0, unit="deg"))
    drift_m: float = checked(0.002, Real(0.0, 1.0, unit="m"))
    doubt_sigmas: float = checked(3.0, Real(0.0, 10.0))

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
        self.bias = np.zeros(4)  # the bound of the model's part of the error (the module text)
        self.noise = np.zeros(4)  # the variance of the noise's part
        # The model with both lengths at either end of their tolerance (none without one).
        f = vehicle.length_tolerance
        self.ends = tuple(
            replace(vehicle, hitch_offset=vehicle.hitch_offset * k, trailer_length=vehicle.trailer_length * k)
            for k in ((1.0 - f, 1.0 + f) if f > 0.0 else ())
        )
        self.t = -math.inf
        self.inputs = np.zeros(2)  # the actual speed and steer at the last reading

    def reset(self) -> None:
        """Forget the estimate: the next reading starts it afresh."""
        self.x = None

    def predict(
        self, x: np.ndarray, inputs: np.ndarray, dt: float, vehicle: VehicleTrailer | None = None
    ) -> np.ndarray:
        """The model's configuration ``dt`` seconds on from ``x`` (or each column of it) at ``inputs`` (speed,
        steer) held: RK4, with ``vehicle``'s lengths (default: the model's)."""
        v = self.vehicle if vehicle is None else vehicle
        return np.asarray(rk4(lambda y: full_rhs(v, y, inputs), x, dt, substeps=1), dtype=float)

    def model_bound(
        self, x: np.ndarray, ahead: np.ndarray, bias: np.ndarray, inputs: np.ndarray, dt: float
    ) -> np.ndarray:
        """How far the truth may be from the prediction ``ahead`` of ``x`` by the model's part alone: the farthest
        of the predictions from ``x`` moved by ``bias`` either side, by the model and by its lengths' ends."""
        if not bias.any():  # from x itself the model's own prediction is ``ahead``: only its lengths' ends differ
            starts, models = x[:, None], self.ends
        else:
            starts, models = np.column_stack([x + bias, x - bias]), (self.vehicle, *self.ends)
        if not models:
            return np.zeros_like(x)
        gap = np.hstack([self.predict(starts, inputs[:, None], dt, v) for v in models]) - ahead[:, None]
        gap[2:] = wrap_angle(gap[2:])
        return np.abs(gap).max(axis=1)

    @property
    def doubt(self) -> np.ndarray:
        """How far each component of the last estimate may be from the truth (the module text); 0 where exact."""
        return self.bias + self.settings.doubt_sigmas * np.sqrt(self.noise)

    def update(self, m: Measurement) -> Measurement:
        """The measurement with the configuration estimated from every reading so far, this one last."""
        if not self.noisy.any():
            return m
        z = m.state.as_array()
        inputs = np.array([m.rear_speed, m.front_steer])
        if self.x is None:
            x, p = z.copy(), self.r.copy()
            bias, noise = np.zeros(4), self.r.copy()
        else:
            x, p, bias, noise = self.x, self.p, self.bias, self.noise
            dt = m.t - self.t
            if dt > 0.0:
                held = 0.5 * (self.inputs + inputs)
                ahead = self.predict(x, held, dt)
                bias = np.where(self.noisy, self.model_bound(x, ahead, bias, held, dt), 0.0)
                change = ahead - x
                x = ahead
                drift = self.q_drift * (dt / self.dt)
                p = p + (self.settings.model_error * change) ** 2 + drift
                noise = noise + drift
            gain = np.where(self.noisy, p / np.where(self.noisy, p + self.r, 1.0), 1.0)
            residual = z - x
            residual[2:] = wrap_angle(residual[2:])
            x = np.where(self.noisy, x + gain * residual, z)
            p = np.where(self.noisy, (1.0 - gain) * p, 0.0)
            bias = np.where(self.noisy, (1.0 - gain) * bias, 0.0)
            noise = np.where(self.noisy, (1.0 - gain) ** 2 * noise + gain**2 * self.r, 0.0)
        self.x, self.p, self.t, self.inputs = x, p, m.t, inputs
        self.bias, self.noise = bias, noise
        d = self.doubt
        return replace(m, state=State.from_array(x), doubt=(float(d[0]), float(d[1]), float(d[2]), float(d[3])))
