"""Transcriptions of an optimal control problem into a nonlinear program: any problem that meets :class:`OCP`
(the paper's, :class:`hitchpark.ocp.TrailerParkingProblem`, or the full model's).

A transcription turns the OCP into CasADi's ``{x, p, f, g}`` with the initial
state as the parameter ``p`` (followed by the OCP's ``n_p`` parameters of each
prediction step k = 1..N, whose rows on X_k follow X_k's dynamics, and, for an OCP with
``first_step``, the length of the first prediction step), and knows
how to lay out bounds, initial guesses and solutions. Eq. (51) is the single-shooting form (inputs only); multiple
shooting keeps the states as unknowns tied by the dynamics as equality
constraints, which is sparser and better conditioned over long horizons.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

import casadi as ca
import numpy as np

__all__ = [
    "OCP",
    "Layout",
    "MultipleShooting",
    "OCPSettings",
    "PathConstraint",
    "SingleShooting",
    "Transcription",
    "make_transcription",
    "shifted_rows",
]


class OCPSettings(Protocol):
    """What a transcription reads of an OCP's settings (:class:`hitchpark.ocp.NMPCSettings` has it)."""

    @property
    def prediction_dt(self) -> float | None: ...

    @property
    def transcription(self) -> str: ...


class OCP(Protocol):
    """What a transcription needs of an optimal control problem (the paper's or the full model's)."""

    @property
    def settings(self) -> OCPSettings: ...

    n_x: int
    n_u: int
    path_constraints: list[PathConstraint]
    #: Parameters of each prediction step k = 1..N beyond the initial state (the NLP's ``p`` is X_0, then these).
    n_p: int
    #: Whether the first prediction step's length is a parameter, the NLP's last (``discrete_dynamics`` then
    #: takes a step length): the prediction grid stays where it is in time while the controller's samples pass,
    #: the first step shortening, instead of moving on a fraction of a step each sample
    #: (:meth:`~hitchpark.control.receding.RecedingHorizon._next_first_step`).
    first_step: bool

    @property
    def horizon(self) -> int: ...

    def step_rows(self, x: Any, params: Any) -> tuple[list[Any], list[float], list[float]]:
        """Constraint rows ``(expressions, lower, upper)`` on X_k (k = 1..N) given that step's parameters."""
        ...

    def discrete_dynamics(self, x: Any, u: Any, dt: Any = None) -> Any:
        """X_{k+1} from X_k and U_k over ``dt`` [s] (None: the prediction step)."""
        ...

    def stage_cost(self, x: Any, u: Any, params: Any = None) -> Any:
        """The cost of stage k; ``params``: step k's parameters (step 1's for k = 0, where X_0 is given)."""
        ...

    def terminal_cost(self, x: Any, params: Any = None) -> Any: ...

    def state_bounds(self) -> tuple[np.ndarray, np.ndarray] | None: ...


#: An extra constraint on stage k: ``(x_k, u_k, k) -> (expr, lower, upper)``, CasADi expressions.
PathConstraint = Callable[[Any, Any, int], tuple[Any, Any, Any]]


@dataclass(frozen=True)
class Layout:
    """Where multiple shooting keeps each stage's unknowns and rows: ``states`` (N + 1, n_x) and ``inputs``
    (N, n_u) index the NLP's ``x``; ``dynamics`` (N, n_x) the rows of ``g`` tying X_{k+1} to X_k and U_k (their
    multipliers are the costates); ``step_rows`` (N, m) the OCP's rows on X_1..X_N, where every step has the
    same number (else None)."""

    states: np.ndarray
    inputs: np.ndarray
    dynamics: np.ndarray
    step_rows: np.ndarray | None


class Transcription:
    """Common interface. ``nlp``, ``lbg``, ``ubg`` are ready for ``casadi.nlpsol``."""

    nlp: dict[str, Any]
    lbg: np.ndarray
    ubg: np.ndarray

    def __init__(self, problem: OCP):
        self.problem = problem

    def bounds(
        self, u_min: np.ndarray, u_max: np.ndarray, free_initial: dict[int, tuple[float, float]] | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``lbx, ubx, lbg, ubg`` given input bounds (the same for all k, Eq. 50) and the problem's state bounds.

        ``free_initial`` frees components of X_0 from the measured state, within the given bounds
        (the steer the next stage would like to start with, chosen while standing still).
        """
        raise NotImplementedError

    def guess(self, x0: np.ndarray, inputs: np.ndarray, states: np.ndarray | None = None) -> np.ndarray:
        """Decision vector from an input guess (N, 2) and optionally a state guess (N+1, 3)."""
        raise NotImplementedError

    def unpack(self, w: np.ndarray, x0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Predicted states (N+1, n_x) and inputs (N, n_u) from a decision vector; ``x0``: the initial state or
        the whole parameter vector p (single shooting rolls the states out from it, over the first step's
        length that p holds)."""
        raise NotImplementedError

    def shift_duals(self, lam_x: np.ndarray, lam_g: np.ndarray, part: float) -> tuple[np.ndarray, np.ndarray] | None:
        """A solution's multipliers ``lam_x``, ``lam_g`` moved on by ``part`` of a prediction step (0 <= part
        <= 1) as the primal warm start is: the next problem's start. None: this layout has none."""
        return None

    def _path_constraints(self, xs: list[Any], us: list[Any]) -> tuple[list[Any], list[Any], list[Any]]:
        g, lb, ub = [], [], []
        for k, (x, u) in enumerate(zip(xs[:-1], us, strict=True)):
            for con in self.problem.path_constraints:
                expr, lo, hi = con(x, u, k)
                g.append(expr)
                lb.append(lo)
                ub.append(hi)
        return g, lb, ub


def _step_params(problem: OCP, extra: Any, k: int) -> Any:
    """The parameters of prediction step k = 1..N."""
    return extra[(k - 1) * problem.n_p : k * problem.n_p]


def _cost(problem: OCP, xs: list[Any], us: list[Any], extra: Any, h0: Any = None) -> Any:
    """Stage costs of k = 0..N-1 and the terminal cost, each with its step's parameters (X_0's stage, where
    X_0 is given, with step 1's). ``h0``: the first step's length, whose stage weighs that part of a
    prediction step (a stage's cost is that of a prediction step's time)."""
    N = len(us)
    costs = [problem.stage_cost(xs[k], us[k], _step_params(problem, extra, max(k, 1))) for k in range(N)]
    if h0 is not None:
        costs[0] = first_step_weight(problem, h0) * costs[0]
    return sum(costs) + problem.terminal_cost(xs[N], _step_params(problem, extra, N))


def first_step_weight(problem: OCP, h0: Any) -> Any:
    """The weight of the first stage's cost when its step lasts ``h0`` [s]: that part of a prediction step."""
    assert problem.settings.prediction_dt is not None
    return h0 / problem.settings.prediction_dt


def _first_step(problem: OCP) -> Any:
    """The symbol of the first step's length (the NLP's last parameter), or None (the OCP has none)."""
    return ca.SX.sym("h0") if problem.first_step else None


def _dynamics(problem: OCP, x: Any, u: Any, k: int, h0: Any) -> Any:
    """X_{k+1} = g(X_k, U_k), Eq. (48): over the first step's length ``h0`` for k = 0 where given."""
    return problem.discrete_dynamics(x, u, h0) if k == 0 and h0 is not None else problem.discrete_dynamics(x, u)


def _flat(values: list[Any]) -> np.ndarray:
    if not values:
        return np.zeros(0)
    return np.concatenate([np.atleast_1d(np.asarray(ca.DM(v)).ravel()) for v in values])


class MultipleShooting(Transcription):
    """w = [X_0, U_0, X_1, U_1, ..., X_N]; X_0 = p and X_{k+1} = g(X_k, U_k) as equalities."""

    def __init__(self, problem: OCP):
        super().__init__(problem)
        N, nx, nu = problem.horizon, problem.n_x, problem.n_u
        x0 = ca.SX.sym("x0", nx)
        extra = ca.SX.sym("P", problem.n_p * N)
        h0 = _first_step(problem)
        p = ca.vertcat(x0, extra) if h0 is None else ca.vertcat(x0, extra, h0)
        xs = [ca.SX.sym(f"X{k}", nx) for k in range(N + 1)]
        us = [ca.SX.sym(f"U{k}", nu) for k in range(N)]
        w: list[Any] = []
        for k in range(N):
            w += [xs[k], us[k]]
        w.append(xs[N])
        cost = _cost(problem, xs, us, extra, h0)  # Eq. (49)
        g: list[Any] = [xs[0] - x0]  # X_0 = p: the first nx constraints
        lbg, ubg = [np.zeros(nx)], [np.zeros(nx)]

        # Where each stage's constraints lie in g: the rows of X_0 = p and of each gap X_{k+1} - f(X_k, U_k)
        # (their multipliers are the costates of X_0 ... X_N), and the rows on each X_k, k >= 1.
        at = nx
        costates, step_rows = [np.arange(nx)], []

        def add(k: int) -> None:  # the rows on X_k (k >= 1), with their step's parameters
            nonlocal at
            rows, lo, hi = problem.step_rows(xs[k], _step_params(problem, extra, k))
            g.extend(rows)
            lbg.append(np.array(lo, dtype=float))
            ubg.append(np.array(hi, dtype=float))
            step_rows.append(np.arange(at, at + len(lo)))
            at += len(lo)

        # fatrop's structure detection takes the rows on X_k after the dynamics of stage k (measured: after
        # those of stage k - 1 it finds twice the stages and refuses).
        for k in range(N):
            g.append(xs[k + 1] - _dynamics(problem, xs[k], us[k], k, h0))  # Eq. (48)
            lbg.append(np.zeros(nx))
            ubg.append(np.zeros(nx))
            costates.append(np.arange(at, at + nx))
            at += nx
            if k > 0:
                add(k)
        add(N)
        self._costate_idx = np.array(costates)
        # The same rows on every X_k (one OCP's step_rows), else none to shift.
        same = len({len(r) for r in step_rows}) == 1 and len(step_rows[0]) > 0
        self._row_idx = np.array(step_rows) if same else None
        pg, plb, pub = self._path_constraints(xs, us)
        self.nlp = {"x": ca.vertcat(*w), "p": p, "f": cost, "g": ca.vertcat(*g, *pg)}
        self.lbg = np.concatenate([*lbg, _flat(plb)])
        self.ubg = np.concatenate([*ubg, _flat(pub)])
        stride = nx + nu
        self._x_idx = np.array([[k * stride + i for i in range(nx)] for k in range(N + 1)])
        self._u_idx = np.array([[k * stride + nx + i for i in range(nu)] for k in range(N)])
        self._n = stride * N + nx
        self._shift_x = _shift_map(self._x_idx, self._u_idx)
        self._shift_g = _shift_map(self._costate_idx, self._row_idx)
        self.layout = Layout(self._x_idx, self._u_idx, self._costate_idx, self._row_idx)
        self._bounds: dict[
            tuple[tuple[float, ...], tuple[float, ...]], tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]
        ] = {}
        x, u = ca.SX.sym("x", nx), ca.SX.sym("u", nu)
        self._step = ca.Function("step", [x, u], [problem.discrete_dynamics(x, u)])  # for cold-start rollouts

    def bounds(
        self, u_min: np.ndarray, u_max: np.ndarray, free_initial: dict[int, tuple[float, float]] | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        key = (tuple(np.ravel(u_min)), tuple(np.ravel(u_max)))
        if not free_initial and key in self._bounds:  # the same every step: built once, read-only
            return self._bounds[key]
        lb = np.full(self._n, -np.inf)
        ub = np.full(self._n, np.inf)
        lb[self._u_idx] = u_min
        ub[self._u_idx] = u_max
        x_bounds = self.problem.state_bounds()
        if x_bounds is not None:
            lb[self._x_idx[1:]] = x_bounds[0]
            ub[self._x_idx[1:]] = x_bounds[1]
        lbg, ubg = self.lbg, self.ubg
        if free_initial:
            lbg, ubg = lbg.copy(), ubg.copy()
            for i, (lo, hi) in free_initial.items():
                lbg[i], ubg[i] = -np.inf, np.inf  # X_0[i] - p[i] unconstrained ...
                lb[self._x_idx[0, i]], ub[self._x_idx[0, i]] = lo, hi  # ... X_0[i] within its bounds
            return lb, ub, lbg, ubg
        lb.flags.writeable = ub.flags.writeable = False
        self._bounds[key] = (lb, ub, lbg, ubg)
        return self._bounds[key]

    def guess(self, x0: np.ndarray, inputs: np.ndarray, states: np.ndarray | None = None) -> np.ndarray:
        if states is None:
            rollout = [np.asarray(x0, dtype=float)]
            for u in inputs:
                rollout.append(np.asarray(self._step(rollout[-1], u)).ravel())
            states = np.array(rollout)
        w = np.zeros(self._n)
        w[self._x_idx] = states
        w[self._x_idx[0]] = x0
        w[self._u_idx] = inputs
        return w

    def unpack(self, w: np.ndarray, x0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        w = np.asarray(w).ravel()
        return w[self._x_idx], w[self._u_idx]

    def shift_duals(self, lam_x: np.ndarray, lam_g: np.ndarray, part: float) -> tuple[np.ndarray, np.ndarray] | None:
        """Each stage's multipliers take those of the next (a fraction ``part`` of the way there), the last
        stage's held, as the states and inputs of the warm start do: the bounds' on X_k and U_k, the
        costates, the rows on X_k. X_0 has no bounds (it is p); path constraints over the horizon keep theirs."""
        lam_x = np.array(lam_x, dtype=float).ravel()
        lam_g = np.array(lam_g, dtype=float).ravel()
        if lam_x.size != self._n or lam_g.size != len(self.lbg):
            return None
        if part > 0.0:  # (0: the grid stays put, each stage keeps its own)
            for lam, (moved, ahead) in ((lam_x, self._shift_x), (lam_g, self._shift_g)):
                lam[moved] = lam[ahead] if part >= 1.0 else (1.0 - part) * lam[moved] + part * lam[ahead]
        lam_x[self._x_idx[0]] = 0.0
        return lam_x, lam_g


def _shift_map(*blocks: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """The entries of blocks of indices (a row per stage) and, for each, the entry of the next stage it
    takes the value of (the last stage's its own): what :meth:`MultipleShooting.shift_duals` moves."""
    used = [b for b in blocks if b is not None]
    moved = np.concatenate([b.ravel() for b in used])
    ahead = np.concatenate([np.concatenate([b[1:], b[-1:]]).ravel() for b in used])
    return moved, ahead


def shifted_rows(rows: np.ndarray, part: float) -> np.ndarray:
    """``rows`` (one per step) moved on by ``part`` of a step (0 <= part <= 1), linearly, the last row held."""
    if part <= 0.0:
        return np.array(rows, dtype=float)
    ahead = np.empty_like(rows)
    ahead[:-1] = rows[1:]
    ahead[-1] = rows[-1]
    return ahead if part >= 1.0 else (1.0 - part) * rows + part * ahead


class SingleShooting(Transcription):
    """w = [U_0, ..., U_{N-1}]; the states are rolled out from p, Eq. (51).

    The problem's state bounds become constraints on the rolled-out states (only the
    components with a finite bound), so the NLP stays small: the inputs alone.
    """

    def __init__(self, problem: OCP):
        super().__init__(problem)
        N, nx, nu = problem.horizon, problem.n_x, problem.n_u
        x0 = ca.SX.sym("x0", nx)
        extra = ca.SX.sym("P", problem.n_p * N)
        h0 = _first_step(problem)
        p = ca.vertcat(x0, extra) if h0 is None else ca.vertcat(x0, extra, h0)
        us = [ca.SX.sym(f"U{k}", nu) for k in range(N)]
        xs = [x0]
        for k in range(N):
            xs.append(_dynamics(problem, xs[k], us[k], k, h0))  # Eq. (48)
        cost = _cost(problem, xs, us, extra, h0)  # Eq. (51)
        pg, plb, pub = self._path_constraints(xs, us)
        sg, slb, sub = [], [], []
        x_bounds = problem.state_bounds()
        if x_bounds is not None:
            rows = [i for i in range(nx) if np.isfinite(x_bounds[0][i]) or np.isfinite(x_bounds[1][i])]
            for k in range(1, N + 1):
                sg += [xs[k][i] for i in rows]
                slb += [x_bounds[0][i] for i in rows]
                sub += [x_bounds[1][i] for i in rows]
        for k in range(1, N + 1):
            rows_k, lo, hi = problem.step_rows(xs[k], _step_params(problem, extra, k))
            sg += rows_k
            slb += lo
            sub += hi
        w = ca.vertcat(*us)
        self.nlp = {"x": w, "p": p, "f": cost, "g": ca.vertcat(*sg, *pg)}
        self.lbg = np.concatenate([np.array(slb, dtype=float), _flat(plb)])
        self.ubg = np.concatenate([np.array(sub, dtype=float), _flat(pub)])
        first = [] if h0 is None else [h0]
        self._rollout = ca.Function("rollout", [w, x0, *first], [ca.horzcat(*xs).T])
        self._N, self._nu, self._nx, self._n_p = N, nu, nx, int(p.numel())

    def bounds(
        self, u_min: np.ndarray, u_max: np.ndarray, free_initial: dict[int, tuple[float, float]] | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        if free_initial:
            raise ValueError("single shooting cannot free the initial state: it is the parameter")
        return np.tile(u_min, self._N), np.tile(u_max, self._N), self.lbg, self.ubg

    def guess(self, x0: np.ndarray, inputs: np.ndarray, states: np.ndarray | None = None) -> np.ndarray:
        return np.asarray(inputs, dtype=float).ravel()

    def unpack(self, w: np.ndarray, x0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        w, x0 = np.asarray(w).ravel(), np.asarray(x0, dtype=float).ravel()
        first: list[float] = []
        if self.problem.first_step:  # the first step's length: p's last entry, else a whole prediction step
            whole = len(x0) == self._n_p
            assert self.problem.settings.prediction_dt is not None
            first = [float(x0[-1]) if whole else float(self.problem.settings.prediction_dt)]
        return np.asarray(self._rollout(w, x0[: self._nx], *first)), w.reshape(self._N, self._nu)


def make_transcription(problem: OCP) -> Transcription:
    """The transcription named by ``problem.settings.transcription``."""
    kind = problem.settings.transcription
    return {"multiple_shooting": MultipleShooting, "single_shooting": SingleShooting}[kind](problem)
