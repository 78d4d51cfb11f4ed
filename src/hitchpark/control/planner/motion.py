"""Motion primitives on the exact full model (Eqs. 19-24), integrated for many primitives in one call.

A primitive drives the rear axle ``length`` metres at 1 m/s, forward or in reverse, while the front steer
moves from its value at the start towards a target at ``max_steer_rate`` (a ramp, then held): the steer
never jumps within a direction. One RK4 step of the full model per sample, with the ramp evaluated at
the RK4 stages' times. Built once per vehicle and sampling as a CasADi function mapped over a batch of
primitives: evaluating 14 primitives of 10 samples takes about 0.3 ms, against about 1.8 ms for the same
RK4 vectorised in NumPy (measured on this 2-core machine).
"""

from __future__ import annotations

import functools

import casadi as ca
import numpy as np

from ...model.kinematics import full_rhs
from ...model.vehicle import VehicleTrailer

__all__ = ["PrimitiveBatch", "steer_profile"]


def steer_profile(start: np.ndarray, target: np.ndarray, rate: float, t: np.ndarray) -> np.ndarray:
    """Steer at times ``t`` [s] of a ramp from ``start`` towards ``target`` at ``rate`` [rad/s], then held."""
    return start + np.clip(target - start, -rate * t, rate * t)


@functools.lru_cache(maxsize=16)
def _primitive_function(vehicle: VehicleTrailer, length: float, samples: int) -> ca.Function:
    """``F(x0[4], steer0, steer1, direction) -> (4, samples + 1)``: the configurations at the samples."""
    x0, s0, s1, d = ca.SX.sym("x0", 4), ca.SX.sym("s0"), ca.SX.sym("s1"), ca.SX.sym("d")
    rate = vehicle.max_steer_rate
    h = length / samples

    def steer(t: float) -> ca.SX:
        return s0 + ca.fmin(ca.fmax(s1 - s0, -rate * t), rate * t)

    def rhs(x: ca.SX, t: float) -> ca.SX:
        return full_rhs(vehicle, x, ca.vertcat(d, steer(t)))

    x, columns = x0, [x0]
    for i in range(samples):
        t = i * h
        k1 = rhs(x, t)
        k2 = rhs(x + 0.5 * h * k1, t + 0.5 * h)
        k3 = rhs(x + 0.5 * h * k2, t + 0.5 * h)
        k4 = rhs(x + h * k3, t + h)
        x = x + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        columns.append(x)
    return ca.Function("primitive", [x0, s0, s1, d], [ca.horzcat(*columns)])


class PrimitiveBatch:
    """Integrates up to ``size`` primitives of one vehicle and sampling at once."""

    def __init__(self, vehicle: VehicleTrailer, length: float, samples: int, size: int):
        self.samples = samples
        self.size = size
        self.times = np.linspace(0.0, length, samples + 1)
        self._mapped = _primitive_function(vehicle, length, samples).map(size)

    def run(self, start: np.ndarray, steer0: np.ndarray, steer1: np.ndarray, direction: np.ndarray) -> np.ndarray:
        """Configurations, shape ``(n, samples + 1, 4)``, of the ``n <= size`` primitives from ``start`` (4,).

        ``steer0``, ``steer1``, ``direction`` (+1 forward, -1 reverse): one per primitive.
        """
        n = len(steer1)
        pad = self.size - n
        s0 = np.pad(np.asarray(steer0, dtype=float), (0, pad))
        s1 = np.pad(np.asarray(steer1, dtype=float), (0, pad))
        d = np.pad(np.asarray(direction, dtype=float), (0, pad))
        x0 = np.repeat(np.asarray(start, dtype=float)[:, None], self.size, axis=1)
        out = np.asarray(self._mapped(x0, s0, s1, d))  # (4, size * (samples + 1))
        return out.reshape(4, self.size, self.samples + 1).transpose(1, 2, 0)[:n]
