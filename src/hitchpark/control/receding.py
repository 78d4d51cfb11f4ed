"""The solve machinery both receding-horizon controllers share (:mod:`.nmpc`).

An OCP made ready to solve (:class:`Program`: its transcription, primary and fallback routes), the
cascade of one step (primary, fallback, a last try from a cold start), the warm start (the previous
plan moved on by a sample), the step parameters of an OCP that has some, and what a step decided
(:class:`NMPCStep`) and posed (:class:`NLPProblem`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..checks import InputError, check_instance
from ..model.plant import Measurement
from ..model.state import Pose
from ..model.vehicle import VehicleTrailer, check_vehicle
from ..ocp.settings import NMPCSettings, ParkingOCP
from ..solvers.registry import ROUTES, casadi_reason, make_solver, takes_duals, takes_free_initial
from ..solvers.transcription import make_transcription, shifted_rows
from .step import ControlStep

__all__ = ["NLPProblem", "NMPCStep"]


@dataclass(frozen=True)
class NLPProblem:
    """One NMPC solve as the controller posed it to its primary solver: replayable through any route.

    ``p`` is the initial state and the OCP's step parameters (the scene's lines), ``w0`` the warm start,
    the rest the bounds of the decision vector and of the constraints, all in the transcription's layout;
    ``lam_x0`` and ``lam_g0`` the multipliers it started from (None: the solver's own start).
    """

    p: np.ndarray
    w0: np.ndarray
    lbx: np.ndarray
    ubx: np.ndarray
    lbg: np.ndarray
    ubg: np.ndarray
    lam_x0: np.ndarray | None = None
    lam_g0: np.ndarray | None = None

    def inputs(self, duals: bool = False) -> dict[str, np.ndarray]:
        """The keyword arguments of a CasADi ``nlpsol`` call; with the multipliers if ``duals`` (and recorded):
        for a solver that takes them (:func:`hitchpark.solvers.registry.takes_duals`)."""
        out = {"x0": self.w0, "p": self.p, "lbx": self.lbx, "ubx": self.ubx, "lbg": self.lbg, "ubg": self.ubg}
        if duals and self.lam_x0 is not None and self.lam_g0 is not None:
            out.update(lam_x0=self.lam_x0, lam_g0=self.lam_g0)
        return out


#: The record of an NMPC step: a :class:`~.step.ControlStep` (the name it had when only the NMPCs made one).
NMPCStep = ControlStep


def checked_settings(vehicle: Any, settings: Any, kind: str) -> NMPCSettings:
    """Check a controller's arguments; ``settings`` None: the ``kind``'s defaults."""
    check_vehicle(vehicle)
    settings = NMPCSettings(kind=kind) if settings is None else settings
    check_instance("settings", settings, NMPCSettings, "hitchpark.control.NMPCSettings(...)")
    if settings.kind != kind:
        raise InputError(f"this controller needs nmpc.kind {kind!r}, got {settings.kind!r}")
    return settings


@dataclass
class Program:
    """An OCP made ready to solve: its transcription, the primary and fallback solvers."""

    problem: ParkingOCP
    transcription: Any
    solver: Any
    fallback: Any
    equality: list[bool]
    general: Any = None  # a general route beside a structured primary (built when first needed)
    relaxed: Any = None  # the route of problems that relax an equality (built when first needed)


def build_program(problem: ParkingOCP) -> Program:
    s = problem.settings
    transcription = make_transcription(problem)
    equality = list(transcription.lbg == transcription.ubg)
    assert s.solver is not None and s.dual_floor is not None  # resolved per kind by NMPCSettings
    try:
        solver = make_solver(
            s.solver,
            transcription.nlp,
            equality,
            s.solver_options,
            jit=bool(s.jit),
            transcription=transcription,
            dual_floor=s.dual_floor,
        )
    except RuntimeError as exc:  # CasADi refuses an unknown or ill-typed option
        raise InputError(f"nmpc.solver_options are not accepted by {s.solver}: {casadi_reason(exc)}") from None
    fallback = s.fallback_solver
    backup = make_solver(fallback, transcription.nlp, equality) if fallback and fallback != s.solver else None
    return Program(problem, transcription, solver, backup, equality)


class RecedingHorizon:
    """The solve machinery both NMPCs share: transcription, solver cascade, warm start."""

    def __init__(self, vehicle: VehicleTrailer, problem: ParkingOCP):
        vehicle.require_hitch_offset()
        self.vehicle = vehicle
        self.settings = problem.settings
        self._program = build_program(problem)
        self._last_inputs: np.ndarray | None = None
        self._last_states: np.ndarray | None = None
        #: The multipliers (lam_x, lam_g) of the last solution, which the next warm start shifts (or None).
        self._last_duals: tuple[np.ndarray, np.ndarray] | None = None
        self._last_steer = 0.0
        #: The length of the last plan's first prediction step [s] (:meth:`_next_first_step`).
        self._first_step = self.prediction_step
        #: Set to a list to record every problem posed to the primary solver (``hitchpark bench``).
        self.recorder: list[NLPProblem] | None = None

    @property
    def prediction_step(self) -> float:
        """The OCP's prediction step [s] (``prediction_dt``, which the settings resolve to ``dt`` if unset)."""
        return float(self.settings.prediction_dt or self.settings.dt)

    @property
    def problem(self) -> ParkingOCP:
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
        self._last_duals = None
        self._last_steer = float(front_steer)

    def _cold_inputs(self) -> np.ndarray:
        raise NotImplementedError

    def _next_first_step(self) -> tuple[float, float]:
        """The next problem's first prediction step [s], and how far the last plan moves on to it (a part of
        a prediction step: 1 a whole one, 0 none).

        An OCP without ``first_step`` predicts in equal steps from each sample: its plan moves on by the
        fraction ``dt / prediction_dt`` of a step (interpolated, :func:`.shifted_rows`). With one, the
        prediction grid stays put in time: each sample shortens the first step by ``dt``, the plan's rows
        unmoved, until less than a sample of it is left; then the grid moves on by a whole step, the first
        one made that much longer. With a prediction step of three samples (the full kind's 0.3 s), the
        first step lasts 0.3, 0.2, 0.1, 0.3, ... s and the warm start is the last plan itself, or moved on by
        exactly one step. An interpolated start misses where the plan's inputs change within a step (where
        it starts braking at the limit, say), and the longer the horizon the more such changes it holds: the
        iterations, and the time, of a long horizon grew with it (docs/history/speed-notebook.md, "Prediction grid").
        """
        s, step = self.settings, self.prediction_step
        if not self.problem.first_step:
            return step, s.dt / step
        if self._last_inputs is None:
            return step, 1.0  # a new grid: no plan to move on
        left = self._first_step - s.dt  # of the last plan's first step, after this sample
        if left >= s.dt - 1e-9:
            return left, 0.0
        return left + step, 1.0

    def _initial_guess(self, x0: np.ndarray, u_min: np.ndarray, u_max: np.ndarray) -> np.ndarray:
        if self._last_inputs is None:
            inputs, states = self._cold_inputs(), None
        else:
            # The previous solution moved on by one control sample (:meth:`_next_first_step`), the last step
            # repeated.
            assert self._last_states is not None
            part = self._next_first_step()[1]
            inputs = shifted_rows(self._last_inputs, part)
            states = shifted_rows(self._last_states, part)
        inputs = np.minimum(np.maximum(inputs, u_min), u_max)  # np.clip, cheaper
        return self.transcription.guess(x0, inputs, states)

    def _warm_duals(self) -> tuple[np.ndarray, np.ndarray] | None:
        """The multipliers a primary solver that takes them starts from: the last solution's, shifted as the
        primal warm start (:meth:`.Transcription.shift_duals`); None without one, or with ``warm_duals`` off."""
        if not self.settings.warm_duals or self._last_duals is None or self._last_inputs is None:
            return None
        return self.transcription.shift_duals(*self._last_duals, self._next_first_step()[1])

    def _solve(
        self,
        solver: Any,
        p: np.ndarray,
        w0: np.ndarray,
        bounds: tuple[np.ndarray, ...],
        duals: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> tuple[bool, str, np.ndarray, float]:
        """One solver's answer; a successful one's multipliers are kept for the next warm start.

        A start or parameter that is not finite is not passed on: fatrop, given one, iterates without end
        (measured: a NaN in either hangs its call), and no solver can answer it.
        """
        lbx, ubx, lbg, ubg = bounds
        start = {} if duals is None else {"lam_x0": duals[0], "lam_g0": duals[1]}
        self._last_duals = None
        if not _finite(w0, p):
            return False, "non-finite solver input (start or parameters)", np.full(len(w0), np.nan), math.nan
        try:
            sol = solver(x0=w0, p=p, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg, **start)
            stats = solver.stats()
            ok, status = bool(stats.get("success", False)), str(stats.get("return_status", "unknown"))
            w, cost = np.asarray(sol["x"]).ravel(), float(sol["f"])
        except RuntimeError as exc:  # CasADi raises on evaluation errors (e.g. NaN in a function)
            return False, f"solver error: {exc}".splitlines()[0], np.full(len(w0), np.nan), math.nan
        if ok and not (np.isfinite(w).all() and math.isfinite(cost)):
            ok, status = False, "non-finite solution"
        if ok:
            lam_x, lam_g = np.asarray(sol["lam_x"], dtype=float).ravel(), np.asarray(sol["lam_g"], dtype=float).ravel()
            if np.isfinite(lam_x).all() and np.isfinite(lam_g).all():
                self._last_duals = (lam_x, lam_g)
        return ok, status, w, cost

    def _general_solver(self, program: Program | None = None) -> Any:
        """The primary route, or a general one if the primary needs every equality of the transcription kept:
        the fallback, else IPOPT (the cold start's rounds among obstacles build on its iterates). Without a
        fallback, a primary that takes every problem and answers with its iterates (``riccati_c``) is its own
        general route, as in the exported package, which has no other solver."""
        assert self.settings.solver is not None
        program = program or self._program
        structured = ROUTES[self.settings.solver].structured
        if not structured or (self.settings.fallback_solver is None and takes_free_initial(program.solver)):
            return program.solver
        if program.general is None:
            general = self.settings.fallback_solver
            if general is None or ROUTES[general].structured:
                general = "ipopt"
            program.general = program.fallback if general == self.settings.fallback_solver else None
            if program.general is None:
                program.general = make_solver(general, program.transcription.nlp, program.equality)
        return program.general

    def _relaxed_solver(self, program: Program | None = None) -> Any:
        """The route of a problem that relaxes an equality of the transcription.

        A stage's free-steer problem (:meth:`FullNMPC.initial_steer`, once per stage, standing still) frees
        the equality X_0[steer] = p[steer]; a structure-exploiting route such as fatrop cannot take that.
        It goes to the primary solver where that takes it (``riccati_c``), else to ``relaxed_solver``, else to
        :meth:`_general_solver`.
        """
        assert self.settings.solver is not None
        program = program or self._program
        if takes_free_initial(program.solver):
            return program.solver
        name = self.settings.relaxed_solver
        if not ROUTES[self.settings.solver].structured or name is None:
            return self._general_solver(program)
        if program.relaxed is None:
            # The fallback's route: the same solver (the cascade then does not try it twice).
            program.relaxed = program.fallback if name == self.settings.fallback_solver else None
            if program.relaxed is None:
                program.relaxed = make_solver(name, program.transcription.nlp, program.equality)
        return program.relaxed

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
        relaxes an equality of the transcription (see :meth:`_relaxed_solver`).
        """
        t0 = time.perf_counter()
        relaxed = bool(free)
        bounds = self.transcription.bounds(u_min, u_max, free)
        cold = self._last_inputs is None
        warm = self._initial_guess(x0, u_min, u_max)
        if cold:
            warm = self._cold_start(x0, warm, u_min, u_max, free)
        p = np.concatenate([x0, self._step_parameters(warm, x0)])
        primary = self._relaxed_solver() if relaxed else self.solver
        duals = None if relaxed or cold or not takes_duals(primary) else self._warm_duals()
        # A problem the primary solver is given (not a free-steer problem, which not every route takes).
        if self.recorder is not None and primary is self.solver and not relaxed and _finite(warm, p):
            arrays = (np.array(a, dtype=float) for a in (p, warm, *bounds))
            self.recorder.append(NLPProblem(*arrays, *(duals or (None, None))))
        ok, status, w, cost = self._solve(primary, p, warm, bounds, duals)
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
        states, inputs = self.transcription.unpack(w, p)
        return ok, status, states, inputs, cost, solve_ms

    def _stop(self, status: str, cost: float, solve_ms: float, states: np.ndarray, inputs: np.ndarray) -> NMPCStep:
        self._last_inputs = self._last_states = None
        return ControlStep(
            trailer_speed=0.0,
            virtual_steer=0.0,
            rear_speed=0.0,
            front_steer=self._last_steer,
            ok=False,
            stop=True,
            status=status,
            cost=cost,
            solve_ms=solve_ms,
            predicted_states=states,
            predicted_inputs=inputs,
        )

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


def _finite(w0: np.ndarray, p: np.ndarray) -> bool:
    """Whether a start and parameters can be handed to a solver (see :meth:`RecedingHorizon._solve`)."""
    return bool(np.isfinite(w0).all() and np.isfinite(p).all())
