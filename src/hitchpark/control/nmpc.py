"""Receding-horizon controllers: the paper's trailer NMPC (Section 4) and the full-model NMPC.

Each step: move the measured pose into the parking frame of the goal (a parameter of the
step, so one controller serves many goals and starts), warm-start from the shifted previous
solution, solve, apply only the first move. A failed solve or a non-finite answer never
reaches the vehicle: the step commands a stop and says why. Solvers come from the
registry of :mod:`.solvers`: a primary, a fallback, and a last try from a cold start.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from ..checks import InputError, check_instance, check_range
from ..model.inverse import front_steer_from_virtual, rear_speed_from_trailer_speed, virtual_steer_from_front
from ..model.kinematics import trailer_speed_from_rear_speed
from ..model.plant import Command, Measurement
from ..model.scene import Scene
from ..model.state import Pose, State, check_goal, to_goal_frame
from ..model.vehicle import VehicleTrailer, check_vehicle
from .clearance import ClearanceConstraints
from .full_ocp import SPEED, STEER, FullParkingProblem
from .ocp import OCP, NMPCSettings, TrailerParkingProblem
from .solvers import ROUTES, casadi_reason, make_solver
from .transcription import make_transcription

__all__ = ["FullNMPC", "NLPProblem", "NMPCStep", "TrailerNMPC", "make_nmpc"]


@dataclass(frozen=True)
class NLPProblem:
    """One NMPC solve as the controller posed it to its primary solver: replayable through any route.

    ``p`` is the initial state and the OCP's step parameters (the scene's lines), ``w0`` the warm start,
    the rest the bounds of the decision vector and of the constraints, all in the transcription's layout.
    """

    p: np.ndarray
    w0: np.ndarray
    lbx: np.ndarray
    ubx: np.ndarray
    lbg: np.ndarray
    ubg: np.ndarray

    def inputs(self) -> dict[str, np.ndarray]:
        """The keyword arguments of a CasADi ``nlpsol`` call."""
        return {"x0": self.w0, "p": self.p, "lbx": self.lbx, "ubx": self.ubx, "lbg": self.lbg, "ubg": self.ubg}


@dataclass(frozen=True)
class NMPCStep:
    """What one NMPC step decided.

    ``rear_speed``/``front_steer`` are the vehicle command; ``trailer_speed``/``virtual_steer``
    the same motion in the trailer's virtual inputs (the paper's U_0, or Eqs. (18) and (56) of
    the command for the full model). ``ok`` is False when the solver failed or gave a
    non-finite answer; the command is then a stop (zero speed, steer held) and ``status``
    says why. ``stop`` is True when the optimal speed is zero: the stage is over.
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

    @property
    def command(self) -> Command:
        return Command(self.rear_speed, self.front_steer)


def _shifted(rows: np.ndarray, part: float) -> np.ndarray:
    """``rows`` (one per step) advanced by ``part`` of a step (0 < part <= 1), linearly, the last row held."""
    ahead = np.vstack([rows[1:], rows[-1:]])
    return ahead if part >= 1.0 else (1.0 - part) * rows + part * ahead


def _settings(vehicle: Any, settings: Any, kind: str) -> NMPCSettings:
    """Check a controller's arguments; ``settings`` None: the ``kind``'s defaults."""
    check_vehicle(vehicle)
    settings = NMPCSettings(kind=kind) if settings is None else settings
    check_instance("settings", settings, NMPCSettings, "hitchpark.control.NMPCSettings(...)")
    if settings.kind != kind:
        raise InputError(f"this controller needs nmpc.kind {kind!r}, got {settings.kind!r}")
    return settings


@dataclass
class _Program:
    """An OCP made ready to solve: its transcription, the primary and fallback solvers."""

    problem: OCP
    transcription: Any
    solver: Any
    fallback: Any
    equality: list[bool]
    general: Any = None  # a route for problems that relax an equality (built when first needed)


def _program(problem: OCP) -> _Program:
    s = problem.settings
    transcription = make_transcription(problem)
    equality = list(transcription.lbg == transcription.ubg)
    assert s.solver is not None  # resolved per kind by NMPCSettings
    try:
        solver = make_solver(s.solver, transcription.nlp, equality, s.solver_options, jit=bool(s.jit))
    except RuntimeError as exc:  # CasADi refuses an unknown or ill-typed option
        raise InputError(f"nmpc.solver_options are not accepted by {s.solver}: {casadi_reason(exc)}") from None
    fallback = s.fallback_solver
    backup = make_solver(fallback, transcription.nlp, equality) if fallback and fallback != s.solver else None
    return _Program(problem, transcription, solver, backup, equality)


class _RecedingHorizon:
    """The solve machinery both NMPCs share: transcription, solver cascade, warm start."""

    def __init__(self, vehicle: VehicleTrailer, problem: OCP):
        vehicle.require_hitch_offset()
        self.vehicle = vehicle
        self.settings = problem.settings
        self._program = _program(problem)
        self._last_inputs: np.ndarray | None = None
        self._last_states: np.ndarray | None = None
        self._last_steer = 0.0
        #: Set to a list to record every problem posed to the primary solver (``hitchpark bench``).
        self.recorder: list[NLPProblem] | None = None

    @property
    def problem(self) -> OCP:
        """The OCP solved now."""
        return self._program.problem

    @property
    def transcription(self) -> Any:
        return self._program.transcription

    @property
    def solver(self) -> Any:
        """The primary solver of the OCP solved now."""
        return self._program.solver

    @solver.setter
    def solver(self, solver: Any) -> None:
        self._program.solver = solver

    @property
    def fallback(self) -> Any:
        """The fallback solver of the OCP solved now (None: none)."""
        return self._program.fallback

    @fallback.setter
    def fallback(self, solver: Any) -> None:
        self._program.fallback = solver

    def _step_parameters(self, warm: np.ndarray, x0: np.ndarray) -> np.ndarray:
        """The OCP's parameters of each prediction step, from the warm start (none unless an OCP has some)."""
        return np.zeros(0)

    def _cold_start(
        self, x0: np.ndarray, guess: np.ndarray, u_min: np.ndarray, u_max: np.ndarray, free: Any
    ) -> np.ndarray:
        """The warm start when there is no previous plan: ``guess`` (the cold guess) unless an OCP does better."""
        return guess

    def reset(self, front_steer: float = 0.0) -> None:
        """Forget the warm start (call at the start of each reverse stage)."""
        self._last_inputs = None
        self._last_states = None
        self._last_steer = float(front_steer)

    def _cold_inputs(self) -> np.ndarray:
        raise NotImplementedError

    def _initial_guess(self, x0: np.ndarray, u_min: np.ndarray, u_max: np.ndarray) -> np.ndarray:
        if self._last_inputs is None:
            inputs, states = self._cold_inputs(), None
        else:
            # The previous solution moved on by one control sample: a whole prediction step when they are
            # equal, else the fraction dt / prediction_dt of one (interpolated), the last step repeated.
            assert self._last_states is not None and self.settings.prediction_dt is not None
            part = self.settings.dt / self.settings.prediction_dt
            inputs = _shifted(self._last_inputs, part)
            states = _shifted(self._last_states, part)
        inputs = np.clip(inputs, u_min, u_max)
        return self.transcription.guess(x0, inputs, states)

    def _solve(
        self, solver: Any, p: np.ndarray, w0: np.ndarray, bounds: tuple[np.ndarray, ...]
    ) -> tuple[bool, str, np.ndarray, float]:
        lbx, ubx, lbg, ubg = bounds
        try:
            sol = solver(x0=w0, p=p, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg)
            stats = solver.stats()
            ok, status = bool(stats.get("success", False)), str(stats.get("return_status", "unknown"))
            w, cost = np.asarray(sol["x"]).ravel(), float(sol["f"])
        except RuntimeError as exc:  # CasADi raises on evaluation errors (e.g. NaN in a function)
            return False, f"solver error: {exc}".splitlines()[0], np.full(len(w0), np.nan), math.nan
        if ok and not (np.all(np.isfinite(w)) and math.isfinite(cost)):
            ok, status = False, "non-finite solution"
        return ok, status, w, cost

    def _general_solver(self, program: _Program | None = None) -> Any:
        """The primary route, or a general one if the primary needs every equality of the transcription kept.

        A stage's free-steer problem (:meth:`FullNMPC.initial_steer`, once per stage, standing still) frees
        the equality X_0[steer] = p[steer]; a structure-exploiting route such as fatrop cannot take that.
        """
        assert self.settings.solver is not None
        program = program or self._program
        if not ROUTES[self.settings.solver].structured:
            return program.solver
        if program.general is None:
            general = self.settings.fallback_solver
            if general is None or ROUTES[general].structured:
                general = "ipopt"
            program.general = program.fallback if general == self.settings.fallback_solver else None
            if program.general is None:
                program.general = make_solver(general, program.transcription.nlp, program.equality)
        return program.general

    def _fallback_structured(self) -> bool:
        fallback = self.settings.fallback_solver
        return fallback is not None and ROUTES[fallback].structured

    def _solve_cascade(
        self,
        x0: np.ndarray,
        u_min: np.ndarray,
        u_max: np.ndarray,
        free: dict[int, tuple[float, float]] | None = None,
    ) -> tuple[bool, str, np.ndarray, np.ndarray, float, float]:
        """Primary solver, then the fallback, then a cold start; returns ok, status, states, inputs, cost, ms.

        ``free``: components of X_0 freed within bounds (:meth:`.Transcription.bounds`); such a problem
        relaxes an equality of the transcription (see :meth:`_general_solver`).
        """
        t0 = time.perf_counter()
        relaxed = bool(free)
        bounds = self.transcription.bounds(u_min, u_max, free)
        cold = self._last_inputs is None
        warm = self._initial_guess(x0, u_min, u_max)
        if cold:
            warm = self._cold_start(x0, warm, u_min, u_max, free)
        p = np.concatenate([x0, self._step_parameters(warm, x0)])
        primary = self._general_solver() if relaxed else self.solver
        if self.recorder is not None and primary is self.solver:
            self.recorder.append(NLPProblem(*(np.array(a, dtype=float) for a in (p, warm, *bounds))))
        ok, status, w, cost = self._solve(primary, p, warm, bounds)
        # The fast primary solver can stall where the interior-point fallback does not (a structured
        # fallback cannot take a relaxed problem; the same solver again would answer the same).
        fallback = self.fallback
        if fallback is primary or (relaxed and fallback is not None and self._fallback_structured()):
            fallback = None
        if not ok and fallback is not None:
            ok, status, w, cost = self._solve(fallback, p, warm, bounds)
        if not ok and not cold:
            # A warm start can mislead the solver; one last try from the cold guess before giving up.
            self._last_inputs = self._last_states = None
            guess = self._cold_start(x0, self._initial_guess(x0, u_min, u_max), u_min, u_max, free)
            p = np.concatenate([x0, self._step_parameters(guess, x0)])
            ok, status, w, cost = self._solve(fallback or primary, p, guess, bounds)
        solve_ms = 1e3 * (time.perf_counter() - t0)
        states, inputs = self.transcription.unpack(w, x0)
        return ok, status, states, inputs, cost, solve_ms

    def _stop(self, status: str, cost: float, solve_ms: float, states: np.ndarray, inputs: np.ndarray) -> NMPCStep:
        self._last_inputs = self._last_states = None
        return NMPCStep(0.0, 0.0, 0.0, self._last_steer, cost, solve_ms, False, True, status, states, inputs)

    def _refuse(self, state: Sequence[float] | np.ndarray, hitch: float) -> NMPCStep | None:
        refuse = ""
        if not all(map(math.isfinite, state)):
            refuse = "non-finite state"
        elif abs(hitch) > self.vehicle.max_hitch:
            refuse = "hitch angle beyond max_hitch"  # the model would ask for nonsense (even driving forward)
        if not refuse:
            return None
        empty = np.full((self.problem.horizon + 1, self.problem.n_x), np.nan)
        return self._stop(refuse, math.nan, 0.0, empty, empty[:-1, : self.problem.n_u])

    def initial_steer(self, measurement: Measurement, goal: Pose) -> float | None:
        """The steer this controller would like to start a stage with (None: no preference)."""
        return None


class TrailerNMPC(_RecedingHorizon):
    """The paper's receding-horizon controller for the trailer alone (Eqs. 47-57).

    Each step bounds the virtual steer by Eqs. (56)-(57) at the current hitch angle and maps
    U_0 to the vehicle through Eqs. (44)-(45). It knows no actuator dynamics and no delay.
    """

    def __init__(self, vehicle: VehicleTrailer, settings: NMPCSettings | None = None):
        settings = _settings(vehicle, settings, "paper")
        super().__init__(vehicle, TrailerParkingProblem(vehicle, settings))

    def _cold_inputs(self) -> np.ndarray:
        # Reverse straight at half the speed bound; u = 0 would be a stationary point of the speed.
        return np.tile([0.5 * self.settings.speed_min, 0.0], (self.problem.horizon, 1))

    def act(self, measurement: Measurement, goal: Pose, in_flight: Sequence[Command] = ()) -> NMPCStep:
        """One step from a measurement (the paper's controller ignores the actuators and the delay)."""
        s = measurement.state
        return self.step(s.x, s.y, s.yaw, s.hitch, goal)

    def step(
        self, x_trailer: float, y_trailer: float, yaw_trailer: float, hitch: float, goal: Pose | None = None
    ) -> NMPCStep:
        """Solve the OCP from the current configuration and return U_0 and the vehicle command."""
        State(x_trailer, y_trailer, yaw_trailer, hitch)  # finite and in range, or an InputError
        goal = check_goal(goal)
        refused = self._refuse((x_trailer, y_trailer, yaw_trailer, hitch), hitch)
        if refused is not None:
            return refused
        x0 = np.array(to_goal_frame(goal, x_trailer, y_trailer, yaw_trailer), dtype=float)
        assert isinstance(self.problem, TrailerParkingProblem)
        u_min, u_max = self.problem.input_bounds(hitch)  # Eqs. (56)-(57) at the current hitch angle
        ok, status, states, inputs, cost, solve_ms = self._solve_cascade(x0, u_min, u_max)
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


class FullNMPC(_RecedingHorizon):
    """The full-model NMPC (:mod:`.full_ocp`): limits on the whole horizon, the command delay predicted out.

    ``act`` takes the measurement (pose, hitch, actual steer and speed) and the commands
    issued but not yet acted on (the known delay), predicts the state at which the new
    command will act, solves, and commands the planned steer and speed one sample ahead.
    """

    def __init__(self, vehicle: VehicleTrailer, settings: NMPCSettings | None = None):
        settings = _settings(vehicle, settings, "full")
        problem = FullParkingProblem(vehicle, settings)
        super().__init__(vehicle, problem)
        self._open = self._program  # the OCP of open space
        self._among: _Program | None = None  # the obstacle OCP, built when first needed
        self._goal = Pose()
        x, u = ca.SX.sym("x", 6), ca.SX.sym("u", 2)
        # One controller sample of the model: for the commands in flight and for the first move of a plan.
        self._model_step = ca.Function("model_step", [x, u], [problem.discrete_dynamics(x, u, settings.dt)])

    def keep_clear(self, scene: Scene, clearance_m: float) -> None:
        """Keep the bodies ``clearance_m`` from ``scene`` over the horizon from now on (the obstacle OCP, with
        ``nmpc.obstacle_planes`` lines per body and step, :mod:`.clearance`); an empty scene, or no planes,
        solves the OCP of open space."""
        check_instance("scene", scene, Scene, "hitchpark.model.Scene(obstacles, area)")
        check_range("clearance_m", clearance_m, 0.0, 10.0, unit="m")
        self.reset(self._last_steer)
        if scene.is_empty or self.settings.obstacle_planes == 0:
            self._program = self._open
            return
        if self._among is None:
            lines = ClearanceConstraints(self.vehicle, self.settings.obstacle_planes)
            self._among = _program(FullParkingProblem(self.vehicle, self.settings, lines))
        assert isinstance(self._among.problem, FullParkingProblem) and self._among.problem.clearance is not None
        self._among.problem.clearance.use(scene, clearance_m)
        self._program = self._among

    def _step_parameters(self, warm: np.ndarray, x0: np.ndarray) -> np.ndarray:
        assert isinstance(self.problem, FullParkingProblem)
        lines = self.problem.clearance
        if lines is None:
            return np.zeros(0)
        states, _ = self.transcription.unpack(warm, x0)
        return lines.parameters(self._goal, np.vstack([x0[None, :], states[1:]]))

    def _cold_start(
        self, x0: np.ndarray, guess: np.ndarray, u_min: np.ndarray, u_max: np.ndarray, free: Any
    ) -> np.ndarray:
        """Among obstacles, a plan to draw the scene's lines around when there is no previous one.

        Lines drawn around the cold guess (reverse with the steer held) can shut out every plan: a line
        at a corner the guess passes too close leaves no room where the plan will be. So the plan of
        open space comes first (clear wherever the car can be clear; it meets every line drawn around
        it when it is). Where it passes too close, the obstacle OCP is solved around it, and while that
        fails, again around the general solver's last iterate (up to :data:`COLD_ROUNDS` rounds): once a
        round succeeds, its plan meets the lines drawn around it, and the warm-started steps that follow
        keep it so.
        """
        if self._program is self._open:
            return guess
        bounds = self._open.transcription.bounds(u_min, u_max, free)
        solver = self._general_solver(self._open) if free else self._open.solver
        ok, _, w, _ = self._solve(solver, x0, guess, bounds)
        if not ok:
            w = guess
        bounds = self.transcription.bounds(u_min, u_max, free)
        general = self._general_solver()
        for _ in range(COLD_ROUNDS):
            p = np.concatenate([x0, self._step_parameters(w, x0)])
            ok, _, iterate, _ = self._solve(general, p, w, bounds)
            if not np.all(np.isfinite(iterate)):
                break
            w = iterate
            if ok:
                break
        return w

    def _cold_inputs(self) -> np.ndarray:
        # Accelerate in reverse, straight: from standing still a zero input sees no gain in moving.
        n = self.problem.horizon
        assert self.settings.prediction_dt is not None
        ramp = max(
            1, round(0.5 * abs(self.settings.speed_min) / (self.vehicle.max_accel * self.settings.prediction_dt))
        )
        accel = np.where(np.arange(n) < ramp, -self.vehicle.max_accel, 0.0)
        return np.column_stack([np.zeros(n), accel])

    def _state(self, measurement: Measurement, goal: Pose, in_flight: Sequence[Command]) -> np.ndarray:
        """Measured state in the parking frame, predicted over the commands still in flight."""
        s = measurement.state
        x = np.array(
            [*to_goal_frame(goal, s.x, s.y, s.yaw), s.hitch, measurement.front_steer, measurement.rear_speed],
            dtype=float,
        )
        v, dt = self.vehicle, self.settings.dt
        for cmd in in_flight:
            rate = np.clip((cmd.front_steer - x[STEER]) / dt, -v.max_steer_rate, v.max_steer_rate)
            accel = np.clip((cmd.rear_speed - x[SPEED]) / dt, -v.max_accel, v.max_accel)
            x = np.asarray(self._model_step(x, [rate, accel])).ravel()
        return x

    def act(self, measurement: Measurement, goal: Pose, in_flight: Sequence[Command] = ()) -> NMPCStep:
        check_instance("measurement", measurement, Measurement)
        self._goal = check_goal(goal)
        x0 = self._state(measurement, self._goal, in_flight)
        refused = self._refuse(x0, x0[3])
        if refused is not None:
            return refused
        return self._plan(x0)

    def initial_steer(self, measurement: Measurement, goal: Pose) -> float | None:
        """The steer the plan would start with if the wheels could be set freely, chosen standing still."""
        self._goal = check_goal(goal)
        x0 = self._state(measurement, self._goal, ())
        if self._refuse(x0, x0[3]) is not None:
            return None
        step = self._plan(x0, free_steer=True)
        self.reset(measurement.front_steer)
        if not step.ok:
            return None
        limit = self.vehicle.max_steer  # the solver's tolerance must not leak past the limit
        return float(np.clip(step.predicted_states[0, STEER], -limit, limit))

    def _plan(self, x0: np.ndarray, free_steer: bool = False) -> NMPCStep:
        assert isinstance(self.problem, FullParkingProblem)
        v = self.vehicle
        u_min, u_max = self.problem.input_bounds()
        free = {STEER: (-v.max_steer, v.max_steer)} if free_steer else None
        ok, status, states, inputs, cost, solve_ms = self._solve_cascade(x0, u_min, u_max, free)
        if not ok:
            return self._stop(status, cost, solve_ms, states, inputs)
        first = x0 + self.settings.dt * np.concatenate([np.zeros(4), inputs[0]])  # the rates held for one sample
        steer = float(np.clip(first[STEER], -v.max_steer, v.max_steer))
        speed = float(np.clip(first[SPEED], self.settings.speed_min, self.settings.speed_max))
        if not (math.isfinite(steer) and math.isfinite(speed)):
            return self._stop("non-finite vehicle command", cost, solve_ms, states, inputs)
        stop = abs(speed) < self.settings.stop_speed and abs(x0[SPEED]) < self.settings.stop_speed
        self._last_inputs, self._last_states = inputs, states
        if stop:
            speed = 0.0
        self._last_steer = steer
        hitch = float(x0[3])
        trailer_speed = float(trailer_speed_from_rear_speed(v, hitch, speed, steer))  # Eq. (18)
        virtual = float(virtual_steer_from_front(v, hitch, steer))  # Eq. (56)
        return NMPCStep(trailer_speed, virtual, speed, steer, cost, solve_ms, True, stop, status, states, inputs)


#: Rounds of the obstacle OCP from a cold start, each around the last one's iterate (:meth:`FullNMPC._cold_start`).
COLD_ROUNDS = 3

#: The NMPC of each ``NMPCSettings.kind``.
NMPC_CLASSES: dict[str, type[TrailerNMPC] | type[FullNMPC]] = {"paper": TrailerNMPC, "full": FullNMPC}


def make_nmpc(vehicle: VehicleTrailer, settings: NMPCSettings) -> TrailerNMPC | FullNMPC:
    """The reverse controller that ``settings.kind`` names."""
    return NMPC_CLASSES[settings.kind](vehicle, settings)
