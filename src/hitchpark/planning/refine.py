"""The optimised end-game: the end of a path's last reverse run, solved again to end exactly at the goal.

The search stops at the first sample within the goal tolerance (0.3 m, 3 deg, 3 deg of hitch): its
runs land there with the hitch and the steer still swinging (measured: hitch 20 deg and steer 40 deg
2 m before the end of some landings), which no controller can follow to the 0.5 deg of a parked
trailer. This module takes the last ``refine_m`` of trailer-axle path of the last reverse run and finds,
on the full model (Eqs. 19-24) at the same speed, the nearby path that starts where that part starts
(pose, hitch and front steer) and ends exactly on the goal (or its line) at rest: trailer heading along
the goal, hitch and front steer straight. Its front steer moves within ``max_steer_rate`` (per second
at 1 m/s) and ``max_steer``, its hitch within ``max_hitch - hitch_margin``.

A nonlinear program by direct multiple shooting (one RK4 step per interval, a fixed number of intervals,
their length free within limits: the path may grow or shrink a little), laid out in stages and solved
by fatrop (``PlannerSettings.refine_solver``; IPOPT the reference) from the search's own run moved onto
the goal. The cost keeps the trailer axle near that run (which passed the
collision check) and the steer rate, the hitch and the steer low; among obstacles every node keeps the
scene's separating lines (:mod:`~hitchpark.ocp.obstacles`), and :func:`refine_plan` checks the
result's exact swept clearance. When the solver fails, or the result does not keep clear, the searched path
stays. (A run that starts standing still may start with another steer: it is set at the standstill.)
"""

from __future__ import annotations

import functools
import math
import time
from dataclasses import replace
from typing import Any

import casadi as ca
import numpy as np

from ..checks import check_choice
from ..model.collision import swept_clearance
from ..model.integrate import rk4
from ..model.kinematics import full_rhs
from ..model.scene import Scene
from ..model.state import Pose, from_goal_frame, to_goal_frame
from ..model.vehicle import VehicleTrailer
from ..ocp.obstacles import ClearanceConstraints
from ..solvers.registry import cold_solver_names, make_cold_solver
from .settings import PATH_COLUMNS, Plan, PlannerSettings

__all__ = [
    "REFINE_PLANES",
    "REFINE_STEPS",
    "refine_end",
    "refine_plan",
    "refine_solver",
]

#: Intervals of the refined part (its length / REFINE_STEPS each: 0.25 m of rear axle over 20 m).
REFINE_STEPS = 80

#: The refined part may be this much shorter or longer than the part it replaces (a ratio).
LENGTH_RANGE = (0.6, 1.6)

#: The refined path ends with this straight stretch along the goal line [m].
SETTLE_M = 1.0

#: Among obstacles, each node keeps clear of this many of the scene's pieces nearest to each body (the
#: separating lines of :mod:`~hitchpark.ocp.obstacles`).
REFINE_PLANES = 2

#: The refined path's nodes keep ``min_clearance_m`` and half CHECK_STEP_M more (the NLP's constraints);
#: its exact swept clearance is then checked in sub-steps of CHECK_STEP_M [m], a bound low by at most
#: half of that, which is allowed for. (At the 0.05 m of the search's check, a path along lines 0.3 m from a
#: curb is bounded at 0.275 m: curb_parallel's goal, when it kept 0.325 m from the curb, had lines at 0.31 m
#: leave no path to it.)
CHECK_STEP_M = 0.01

#: The first guess closes the gap between the searched run's end and the goal over this much of its
#: end [m of rear axle].
BLEND_M = 3.0

#: Cost weights, per m of path: of the squared trailer-axle distance from the searched path [1/m^2], of
#: the squared steer rate [(rad/m)^-2], hitch and steer [rad^-2]. In open space the path may move well
#: off the searched one to settle; among obstacles less (measured at the campsite: the open-space
#: weights cut past its trees, where the NMPC's separating lines, taken from its warm start to leave room
#: where the car is, then cut through that warm start by up to 0.43 m, problems the SQP route failed
#: on); CLOSE_WEIGHTS keep near it (they leave the bay's reference nearly as unsettled as the search's:
#: 30.2 m and 3 switches over 50 starts, against 22.7 m and 1).
WEIGHTS = (0.1, 0.5, 1.0, 0.2)
OBSTACLE_WEIGHTS = (1.0, 0.5, 1.0, 0.2)
CLOSE_WEIGHTS = (10.0, 0.5, 1.0, 0.2)

#: Among obstacles, the refined path is first asked to keep as much clearance as the searched run kept, up
#: to this much more than ``min_clearance_m`` [m], then ``min_clearance_m`` (OBSTACLE_ATTEMPTS).
WIDE_M = 0.15

#: What is tried in turn among obstacles at ``min_clearance_m``, until a path keeps clear: (weights,
#: straight stretch [m]).
OBSTACLE_ATTEMPTS = ((OBSTACLE_WEIGHTS, SETTLE_M), (CLOSE_WEIGHTS, SETTLE_M), (CLOSE_WEIGHTS, 0.0))


#: The refinement's bounds on the steer, its rate and the hitch are drawn in by this much [rad, rad/m]: an
#: interior-point solver may end a hair past a bound it rests on (fatrop relaxes its bounds by about 1e-8),
#: and the path must keep the limits themselves.
BOUND_MARGIN = 1e-6


@functools.lru_cache(maxsize=16)
def refine_solver(
    vehicle: VehicleTrailer, hitch_limit: float, planes: int = 0, solver: str = "fatrop"
) -> tuple[ca.Function, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The refinement NLP solved by ``solver`` (a cold-start route), the bounds of its variables and of
    its constraints that do not change between calls.

    Laid out in stages, as fatrop takes it: ``w = [X_0, U_0, X_1, ..., U_{N-1}, X_N]``, each X_k the state
    (x, y, yaw, hitch, steer; goal frame) and the length T [m of rear axle] (the same at every stage: T_{k+1}
    = T_k, a state without dynamics, bounded at stage 0), U_k the steer rate [rad per m of rear axle];
    ``g = [gap_0, (gap_k, rows on X_k) for 0 < k < N, rows on X_N]``. Parameters: the trailer-axle positions
    of the searched path at the N + 1 nodes, the weights, and with ``planes`` > 0 the separating lines of
    X_1..X_N (:class:`~hitchpark.ocp.obstacles.ClearanceConstraints`: ``planes`` per body). See
    :func:`_stages` for the indices of the parts of ``w``.
    """
    check_choice("planner.refine_solver", solver, cold_solver_names())  # (refine_end may be called directly)
    n = REFINE_STEPS
    X = [ca.SX.sym(f"X{k}", 6) for k in range(n + 1)]
    U = [ca.SX.sym(f"U{k}") for k in range(n)]
    ref = ca.SX.sym("ref", 2, n + 1)
    weight = ca.SX.sym("weight", 4)
    clearance = ClearanceConstraints(vehicle, planes) if planes else None
    lines = ca.SX.sym("lines", 0 if clearance is None else clearance.n_params, n)

    def rhs(state: ca.SX, rate: ca.SX) -> ca.SX:
        return ca.vertcat(full_rhs(vehicle, state[:4], ca.vertcat(-1.0, state[4])), rate)

    w, g, equality = [], [], []
    cost: Any = 0
    for k in range(n + 1):
        z, length = X[k][:5], X[k][5]
        h = length / n
        w.append(X[k])
        if k > 0:  # node k's share of the path (its interval's length)
            error = z[:2] - ref[:, k]
            cost += h * (weight[0] * ca.sumsqr(error) + weight[2] * z[3] ** 2 + weight[3] * z[4] ** 2)
        if k < n:
            r = U[k]
            w.append(r)
            cost += h * weight[1] * r**2
            moved = rk4(functools.partial(rhs, rate=r), z, h, substeps=1)
            g.append(X[k + 1] - ca.vertcat(moved, length))
            equality += [True] * 6
        if k > 0 and clearance is not None:
            rows = clearance.rows(z, lines[:, k - 1])[0]
            g += rows
            equality += [False] * len(rows)
    # Common subexpressions merged (the RK4 stages repeat the model's sines and cosines): fatrop calls these
    # functions in CasADi's virtual machine, where each instruction costs, and their derivatives (the
    # Lagrangian's Hessian 171294 -> 145462 instructions) come out smaller too.
    nlp: dict[str, Any] = {
        "x": ca.vertcat(*w),
        "p": ca.vertcat(ca.vec(ref), weight, ca.vec(lines)),
        "f": ca.cse(cost),
        "g": ca.cse(ca.vertcat(*g)),
    }
    nlpsol = make_cold_solver(solver, f"refine_end_{solver}", nlp, equality)
    is_row = ~np.array(equality)
    low_g, high_g = np.zeros(len(equality)), np.where(is_row, np.inf, 0.0)
    inf = np.inf
    z_bound = [inf, inf, inf, hitch_limit - BOUND_MARGIN, vehicle.max_steer - BOUND_MARGIN]
    zi, li, ui = _stages()
    high = np.full(len(li) + zi.size + len(ui), inf)
    high[zi] = z_bound
    high[ui] = vehicle.max_steer_rate - BOUND_MARGIN
    return nlpsol, -high, high, low_g, high_g


def _stages() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Indices in ``w`` of the states (N + 1, 5), of the lengths (N + 1,) and of the steer rates (N,)."""
    n = REFINE_STEPS
    stage = 7 * np.arange(n + 1)
    return stage[:, None] + np.arange(5), stage + 5, stage[:-1] + 6


def refine_end(
    vehicle: VehicleTrailer,
    configs: np.ndarray,
    steer: np.ndarray,
    span: float,
    goal: Pose,
    line: tuple[float, float],
    hitch_limit: float,
    settle: float = 0.0,
    free_steer: bool = False,
    weights: tuple[float, float, float, float] = WEIGHTS,
    clearance: ClearanceConstraints | None = None,
    row_m: float = 0.1,
    solver: str = "fatrop",
) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """The reverse run ``configs`` (k, 4: world-frame trailer pose and hitch, k >= 2, evenly spaced in
    rear-axle distance, ``span`` m of it in all) with front steers ``steer`` (k,), solved again to end on
    the goal line ``line`` = (from, to) m ahead of ``goal`` (both 0: the goal itself), heading along it,
    hitch and steer straight, the last ``settle`` m of it straight along the line; ``free_steer``: the
    run starts at a standstill, where the steer may be set anew (else it starts at ``steer[0]``);
    ``weights``: see :data:`WEIGHTS`; ``clearance``: the scene and clearance to keep (``use`` given), each
    node kept on the free side of the separating lines of the first guess there. The rows returned are
    at most ``row_m`` of rear axle apart (the NLP's intervals integrated in as many RK4 steps). Returns
    the new rows after the first (k, 4), the steers of the first and of them (k + 1,) and the rear-axle
    distance driven to each from the first row (k,) [m], or None when ``solver`` (a cold-start route) finds no
    such path."""
    n = REFINE_STEPS
    planes = 0 if clearance is None else clearance.planes
    nlpsol, low, high, low_g, high_g = refine_solver(vehicle, hitch_limit, planes, solver)
    gx, gy, gyaw = to_goal_frame(goal, configs[:, 0], configs[:, 1], configs[:, 2])
    gyaw = np.unwrap(gyaw)
    gyaw = gyaw - 2 * math.pi * round(gyaw[-1] / (2 * math.pi))  # the branch that ends near 0
    along = np.linspace(0.0, 1.0, len(configs))
    nodes = np.linspace(0.0, 1.0, n + 1)
    guess_z = np.column_stack([np.interp(nodes, along, v) for v in (gx, gy, gyaw, configs[:, 3], steer)])  # (n + 1, 5)
    # The searched run moved onto the end it must reach over its last BLEND_M (a smoothstep): the first
    # guess, the path the cost keeps near, and where the separating lines are taken.
    target = np.array([float(np.clip(guess_z[-1, 0], min(line), max(line))) + settle, 0.0, 0.0, 0.0, 0.0])
    left = (1.0 - nodes) * span
    blend = np.clip(1.0 - left / min(BLEND_M, span), 0.0, 1.0)
    guess_z += (blend * blend * (3.0 - 2.0 * blend))[:, None] * (target - guess_z[-1])
    guess_u = np.diff(guess_z[:, 4]) / (span / n)
    guess_u = np.clip(guess_u, -vehicle.max_steer_rate, vehicle.max_steer_rate)
    zi, li, ui = _stages()
    guess = np.empty(len(low))
    guess[zi], guess[li], guess[ui] = guess_z, span, guess_u
    low, high = low.copy(), high.copy()
    fixed = zi[0, :4] if free_steer else zi[0]  # starts where the searched run is, steer included unless free
    low[fixed] = high[fixed] = guess_z[0, : len(fixed)]
    low[zi[-1]] = [min(line) + settle, 0.0, 0.0, 0.0, 0.0]
    high[zi[-1]] = [max(line) + settle, 0.0, 0.0, 0.0, 0.0]
    low[li[0]], high[li[0]] = LENGTH_RANGE[0] * span, LENGTH_RANGE[1] * span
    lines = np.zeros(0) if clearance is None else clearance.parameters(goal, guess_z, anchored=False)
    params = np.concatenate([guess_z[:, :2].ravel(), weights, lines])
    result = nlpsol(x0=guess, p=params, lbx=low, ubx=high, lbg=low_g, ubg=high_g)
    if not nlpsol.stats()["success"]:
        return None
    w = np.asarray(result["x"]).ravel()
    z = w[zi]
    if not np.all(np.isfinite(w)):
        return None
    h = float(w[li[0]]) / n
    z, driven = _densified(vehicle, z, w[ui], h, row_m)
    if np.any(np.abs(z[:, 3]) > hitch_limit):  # the nodes keep it; a row between two may not
        return None
    if settle > 0.0:  # the straight stretch, hitch straight: the trailer axle moves as the rear axle
        m = max(1, math.ceil(settle / row_m - 1e-9))
        straight = np.zeros((m, 5))
        straight[:, 0] = z[-1, 0] - settle * np.arange(1, m + 1) / m
        z = np.vstack([z, straight])
        driven = np.concatenate([driven, driven[-1] + settle * np.arange(1, m + 1) / m])
    x, y, yaw = from_goal_frame(goal, z[1:, 0], z[1:, 1], z[1:, 2])
    yaw = yaw + (configs[0, 2] - from_goal_frame(goal, 0.0, 0.0, z[0, 2])[2])  # on the run's own branch
    return np.column_stack([x, y, yaw, z[1:, 3]]), z[:, 4], driven


def _densified(
    vehicle: VehicleTrailer, z: np.ndarray, u: np.ndarray, h: float, row_m: float
) -> tuple[np.ndarray, np.ndarray]:
    """Nodes ``z`` (n + 1, 5) with rows between them, each interval (steer rate ``u``, length ``h``)
    integrated in RK4 steps of at most ``row_m``; and the rear-axle distance to each row after the first."""
    sub = max(1, math.ceil(h / row_m - 1e-9))
    step = h / sub

    def rhs(x: np.ndarray) -> np.ndarray:
        return np.vstack([full_rhs(vehicle, x[:4], np.stack([-np.ones_like(u), x[4]])), u])

    x = z[:-1].T  # (5, n): every interval at once
    inner = []
    for _ in range(sub - 1):
        x = rk4(rhs, x, step, substeps=1)
        inner.append(x.T)
    rows = np.stack([*inner, z[1:]], axis=1).reshape(-1, 5)  # per interval: its inner rows, then its end
    return np.vstack([z[:1], rows]), step * np.arange(1, len(rows) + 1)


@functools.lru_cache(maxsize=16)
def _clearance(vehicle: VehicleTrailer) -> ClearanceConstraints:
    return ClearanceConstraints(vehicle, REFINE_PLANES)


def refine_plan(vehicle: VehicleTrailer, goal: Pose, scene: Scene, settings: PlannerSettings, found: Plan) -> Plan:
    """``found`` with the last ``settings.refine_m`` of its last reverse run (if the path ends in reverse)
    replaced by :func:`refine_end`'s, when ``settings.refine_solver`` solves it and, among obstacles, the whole
    path still keeps ``min_clearance_m`` by the exact swept clearance; ``found`` itself otherwise. The time
    spent is added to ``planning_s`` either way; every try of :data:`OBSTACLE_ATTEMPTS` is made until one keeps
    clear (a count, never the clock: the same plan on any machine)."""
    began = time.perf_counter()
    path = found.path
    direction, s = path["direction"], path["s"]
    if settings.refine_m <= 0.0 or len(s) < 3 or direction[-1] > 0:
        return found
    forward = np.flatnonzero(direction > 0)
    segment_start = int(forward[-1]) if len(forward) else 0  # the row the last reverse run starts from
    first = max(segment_start, int(np.searchsorted(s, s[-1] - settings.refine_m)))
    first = min(first, len(s) - 3)
    configs = np.column_stack([path[k] for k in PATH_COLUMNS[:4]])
    span = float(path["t"][-1] - path["t"][first])
    attempts: list[tuple[tuple[float, float, float, float], float, float]] = [(WEIGHTS, SETTLE_M, 0.0)]
    clearance = None
    if not scene.is_empty:
        clearance = _clearance(vehicle)
        # First as clear as the searched run was (up to WIDE_M more than asked), then as asked.
        searched, _ = swept_clearance(vehicle, scene, configs[first:], max_step_m=CHECK_STEP_M)
        wide = min(searched - CHECK_STEP_M, settings.min_clearance_m + WIDE_M)
        attempts = [(w, settle, settings.min_clearance_m) for w, settle in OBSTACLE_ATTEMPTS]
        if wide > settings.min_clearance_m:
            attempts.insert(0, (OBSTACLE_WEIGHTS, SETTLE_M, wide))
    why = f"{settings.refine_solver} found no path ending at the goal"
    chosen: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None
    for weights, settle, keep in attempts:
        if clearance is not None:
            clearance.use(scene, keep + CHECK_STEP_M / 2)
        refined = refine_end(
            vehicle,
            configs[first:],
            path["front_steer"][first:],
            span,
            goal,
            (settings.goal_line_from_m, settings.goal_line_m),
            vehicle.max_hitch - settings.hitch_margin,
            settle,
            free_steer=first == segment_start,
            weights=weights,
            clearance=clearance,
            row_m=settings.sample_step_m,
            solver=settings.refine_solver,
        )
        if refined is None:
            continue
        new = np.vstack([configs[: first + 1], refined[0]])
        kept, _ = swept_clearance(vehicle, scene, new[first:], max_step_m=CHECK_STEP_M)
        if kept >= settings.min_clearance_m - CHECK_STEP_M / 2:
            chosen = (new, *refined)
            break
        why = "the refined end comes too close to the scene"
    if chosen is None:
        spent = found.planning_s + time.perf_counter() - began
        return replace(found, detail=f"{found.detail}; its end not refined ({why})", planning_s=spent)
    new, rows, steer, driven = chosen
    # The steer at the path's start is the refined one; after a change of direction, the new run's steer
    # is set at the standstill, between the row that ends the last run and the next.
    rows_steer = np.concatenate(
        [path["front_steer"][:first], steer[:1] if first == 0 else path["front_steer"][first : first + 1], steer[1:]]
    )
    t = np.concatenate([path["t"][: first + 1], path["t"][first] + driven])
    d = np.concatenate([direction[: first + 1], np.full(len(rows), -1.0)])
    moved = np.hypot(np.diff(new[:, 0]), np.diff(new[:, 1]))
    columns = {
        "x_trailer": new[:, 0],
        "y_trailer": new[:, 1],
        "yaw_trailer": new[:, 2],
        "hitch": new[:, 3],
        "front_steer": rows_steer,
        "direction": d,
        "s": np.concatenate([[0.0], np.cumsum(moved)]),
        "t": t,
    }
    return replace(
        found,
        path=columns,
        length_m=float(columns["s"][-1]),
        planning_s=found.planning_s + time.perf_counter() - began,
        detail=found.detail + "; its end refined to end at the goal",
    )
