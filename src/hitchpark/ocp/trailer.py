"""The paper's trailer-parking optimal control problem, Eqs. (47)-(57): model, cost, constraints.

This module says *what* is optimised. How it becomes a nonlinear program
(:mod:`hitchpark.solvers.transcription`) and which solver solves it (:func:`hitchpark.solvers.make_solver`) are
chosen apart, so solvers can be swapped and the problem extended (longer horizons, more states, obstacle
constraints) without touching the others.

Everything here lives in the parking frame (Fig. 5): origin at the goal trailer-axle
position, X along the goal trailer heading, so the parked state is zero.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from ..checks import InputError
from ..model.inverse import virtual_steer_bounds
from ..model.kinematics import TRAILER_INPUT, TRAILER_STATE, trailer_rhs
from ..model.vehicle import VehicleTrailer
from ..solvers.transcription import PathConstraint
from .settings import NMPCSettings

__all__ = ["TrailerParkingProblem"]


class TrailerParkingProblem:
    """The OCP of Eq. (50): drive the trailer-only model (Eq. 47) to the zero state.

    Attributes
    ----------
    n_x, n_u : int
        Number of states (3: x, y, yaw) and inputs (2: trailer speed, virtual steer).
    path_constraints : list of PathConstraint
        Extra stage constraints (empty in the paper); transcriptions add them for k = 0..N-1.
    """

    state_names = TRAILER_STATE
    input_names = TRAILER_INPUT
    n_x = 3
    n_u = 2
    n_p = 0
    first_step = False  # its prediction step is the controller's sample (Eq. 48)

    def __init__(self, vehicle: VehicleTrailer, settings: NMPCSettings | None = None):
        vehicle.require_hitch_offset()
        self.vehicle = vehicle
        self.settings = settings or NMPCSettings(kind="paper")
        if self.settings.kind != "paper":
            raise InputError(
                f"TrailerParkingProblem is the paper's OCP: it needs nmpc.kind 'paper', got {self.settings.kind!r}"
            )
        self.path_constraints: list[PathConstraint] = []
        s = self.settings
        self._Q = ca.diag(ca.DM(list(s.Q or ())))
        self._R = ca.diag(ca.DM(list(s.R or ())))
        self._P = ca.diag(ca.DM(list(s.P or ())))

    @property
    def horizon(self) -> int:
        assert self.settings.horizon is not None  # resolved per kind by NMPCSettings
        return self.settings.horizon

    def discrete_dynamics(self, x: Any, u: Any, dt: Any = None) -> Any:
        """g(X_k, U_k) = X_k + d_t f(X_k, U_k): the Euler step of Eq. (48) (``dt`` None: d_t)."""
        return x + (self.settings.dt if dt is None else dt) * trailer_rhs(self.vehicle, x, u)

    def stage_cost(self, x: Any, u: Any, params: Any = None) -> Any:
        """X_k^T Q X_k + U_k^T R U_k, Eq. (49)."""
        return ca.bilin(self._Q, x, x) + ca.bilin(self._R, u, u)

    def terminal_cost(self, x: Any, params: Any = None) -> Any:
        """X_N^T P X_N, Eq. (49)."""
        return ca.bilin(self._P, x, x)

    def state_bounds(self) -> tuple[np.ndarray, np.ndarray] | None:
        """Bounds on X_1..X_N: none in the paper's OCP (Eq. 50 bounds only the inputs)."""
        return None

    def step_rows(self, x: Any, params: Any) -> tuple[list[Any], list[float], list[float]]:
        """None: the paper's OCP has no parameters beyond X_0."""
        return [], [], []

    def input_bounds(self, hitch: float) -> tuple[np.ndarray, np.ndarray]:
        """U_min, U_max at the current hitch angle: speed bounds and Eqs. (56)-(57)."""
        low, high = virtual_steer_bounds(self.vehicle, hitch, self.settings.virtual_limit)
        s = self.settings
        return np.array([s.speed_min, low]), np.array([s.speed_max, high])
