"""The full-model parking OCP: predict what the car will do, not only what the trailer should.

States ``(x_trailer, y_trailer, yaw_trailer, hitch, front_steer, rear_speed)`` in the parking
frame; inputs ``(steer_rate, accel)``. The pose and hitch follow the full kinematics
(Eqs. 19-24, the hitch rate being Eq. (21) minus Eq. (24), as Eq. (43) gives it in the virtual
inputs), the steer and speed integrate their rates. Every limit of the car holds on the whole
horizon, not only on the first step as Eqs. (56)-(57) can promise: |steer| <= max_steer,
|steer rate| <= max_steer_rate, |accel| <= max_accel, |hitch| <= max_hitch - hitch_margin, and
the speed within [speed_min, 0] (reverse). The cost is Eq. (49)'s quadratic form on these
states and inputs, with a terminal weight P. One RK4 step per sample keeps the prediction
accurate at 1 m/s.

Among obstacles (:class:`FullParkingProblem` given a :class:`~.obstacles.ClearanceConstraints`) every
predicted X_k also keeps the bodies on the free side of the scene's separating lines, which are
parameters of each step: the obstacle OCP.

Tracking (``tracking=True``) the cost weighs X_k - R_k instead of X_k, with a reference state R_k of
each step among the step's parameters (a planned path moved along in time,
:class:`~.reference.PathReference`); where the reference has reached the goal, R_k = 0 and the OCP is the
parking OCP again.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import casadi as ca
import numpy as np

from ..model.integrate import rk4
from ..model.kinematics import full_rhs
from ..model.vehicle import VehicleTrailer
from .obstacles import ClearanceConstraints
from .settings import NMPCSettings

__all__ = ["FULL_OCP_INPUT", "FULL_OCP_STATE", "FullParkingProblem"]

FULL_OCP_STATE = ("x_trailer", "y_trailer", "yaw_trailer", "hitch", "front_steer", "rear_speed")
FULL_OCP_INPUT = ("steer_rate", "accel")

#: Index of the steer and speed in the state.
STEER, SPEED = 4, 5


class FullParkingProblem:
    """Drive the full model to the zero state (parked, hitch straight, stopped) within the car's limits."""

    state_names = FULL_OCP_STATE
    input_names = FULL_OCP_INPUT
    n_x = 6
    n_u = 2

    def __init__(
        self,
        vehicle: VehicleTrailer,
        settings: NMPCSettings,
        clearance: ClearanceConstraints | None = None,
        tracking: bool = False,
    ):
        self.vehicle = vehicle
        self.settings = settings
        self.clearance = clearance
        self.tracking = tracking
        #: A step's parameters: its reference state when tracking, then its separating lines.
        self.n_ref = self.n_x if tracking else 0
        self.n_p = self.n_ref + (0 if clearance is None else clearance.n_params)
        #: The first prediction step's length is the NLP's last parameter (the transcription's ``OCP.first_step``):
        #: the grid stays put in time. Not among obstacles: there the grid moving on a third of a step each
        #: sample took fewer iterations (docs/history/speed-notebook.md, "Prediction grid").
        self.first_step = clearance is None
        self.path_constraints: list[Callable[[Any, Any, int], tuple[Any, Any, Any]]] = []
        self._Q = ca.diag(ca.DM(list(settings.Q or ())))
        self._R = ca.diag(ca.DM(list(settings.R or ())))
        self._P = ca.diag(ca.DM(list(settings.P or ())))

    @property
    def horizon(self) -> int:
        assert self.settings.horizon is not None
        return self.settings.horizon

    def rhs(self, x: Any, u: Any) -> Any:
        """Time derivative of the state: full kinematics (Eqs. 19-24) plus the actuator integrators."""
        pose_rates = full_rhs(self.vehicle, x[0:4], ca.vertcat(x[SPEED], x[STEER]))
        return ca.vertcat(pose_rates, u[0], u[1])

    def discrete_dynamics(self, x: Any, u: Any, dt: Any = None) -> Any:
        """One RK4 step of ``dt`` [s] (a number or a CasADi symbol; default: the prediction step), inputs held."""
        step = self.settings.prediction_dt if dt is None else dt
        assert step is not None
        return rk4(lambda z: self.rhs(z, u), x, step, substeps=1)

    def _error(self, x: Any, params: Any) -> Any:
        """X_k, or X_k - R_k when tracking (``params``: the step's parameters, the reference first), its
        position part along and across the reference's heading: Q and P weigh the error along the path as
        they weigh it along the goal line, the last stretch of every path."""
        if not self.tracking:
            return x
        e = x - params[: self.n_ref]
        c, s = ca.cos(params[2]), ca.sin(params[2])
        return ca.vertcat(c * e[0] + s * e[1], -s * e[0] + c * e[1], e[2:])

    def stage_cost(self, x: Any, u: Any, params: Any = None) -> Any:
        """E_k^T Q E_k + U_k^T R U_k, Eq. (49) on the full state (E_k = X_k, or X_k - R_k tracking) and the
        actuator rates."""
        e = self._error(x, params)
        return ca.bilin(self._Q, e, e) + ca.bilin(self._R, u, u)

    def terminal_cost(self, x: Any, params: Any = None) -> Any:
        """E_N^T P E_N."""
        e = self._error(x, params)
        return ca.bilin(self._P, e, e)

    def step_rows(self, x: Any, params: Any) -> tuple[list[Any], list[float], list[float]]:
        """The separating lines of the scene at this step (none in open space)."""
        return ([], [], []) if self.clearance is None else self.clearance.rows(x, params[self.n_ref :])

    def state_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Bounds on X_1..X_N: the jackknife limit with its margin, the steer limit, reverse speeds."""
        v, s = self.vehicle, self.settings
        hitch = v.max_hitch - s.hitch_margin
        low = np.array([-np.inf, -np.inf, -np.inf, -hitch, -v.max_steer, s.speed_min])
        high = np.array([np.inf, np.inf, np.inf, hitch, v.max_steer, s.speed_max])
        return low, high

    def input_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The steer-rate and acceleration limits of the vehicle."""
        v = self.vehicle
        return np.array([-v.max_steer_rate, -v.max_accel]), np.array([v.max_steer_rate, v.max_accel])
