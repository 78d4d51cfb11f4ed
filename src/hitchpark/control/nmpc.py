"""The receding-horizon trailer NMPC (Section 4) and its solver back ends.

Each step: move the trailer pose into the parking frame of the goal, bound the
virtual steer by Eqs. (56)-(57) at the current hitch angle, warm-start from the
shifted previous solution, solve, apply only U_0, and map it to the vehicle
through Eqs. (44)-(45). A failed solve or a non-finite answer never reaches the
vehicle: the step commands a stop and says why.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from typing import Any

import casadi as ca
import numpy as np

from ..model.geometry import Pose, to_goal_frame, wrap_angle
from ..model.inverse import front_steer_from_virtual, rear_speed_from_trailer_speed
from ..model.vehicle import VehicleTrailer
from .ocp import NMPCSettings, TrailerParkingProblem
from .transcription import Transcription, make_transcription

__all__ = ["NMPCStep", "Pose", "TrailerNMPC", "make_solver", "to_goal_frame", "wrap_angle"]


def make_solver(transcription: Transcription, settings: NMPCSettings) -> Any:
    """A CasADi ``nlpsol`` for the transcription, quiet, with the solver named in ``settings``."""
    if settings.solver == "ipopt":
        opts: dict[str, Any] = {
            "print_time": False,
            "ipopt.print_level": 0,
            "ipopt.sb": "yes",
            "ipopt.tol": 1e-9,
            "ipopt.max_iter": 300,
            "ipopt.warm_start_init_point": "yes",
            "ipopt.warm_start_bound_push": 1e-9,
            "ipopt.warm_start_mult_bound_push": 1e-9,
            "ipopt.mu_init": 1e-4,
        }
        name = "ipopt"
    else:
        opts = {
            "print_time": False,
            "print_header": False,
            "print_iteration": False,
            "print_status": False,
            "qpsol": "qrqp",
            "qpsol_options": {"print_iter": False, "print_header": False, "print_info": False, "error_on_fail": False},
            "hessian_approximation": "exact",
            "convexify_strategy": "eigen-clip",
            "max_iter": 100,
            # Primal 1e-9 is below what the Euler equalities (terms ~10) reach in double precision: the SQP
            # then stalls at the optimum with Search_Direction_Becomes_Too_Small. 1e-8 / 1e-8 converge.
            "tol_pr": 1e-8,
            "tol_du": 1e-8,
            "error_on_fail": False,
        }
        name = "sqpmethod"
    opts.update(settings.solver_options)
    return ca.nlpsol("trailer_nmpc", name, transcription.nlp, opts)


@dataclass(frozen=True)
class NMPCStep:
    """What one NMPC step decided.

    ``trailer_speed``/``virtual_steer`` are U_0 (the virtual inputs), ``rear_speed``/
    ``front_steer`` the vehicle command from Eqs. (44)-(45). ``ok`` is False when the
    solver failed or gave a non-finite answer; the command is then a stop
    (zero speed) and ``status`` says why. ``stop`` is True when U_0's speed is zero
    (|V_T| < stop_speed): the stage is over.
    """

    trailer_speed: float
    virtual_steer: float
    rear_speed: float
    front_steer: float
    cost: float
    solve_ms: float
    ok: bool
    stop: bool
    status: str
    predicted_states: np.ndarray
    predicted_inputs: np.ndarray


class TrailerNMPC:
    """Receding-horizon controller for the trailer.

    Parameters
    ----------
    vehicle : VehicleTrailer
        The vehicle-trailer combination (needs L_H > 0).
    settings : NMPCSettings
        Horizon, weights, bounds, solver (defaults: Table 4).
    goal : Pose
        Goal trailer-axle pose in the world frame.
    """

    def __init__(self, vehicle: VehicleTrailer, settings: NMPCSettings | None = None, goal: Pose | None = None):
        self.problem = TrailerParkingProblem(vehicle, settings)
        self.vehicle = vehicle
        self.settings = self.problem.settings
        self.goal = goal or Pose()
        self.transcription = make_transcription(self.problem)
        self.solver = make_solver(self.transcription, self.settings)
        fallback = self.settings.fallback_solver
        self.fallback = (
            make_solver(self.transcription, replace(self.settings, solver=fallback, solver_options={}))
            if fallback and fallback != self.settings.solver
            else None
        )
        self._last_inputs: np.ndarray | None = None
        self._last_states: np.ndarray | None = None
        self._last_steer = 0.0

    def reset(self, front_steer: float = 0.0) -> None:
        """Forget the warm start (call at the start of each reverse stage)."""
        self._last_inputs = None
        self._last_states = None
        self._last_steer = float(front_steer)

    def _initial_guess(self, x0: np.ndarray, u_min: np.ndarray, u_max: np.ndarray) -> np.ndarray:
        if self._last_inputs is None:
            # Cold start: reverse straight at half the speed bound; u = 0 would be a stationary point of the speed.
            inputs = np.tile([0.5 * self.settings.speed_min, 0.0], (self.problem.horizon, 1))
            states = None
        else:
            inputs = np.vstack([self._last_inputs[1:], self._last_inputs[-1:]])  # shifted previous solution
            assert self._last_states is not None
            states = np.vstack([self._last_states[1:], self._last_states[-1:]])
        inputs = np.clip(inputs, u_min, u_max)
        return self.transcription.guess(x0, inputs, states)

    def _solve(
        self, solver: Any, x0: np.ndarray, w0: np.ndarray, lbx: np.ndarray, ubx: np.ndarray
    ) -> tuple[bool, str, np.ndarray, float]:
        try:
            sol = solver(x0=w0, p=x0, lbx=lbx, ubx=ubx, lbg=self.transcription.lbg, ubg=self.transcription.ubg)
            stats = solver.stats()
            ok, status = bool(stats.get("success", False)), str(stats.get("return_status", "unknown"))
            w, cost = np.asarray(sol["x"]).ravel(), float(sol["f"])
        except RuntimeError as exc:  # CasADi raises on evaluation errors (e.g. NaN in a function)
            return False, f"solver error: {exc}".splitlines()[0], np.full(len(w0), np.nan), math.nan
        if ok and not (np.all(np.isfinite(w)) and math.isfinite(cost)):
            ok, status = False, "non-finite solution"
        return ok, status, w, cost

    def step(self, x_trailer: float, y_trailer: float, yaw_trailer: float, hitch: float) -> NMPCStep:
        """Solve the OCP from the current configuration and return U_0 and the vehicle command."""
        refuse = ""
        if not all(map(math.isfinite, (x_trailer, y_trailer, yaw_trailer, hitch))):
            refuse = "non-finite state"
        elif abs(hitch) > self.vehicle.max_hitch:
            refuse = "hitch angle beyond max_hitch"  # Eqs. (44)-(45) would ask for nonsense (even driving forward)
        if refuse:
            empty = np.full((self.problem.horizon + 1, self.problem.n_x), np.nan)
            return self._stop(refuse, math.nan, 0.0, empty, empty[:-1, : self.problem.n_u])
        x0 = np.array(to_goal_frame(self.goal, x_trailer, y_trailer, yaw_trailer), dtype=float)
        u_min, u_max = self.problem.input_bounds(hitch)  # Eqs. (56)-(57) at the current hitch angle
        lbx, ubx = self.transcription.bounds(u_min, u_max)
        t0 = time.perf_counter()
        warm = self._initial_guess(x0, u_min, u_max)
        ok, status, w, cost = self._solve(self.solver, x0, warm, lbx, ubx)
        if not ok and self.fallback is not None:
            # The fast primary solver can stall where the interior-point fallback does not.
            ok, status, w, cost = self._solve(self.fallback, x0, warm, lbx, ubx)
        if not ok and self._last_inputs is not None:
            # A warm start can mislead the solver; one last try from the cold guess before giving up.
            self._last_inputs = self._last_states = None
            cold = self._initial_guess(x0, u_min, u_max)
            ok, status, w, cost = self._solve(self.fallback or self.solver, x0, cold, lbx, ubx)
        solve_ms = 1e3 * (time.perf_counter() - t0)
        states, inputs = self.transcription.unpack(w, x0)
        if not ok:
            return self._stop(status, cost, solve_ms, states, inputs)
        v_t, d_t = inputs[0]
        d_t = float(np.clip(d_t, u_min[1], u_max[1]))  # solver tolerance must not leak past Eq. (57)
        v_t = float(np.clip(v_t, u_min[0], u_max[0]))
        front = float(front_steer_from_virtual(self.vehicle, hitch, d_t))  # Eq. (45)
        rear = float(rear_speed_from_trailer_speed(self.vehicle, hitch, d_t, v_t))  # Eq. (44)
        front = float(np.clip(front, -self.vehicle.max_steer, self.vehicle.max_steer))
        if not (math.isfinite(front) and math.isfinite(rear)):
            return self._stop("non-finite vehicle command", cost, solve_ms, states, inputs)
        stop = abs(v_t) < self.settings.stop_speed
        self._last_inputs, self._last_states = inputs, states
        if stop:
            rear = 0.0
        self._last_steer = front
        return NMPCStep(v_t, d_t, rear, front, cost, solve_ms, True, stop, status, states, inputs)

    def _stop(self, status: str, cost: float, solve_ms: float, states: np.ndarray, inputs: np.ndarray) -> NMPCStep:
        self._last_inputs = self._last_states = None
        return NMPCStep(0.0, 0.0, 0.0, self._last_steer, cost, solve_ms, False, True, status, states, inputs)
