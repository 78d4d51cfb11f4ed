"""Receding-horizon controllers: the paper's trailer NMPC (Section 4) and the full-model NMPC.

Each step: move the measured pose into the parking frame of the goal (a parameter of the
step, so one controller serves many goals and starts), warm-start from the shifted previous
solution, solve, apply only the first move. A failed solve or a non-finite answer never
reaches the vehicle: the step commands a stop and says why. Solvers come from the
registry of :mod:`hitchpark.solvers`: a primary, a fallback, and a last try from a cold start.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import casadi as ca
import numpy as np

from ..checks import InputError, check_instance, check_range
from ..model.inverse import front_steer_from_virtual, rear_speed_from_trailer_speed, virtual_steer_from_front
from ..model.kinematics import trailer_speed_from_rear_speed
from ..model.plant import Command, Measurement
from ..model.scene import Scene
from ..model.state import Pose, State, check_goal, clamp, to_goal_frame
from ..model.vehicle import VehicleTrailer
from ..ocp.full import SPEED, STEER, FullParkingProblem
from ..ocp.obstacles import ClearanceConstraints
from ..ocp.reference import PathReference
from ..ocp.settings import NMPCSettings
from ..ocp.trailer import TrailerParkingProblem
from .receding import NLPProblem, NMPCStep, Program, RecedingHorizon, build_program, checked_settings
from .step import ControlStep

__all__ = ["FullNMPC", "NLPProblem", "NMPCStep", "TrailerNMPC", "make_nmpc"]


class TrailerNMPC(RecedingHorizon):
    """The paper's receding-horizon controller for the trailer alone (Eqs. 47-57).

    Each step bounds the virtual steer by Eqs. (56)-(57) at the current hitch angle and maps
    U_0 to the vehicle through Eqs. (44)-(45). It knows no actuator dynamics and no delay.
    """

    def __init__(self, vehicle: VehicleTrailer, settings: NMPCSettings | None = None):
        settings = checked_settings(vehicle, settings, "paper")
        super().__init__(vehicle, TrailerParkingProblem(vehicle, settings))

    def _cold_inputs(self) -> np.ndarray:
        # Reverse straight at half the speed bound; u = 0 would be a stationary point of the speed.
        return np.tile([0.5 * self.settings.speed_min, 0.0], (self.problem.horizon, 1))

    def act(self, measurement: Measurement, goal: Pose, in_flight: Sequence[Command] = ()) -> ControlStep:
        """One step from a measurement (the paper's controller ignores the actuators and the delay)."""
        s = measurement.state
        return self.step(s.x, s.y, s.yaw, s.hitch, goal)

    def step(
        self, x_trailer: float, y_trailer: float, yaw_trailer: float, hitch: float, goal: Pose | None = None
    ) -> ControlStep:
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
        d_t = clamp(d_t, u_min[1], u_max[1])  # solver tolerance must not leak past Eq. (57)
        v_t = clamp(v_t, u_min[0], u_max[0])
        front = float(front_steer_from_virtual(self.vehicle, hitch, d_t))  # Eq. (45)
        rear = float(rear_speed_from_trailer_speed(self.vehicle, hitch, d_t, v_t))  # Eq. (44)
        front = clamp(front, -self.vehicle.max_steer, self.vehicle.max_steer)
        if not (math.isfinite(front) and math.isfinite(rear)):
            return self._stop("non-finite vehicle command", cost, solve_ms, states, inputs)
        stop = abs(v_t) < self.settings.stop_speed
        self._last_inputs, self._last_states = inputs, states
        if stop:
            rear = 0.0
        self._last_steer = front
        return ControlStep(
            trailer_speed=v_t,
            virtual_steer=d_t,
            rear_speed=rear,
            front_steer=front,
            ok=True,
            stop=stop,
            status=status,
            cost=cost,
            solve_ms=solve_ms,
            predicted_states=states,
            predicted_inputs=inputs,
        )


class FullNMPC(RecedingHorizon):
    """The full-model NMPC (:mod:`hitchpark.ocp.full`): limits on the whole horizon, the command delay predicted out.

    ``act`` takes the measurement (pose, hitch, actual steer and speed) and the commands
    issued but not yet acted on (the known delay), predicts the state at which the new
    command will act, solves, and commands the planned steer and speed one sample ahead.
    It parks at the goal, or tracks a planned path to it (:meth:`follow`, the tracking OCP),
    and among obstacles keeps clear of them (:meth:`keep_clear`, the obstacle OCP): one OCP
    per combination, each built when first needed.
    """

    def __init__(self, vehicle: VehicleTrailer, settings: NMPCSettings | None = None):
        settings = checked_settings(vehicle, settings, "full")
        problem = FullParkingProblem(vehicle, settings)
        super().__init__(vehicle, problem)
        # The OCPs by (tracking a reference, keeping clear of a scene), each built when first needed.
        self._programs: dict[tuple[bool, bool], Program] = {(False, False): self._program}
        self._scene, self._clearance_m = Scene(), 0.0
        self._base_clearance_m = 0.0
        self._reference: PathReference | None = None
        self._references = np.zeros((0, 6))  # the reference of each prediction step, this step
        self._first_now = self.prediction_step  # this sample's first prediction step [s]
        self._goal = Pose()
        x, u = ca.SX.sym("x", 6), ca.SX.sym("u", 2)
        # One controller sample of the model: for the commands in flight and for the first move of a plan.
        self._model_step = ca.Function("model_step", [x, u], [problem.discrete_dynamics(x, u, settings.dt)])

    @property
    def reference(self) -> PathReference | None:
        """The path tracked now (None: park at the goal)."""
        return self._reference

    def keep_clear(self, scene: Scene, clearance_m: float) -> None:
        """Keep the bodies ``clearance_m`` from ``scene`` over the horizon from now on (the obstacle OCP, with
        ``nmpc.obstacle_planes`` lines per body and step, :mod:`hitchpark.ocp.obstacles`); an empty scene, or no planes,
        solves the OCP of open space."""
        check_instance("scene", scene, Scene, "hitchpark.model.Scene(obstacles, area)")
        check_range("clearance_m", clearance_m, 0.0, 10.0, unit="m")
        self.reset(self._last_steer)
        self._scene, self._clearance_m = scene, float(clearance_m)
        self._base_clearance_m = self._clearance_m
        # Every OCP this scene may need, and the general route of its free-steer problems, built now rather
        # than in the first tick of a stage (``hitchpark realtime``).
        lines = not scene.is_empty and self.settings.obstacle_planes > 0
        for tracking in (False, True):
            for with_lines in {False, lines}:
                program = self._program_for(tracking, with_lines)
                self._general_solver(program)
                self._relaxed_solver(program)
        self._program = self._program_for(self._reference is not None)

    @property
    def clearance_m(self) -> float:
        """How far [m] the predicted bodies keep from the scene now (:meth:`keep_clear`, :meth:`ease_clearance`)."""
        return self._clearance_m

    def ease_clearance(self, clearance_m: float) -> None:
        """From now on keep the bodies ``clearance_m`` from the scene where that is less than :meth:`keep_clear`
        asked (what it asked otherwise): for a stage that begins nearer than that."""
        self.hold_clearance(min(self._base_clearance_m, float(clearance_m)))

    def hold_clearance(self, clearance_m: float) -> None:
        """From now on keep the bodies ``clearance_m`` from the scene, more than :meth:`keep_clear` asked or less:
        for a stage whose guard allows for the estimate's doubt (:class:`~hitchpark.maneuver.stages.GuardedStage`),
        what that allowance takes from the estimate's clearance on top of what the guard keeps."""
        check_range("clearance_m", clearance_m, 0.0, 10.0, unit="m")
        self._clearance_m = float(clearance_m)
        self._program = self._program_for(self._reference is not None)

    def follow(self, reference: PathReference | None) -> None:
        """Track ``reference`` to the goal from now on (the tracking OCP); None: park at the goal."""
        if reference is not None:
            check_instance("reference", reference, PathReference, "hitchpark.control.PathReference(...)")
            if reference.horizon != self.problem.horizon:
                raise InputError(
                    f"the reference has {reference.horizon} steps; the NMPC's horizon is {self.problem.horizon}"
                )
            reference.reset()
        self.reset(self._last_steer)
        self._reference = reference
        self._program = self._program_for(reference is not None)

    def _program_for(self, tracking: bool, lines: bool | None = None) -> Program:
        """The OCP tracking or not, with the scene's lines (``lines`` None: if the scene has any)."""
        if lines is None:
            lines = not self._scene.is_empty and self.settings.obstacle_planes > 0
        key = (tracking, lines)
        if key not in self._programs:
            clearance = ClearanceConstraints(self.vehicle, self.settings.obstacle_planes) if lines else None
            self._programs[key] = build_program(FullParkingProblem(self.vehicle, self.settings, clearance, tracking))
        program = self._programs[key]
        assert isinstance(program.problem, FullParkingProblem)
        if program.problem.clearance is not None:
            program.problem.clearance.use(self._scene, self._clearance_m)
        return program

    def _lines(self, warm: np.ndarray, x0: np.ndarray, problem: FullParkingProblem | None = None) -> np.ndarray:
        """The scene's lines of each step (N, n) drawn around the warm start ((N, 0) in open space), for
        ``problem`` (default: the OCP solved now)."""
        ocp = problem if problem is not None else self.problem
        assert isinstance(ocp, FullParkingProblem)
        lines, n = ocp.clearance, ocp.horizon
        if lines is None:
            return np.zeros((n, 0))
        states, _ = self.transcription.unpack(warm, x0)  # (single shooting: the first step a whole one)
        warm_started = self._last_inputs is not None  # the last plan moved on, not a cold guess
        return lines.parameters(self._goal, np.vstack([x0[None, :], states[1:]]), keep_warm=warm_started).reshape(n, -1)

    def _step_parameters(
        self, warm: np.ndarray, x0: np.ndarray, problem: FullParkingProblem | None = None
    ) -> np.ndarray:
        """Each step's reference (tracking) and lines (among obstacles), for ``problem`` (default: now), then
        the first step's length if the OCP takes it (:meth:`_next_first_step`)."""
        ocp = problem if problem is not None else self.problem
        assert isinstance(ocp, FullParkingProblem)
        refs = self._references if ocp.tracking else np.zeros((ocp.horizon, 0))
        first = [self._first_now] if ocp.first_step else []
        if ocp.clearance is None:  # open space: no lines
            return np.concatenate([refs.ravel(), first])
        return np.concatenate([np.hstack([refs, self._lines(warm, x0, ocp)]).ravel(), first])

    def _cold_start(
        self, x0: np.ndarray, guess: np.ndarray, u_min: np.ndarray, u_max: np.ndarray, free: Any
    ) -> np.ndarray:
        """The warm start when there is no previous plan.

        Tracking, the reference itself (its steer and speed reached within the rate limits). Among
        obstacles, then, a plan to draw the scene's lines around. Lines drawn around the cold guess
        (reverse with the steer held) can shut out every plan: a line at a corner the guess passes too
        close leaves no room where the plan will be. So the plan without lines comes first (clear
        wherever the car can be clear; it meets every line drawn around it when it is). Where it passes
        too close, the obstacle OCP is solved around it, and while that fails, again around the general
        solver's last iterate (up to :data:`COLD_ROUNDS` rounds): once a round succeeds, its plan meets the
        lines drawn around it, and the warm-started steps that follow keep it so. When none succeeds, the
        plan without lines (or the guess) is the start, never a failed round's iterate.
        """
        assert isinstance(self.problem, FullParkingProblem)
        tracking = self.problem.tracking
        if tracking:
            guess = self._reference_guess(x0, u_min, u_max)
        lines = self.problem.clearance
        if lines is None:
            return guess
        plain = self._program_for(tracking, lines=False)
        bounds = plain.transcription.bounds(u_min, u_max, free)
        solver = self._relaxed_solver(plain) if free else plain.solver
        assert isinstance(plain.problem, FullParkingProblem)
        p = np.concatenate([x0, self._step_parameters(guess, x0, plain.problem)])
        ok, _, w, _ = self._solve(solver, p, guess, bounds)
        if not ok:
            w = guess
        states = self.transcription.unpack(w, p)[0]
        if ok and lines.least_slack(states, self._lines(w, x0).ravel()) >= 0.0:
            return w  # clear: it meets the lines drawn around it
        bounds = self.transcription.bounds(u_min, u_max, free)
        general = self._general_solver()
        start, iterate = w, w
        for _ in range(COLD_ROUNDS):
            p = np.concatenate([x0, self._step_parameters(iterate, x0)])
            ok, _, iterate, _ = self._solve(general, p, iterate, bounds)
            if not np.all(np.isfinite(iterate)):
                break
            if ok:
                return iterate
        # No round succeeded: the plan without lines (or the guess), not the last failed iterate, which can be
        # anything; from one far off the solvers that follow can spend minutes (the wild iterate of
        # tests/ocp/test_obstacles.py's failing rounds held the step for minutes on the old code).
        return start

    def _reference_guess(self, x0: np.ndarray, u_min: np.ndarray, u_max: np.ndarray) -> np.ndarray:
        """The reference as a warm start: its states, and the rates that move the steer and speed to it."""
        states = np.vstack([x0[None, :], self._references])
        steps = np.full(len(self._references), self.prediction_step)
        steps[0] = self._first_now
        rates = np.diff(states[:, 4:6], axis=0) / steps[:, None]
        return self.transcription.guess(x0, np.clip(rates, u_min, u_max), states)

    def _cold_inputs(self) -> np.ndarray:
        # Accelerate in reverse, straight: from standing still a zero input sees no gain in moving.
        n = self.problem.horizon
        ramp = max(1, round(0.5 * abs(self.settings.speed_min) / (self.vehicle.max_accel * self.prediction_step)))
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

    def act(self, measurement: Measurement, goal: Pose, in_flight: Sequence[Command] = ()) -> ControlStep:
        check_instance("measurement", measurement, Measurement)
        self._goal = check_goal(goal)
        x0 = self._state(measurement, self._goal, in_flight)
        refused = self._refuse(x0, x0[3])
        if refused is not None:
            return refused
        self._track(x0)
        return self._plan(x0)

    def _track(self, x0: np.ndarray) -> None:
        """This sample's first prediction step (:meth:`_next_first_step`); tracking, the reference of each
        prediction step from ``x0``, whose yaw moves to its branch."""
        self._first_now = self._next_first_step()[0]
        if self._reference is not None:
            self._references = self._reference.window(x0, self._first_now)
            x0[2] = self._reference.branch(float(x0[2]))

    def initial_steer(self, measurement: Measurement, goal: Pose) -> float | None:
        """The steer the plan would start with if the wheels could be set freely, chosen standing still."""
        self._goal = check_goal(goal)
        x0 = self._state(measurement, self._goal, ())
        if self._refuse(x0, x0[3]) is not None:
            return None
        self._track(x0)
        step = self._plan(x0, free_steer=True)
        self.reset(measurement.front_steer)
        if not step.ok:
            return None
        limit = self.vehicle.max_steer  # the solver's tolerance must not leak past the limit
        return clamp(step.predicted_states[0, STEER], -limit, limit)

    def _plan(self, x0: np.ndarray, free_steer: bool = False) -> ControlStep:
        assert isinstance(self.problem, FullParkingProblem)
        v = self.vehicle
        u_min, u_max = self.problem.input_bounds()
        free = {STEER: (-v.max_steer, v.max_steer)} if free_steer else None
        ok, status, states, inputs, cost, solve_ms = self._solve_cascade(x0, u_min, u_max, free)
        if not ok:
            return self._stop(status, cost, solve_ms, states, inputs)
        dt = self.settings.dt  # the rates held for one sample
        steer = clamp(float(x0[STEER]) + dt * float(inputs[0, 0]), -v.max_steer, v.max_steer)
        speed = clamp(float(x0[SPEED]) + dt * float(inputs[0, 1]), self.settings.speed_min, self.settings.speed_max)
        if not (math.isfinite(steer) and math.isfinite(speed)):
            return self._stop("non-finite vehicle command", cost, solve_ms, states, inputs)
        stop = abs(speed) < self.settings.stop_speed and abs(x0[SPEED]) < self.settings.stop_speed
        self._last_inputs, self._last_states, self._first_step = inputs, states, self._first_now
        if stop:
            speed = 0.0
        self._last_steer = steer
        hitch = float(x0[3])
        trailer_speed = float(trailer_speed_from_rear_speed(v, hitch, speed, steer))  # Eq. (18)
        virtual = float(virtual_steer_from_front(v, hitch, steer))  # Eq. (56)
        return ControlStep(
            trailer_speed=trailer_speed,
            virtual_steer=virtual,
            rear_speed=speed,
            front_steer=steer,
            ok=True,
            stop=stop,
            status=status,
            cost=cost,
            solve_ms=solve_ms,
            predicted_states=states,
            predicted_inputs=inputs,
        )


#: Rounds of the obstacle OCP from a cold start, each around the last one's iterate (:meth:`FullNMPC._cold_start`).
COLD_ROUNDS = 3

#: The NMPC of each ``NMPCSettings.kind``.
NMPC_CLASSES: dict[str, type[TrailerNMPC] | type[FullNMPC]] = {"paper": TrailerNMPC, "full": FullNMPC}


def make_nmpc(vehicle: VehicleTrailer, settings: NMPCSettings) -> TrailerNMPC | FullNMPC:
    """The reverse controller that ``settings.kind`` names."""
    return NMPC_CLASSES[settings.kind](vehicle, settings)
