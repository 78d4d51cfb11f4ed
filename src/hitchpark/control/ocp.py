"""The trailer-parking optimal control problem, Eqs. (47)-(57): model, cost, constraints.

This module says *what* is optimised. How it becomes a nonlinear program
(:mod:`.transcription`) and which solver solves it (:mod:`.solver`) are chosen
apart, so solvers can be swapped and the problem extended (longer horizons, more
states, obstacle constraints) without touching the others.

Everything here lives in the parking frame (Fig. 5): origin at the goal trailer-axle
position, X along the goal trailer heading, so the parked state is zero.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np

from ..model.inverse import virtual_steer_bounds
from ..model.kinematics import TRAILER_INPUT, TRAILER_STATE, trailer_rhs
from ..model.vehicle import VehicleTrailer

__all__ = ["NMPCSettings", "PathConstraint", "TrailerParkingProblem"]


def _diag(name: str, values: Sequence[float], size: int, positive: bool) -> tuple[float, ...]:
    try:
        items = list(values) if not isinstance(values, str) else None
    except TypeError:
        items = None
    if items is None:
        raise ValueError(f"{name} must be a list of {size} numbers (the diagonal), got {values!r}")
    if any(isinstance(v, bool | np.bool_) or not isinstance(v, numbers.Real) for v in items):
        raise ValueError(f"{name} entries must be numbers, got {items!r}")
    vals = tuple(float(v) for v in items)
    if len(vals) != size:
        raise ValueError(f"{name} must have {size} diagonal entries, got {len(vals)}")
    for v in vals:
        if not math.isfinite(v) or v < 0 or (positive and v == 0):
            bound = "> 0" if positive else ">= 0"
            raise ValueError(f"{name} entries must be finite and {bound}, got {list(vals)}")
    return vals


@dataclass(frozen=True)
class NMPCSettings:
    """Settings of the trailer NMPC. Defaults are the paper's Table 4.

    Parameters
    ----------
    dt : float
        Sample time d_t [s] of the Euler model, Eq. (48), and of the controller.
    horizon : int
        Prediction/control horizon N [steps].
    Q, P : tuple of 3 floats
        Diagonals of the stage and terminal state weights on (x, y, yaw) [1/m^2, 1/m^2, 1/rad^2], Eq. (49).
    R : tuple of 2 floats
        Diagonal of the input weight on (trailer speed, virtual steer), Eq. (49).
    speed_min, speed_max : float
        Trailer-speed bounds V_T,min, V_T,max [m/s]; the NMPC only reverses.
    virtual_limit : float
        |delta_T| <= virtual_limit [rad]: [delta_T,lb2, delta_T,ub2] of Eq. (57).
    stop_speed : float
        A reverse stage ends when the optimal |V_T,0| falls below this [m/s]
        ("the trailer speed in the solution becomes zero", Section 4.1). The
        solver's own tolerance is ~1e-8, so 1e-3 m/s (1 mm per 1 s) separates a
        real zero from the last fractional approach step, which is larger.
    max_steps : int
        A reverse stage that has not stopped after this many steps ends as stalled.
    solver : str
        ``"sqp"`` (CasADi sqpmethod with the qrqp QP solver, exact Hessian, fast) or ``"ipopt"``
        (interior point).
    fallback_solver : str or None
        Solver tried when the first one fails (``"ipopt"``, ``"sqp"`` or None); only if both fail,
        and a retry from a cold start fails too, does the step command a stop.
    transcription : str
        ``"multiple_shooting"`` (states and inputs are unknowns) or ``"single_shooting"`` (inputs only).
    solver_options : dict
        Extra options passed to CasADi's ``nlpsol`` on top of the defaults.
    """

    dt: float = 0.1
    horizon: int = 10
    Q: tuple[float, float, float] = (1.0, 10.0, 10.0)
    R: tuple[float, float] = (0.0, 0.1)
    P: tuple[float, float, float] = (1.0, 10.0, 10.0)
    speed_min: float = -1.0
    speed_max: float = 0.0
    virtual_limit: float = 0.5
    stop_speed: float = 1e-3
    max_steps: int = 1500
    solver: str = "sqp"
    fallback_solver: str | None = "ipopt"
    transcription: str = "multiple_shooting"
    solver_options: dict[str, Any] = field(default_factory=dict, hash=False, compare=False)

    def __post_init__(self) -> None:
        for name in ("dt", "speed_min", "speed_max", "virtual_limit", "stop_speed"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
                raise ValueError(f"nmpc.{name} must be a finite number, got {v!r}")
        if self.dt <= 0:
            raise ValueError(f"nmpc.dt must be > 0 s, got {self.dt:g}")
        for name in ("horizon", "max_steps"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise ValueError(f"nmpc.{name} must be an integer >= 1, got {v!r}")
        object.__setattr__(self, "Q", _diag("nmpc.Q", self.Q, 3, positive=False))
        object.__setattr__(self, "P", _diag("nmpc.P", self.P, 3, positive=False))
        object.__setattr__(self, "R", _diag("nmpc.R", self.R, 2, positive=False))
        if not self.speed_min < 0.0 or self.speed_max > 0.0 or self.speed_min >= self.speed_max:
            raise ValueError(
                f"nmpc speed bounds must satisfy speed_min < 0 and speed_min < speed_max <= 0 m/s (reverse only), "
                f"got [{self.speed_min:g}, {self.speed_max:g}]"
            )
        if not 0.0 < self.virtual_limit < math.pi / 2:
            raise ValueError(f"nmpc.virtual_limit must be in (0, pi/2) rad, got {self.virtual_limit:g}")
        if self.stop_speed <= 0:
            raise ValueError(f"nmpc.stop_speed must be > 0 m/s, got {self.stop_speed:g}")
        if self.solver not in ("ipopt", "sqp"):
            raise ValueError(f"nmpc.solver must be 'ipopt' or 'sqp', got {self.solver!r}")
        if self.fallback_solver not in ("ipopt", "sqp", None):
            raise ValueError(f"nmpc.fallback_solver must be 'ipopt', 'sqp' or none, got {self.fallback_solver!r}")
        if self.transcription not in ("multiple_shooting", "single_shooting"):
            raise ValueError(
                f"nmpc.transcription must be 'multiple_shooting' or 'single_shooting', got {self.transcription!r}"
            )


#: An extra constraint on stage k: ``(x_k, u_k, k) -> (expr, lower, upper)``, CasADi expressions.
PathConstraint = Callable[[Any, Any, int], tuple[Any, Any, Any]]


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

    def __init__(self, vehicle: VehicleTrailer, settings: NMPCSettings | None = None):
        vehicle.require_hitch_offset()
        self.vehicle = vehicle
        self.settings = settings or NMPCSettings()
        self.path_constraints: list[PathConstraint] = []
        s = self.settings
        self._Q = ca.diag(ca.DM(s.Q))
        self._R = ca.diag(ca.DM(s.R))
        self._P = ca.diag(ca.DM(s.P))

    @property
    def horizon(self) -> int:
        return self.settings.horizon

    def discrete_dynamics(self, x: Any, u: Any) -> Any:
        """g(X_k, U_k) = X_k + d_t f(X_k, U_k): the Euler step of Eq. (48)."""
        return x + self.settings.dt * trailer_rhs(self.vehicle, x, u)

    def stage_cost(self, x: Any, u: Any) -> Any:
        """X_k^T Q X_k + U_k^T R U_k, Eq. (49)."""
        return ca.bilin(self._Q, x, x) + ca.bilin(self._R, u, u)

    def terminal_cost(self, x: Any) -> Any:
        """X_N^T P X_N, Eq. (49)."""
        return ca.bilin(self._P, x, x)

    def input_bounds(self, hitch: float) -> tuple[np.ndarray, np.ndarray]:
        """U_min, U_max at the current hitch angle: speed bounds and Eqs. (56)-(57)."""
        low, high = virtual_steer_bounds(self.vehicle, hitch, self.settings.virtual_limit)
        s = self.settings
        return np.array([s.speed_min, low]), np.array([s.speed_max, high])
