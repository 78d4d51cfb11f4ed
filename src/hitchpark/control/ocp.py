"""The trailer-parking optimal control problem, Eqs. (47)-(57): model, cost, constraints.

This module says *what* is optimised. How it becomes a nonlinear program
(:mod:`.transcription`) and which solver solves it (:func:`.nmpc.make_solver`) are chosen
apart, so solvers can be swapped and the problem extended (longer horizons, more
states, obstacle constraints) without touching the others.

Everything here lives in the parking frame (Fig. 5): origin at the goal trailer-axle
position, X along the goal trailer heading, so the parked state is zero.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np

from ..checks import InputError, check_int, check_range
from ..model.inverse import virtual_steer_bounds
from ..model.kinematics import TRAILER_INPUT, TRAILER_STATE, trailer_rhs
from ..model.vehicle import VehicleTrailer

__all__ = ["NMPCSettings", "PathConstraint", "TrailerParkingProblem"]


def _diag(name: str, values: Sequence[float], size: int, positive: bool) -> tuple[float, ...]:
    try:
        items = list(values) if not isinstance(values, str) else None
    except TypeError:
        items = None
    if items is None or len(items) != size:
        raise InputError(f"{name} must be a list of {size} numbers (the diagonal), got {values!r}")
    low_open = positive  # Q, P > 0 as Eq. (49) asks; R may have zeros (Table 4: R = diag(0, 0.1))
    return tuple(check_range(f"{name}[{i}]", v, 0.0, low_open=low_open) for i, v in enumerate(items))


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
        def put(name: str, value: Any) -> None:
            object.__setattr__(self, name, value)

        put("dt", check_range("nmpc.dt", self.dt, 0.0, 1.0, low_open=True, unit="s"))
        put("horizon", check_int("nmpc.horizon", self.horizon, 1, 500))
        put("max_steps", check_int("nmpc.max_steps", self.max_steps, 1, 1_000_000))
        put("Q", _diag("nmpc.Q", self.Q, 3, positive=True))
        put("P", _diag("nmpc.P", self.P, 3, positive=True))
        put("R", _diag("nmpc.R", self.R, 2, positive=False))
        put("speed_min", check_range("nmpc.speed_min", self.speed_min, -10.0, 0.0, high_open=True, unit="m/s"))
        # The stage ends when the optimal speed is zero (Section 4.1): zero must be admissible.
        put("speed_max", check_range("nmpc.speed_max", self.speed_max, 0.0, 0.0, unit="m/s (the stop rule needs it)"))
        lim = check_range("nmpc.virtual_limit", self.virtual_limit, 0.0, math.pi / 2, low_open=True, high_open=True)
        put("virtual_limit", lim)
        put("stop_speed", check_range("nmpc.stop_speed", self.stop_speed, 0.0, 0.1, low_open=True, unit="m/s"))
        if self.solver not in ("ipopt", "sqp"):
            raise InputError(f"nmpc.solver must be 'ipopt' or 'sqp', got {self.solver!r}")
        if self.fallback_solver not in ("ipopt", "sqp", None):
            raise InputError(f"nmpc.fallback_solver must be 'ipopt', 'sqp' or none, got {self.fallback_solver!r}")
        if self.transcription not in ("multiple_shooting", "single_shooting"):
            raise InputError(
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
