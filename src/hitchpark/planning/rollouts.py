"""Pursuits of a reference on the exact full model (Eqs. 19-24), for the planner's end-games.

A run drives the rear axle at 1 m/s in reverse, its front steer a state that moves at most
``max_steer_rate`` towards the steer commanded (as the primitives of :mod:`.motion`): here pure pursuit of
a reference, the goal line (:class:`GoalShot`) or a Dubins path or a path of the goal tree
(:class:`PathPursuit`), steering the trailer through its virtual steer (Eq. 45). Many runs are integrated
in one call of a CasADi function, compiled where a compiler is at hand.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from typing import Any

import casadi as ca
import numpy as np

from ..model.inverse import front_steer_from_virtual_tangent
from ..model.vehicle import VehicleTrailer
from ..native import native
from .motion import actuated_rhs, rk4_columns

__all__ = ["GoalShot", "PathPursuit"]


def _pursuit_rhs(
    vehicle: VehicleTrailer, x: ca.SX, tx: ca.SX | float, ty: ca.SX | float, tan_limit: ca.SX, tau: float
) -> ca.SX:
    """d/dt of (x, y, yaw, hitch, steer) in reverse, the trailer axle pursuing the point (``tx``, ``ty``).

    Pure pursuit of the trailer axle driven backwards: the curvature 2 sin(alpha) / l_d, alpha the bearing
    of the point from the backward heading and l_d its distance, is the trailer's, tan(virtual steer) / L_T
    (Eq. 42), the tangent within +-``tan_limit`` (the virtual steer within +-its angle); the front steer
    follows from Eq. (45), rate-limited as in the primitives. With d the offset of the point,
    sin(alpha) = (d_x sin(yaw) - d_y cos(yaw)) / l_d, so the tangent is had without an angle: no arctangent
    of the bearing to take its sine, no arctangent of the curvature to take its tangent, no square root (an
    RK4 step calls the trigonometric functions and sqrt 53 times instead of 76; the planner's runs spend
    most of their time in them). l_d^2 is taken at least 1e-12 (the point within a micrometre of the axle).
    """
    dx, dy = tx - x[0], ty - x[1]
    lateral = dx * ca.sin(x[2]) - dy * ca.cos(x[2])  # l_d sin(alpha)
    tan_virtual = -2.0 * vehicle.trailer_length * lateral / ca.fmax(dx**2 + dy**2, 1e-12)
    tan_virtual = ca.fmin(ca.fmax(tan_virtual, -tan_limit), tan_limit)
    front = front_steer_from_virtual_tangent(vehicle, x[3], tan_virtual)  # Eq. (45)
    target = ca.fmin(ca.fmax(front, -vehicle.max_steer), vehicle.max_steer)
    return actuated_rhs(vehicle, x, target, -1.0, tau)


@functools.lru_cache(maxsize=16)
def _shot_function(vehicle: VehicleTrailer, step: float, runs: int, chunk: int) -> ca.Function:
    """``F(x0 (5, runs), lookaheads (1, runs * chunk), limits) -> (5, runs * chunk)``: reverse runs onto the goal line.

    In the goal frame. The trailer axle pursues the point of the line y = 0 one look-ahead behind it (the
    foot of the perpendicular when the line is farther). One RK4 step as a function, mapped over the runs
    and accumulated over ``chunk`` samples (CasADi ``mapaccum``): cheap to build, and the end-game can
    stop after any chunk.
    """
    x0, lookahead, limit = ca.SX.sym("x0", 5), ca.SX.sym("lookahead"), ca.SX.sym("limit")
    tan_limit = ca.tan(limit)  # once a step, not once an evaluation of the right-hand side

    def rhs(x: ca.SX) -> ca.SX:
        ahead = ca.sqrt(ca.fmax(lookahead**2 - x[1] ** 2, 0.0))
        return _pursuit_rhs(vehicle, x, x[0] - ahead, 0.0, tan_limit, step)

    one = ca.Function("shot_step", [x0, lookahead, limit], [rk4_columns(rhs, x0, step, 1)[:, 1]])
    return one.map(runs).mapaccum("goal_shot", chunk)


@functools.lru_cache(maxsize=16)
def _pursuit_step_function(vehicle: VehicleTrailer, step: float) -> ca.Function:
    """``F(x (5), target (2), limit) -> (5)``: one RK4 step of a run towards its point."""
    x0, target, limit = ca.SX.sym("x0", 5), ca.SX.sym("target", 2), ca.SX.sym("limit")
    tan_limit = ca.tan(limit)

    def rhs(x: ca.SX) -> ca.SX:
        return _pursuit_rhs(vehicle, x, target[0], target[1], tan_limit, step)

    return ca.Function("pursuit_step", [x0, target, limit], [rk4_columns(rhs, x0, step, 1)[:, 1]])


@functools.lru_cache(maxsize=32)
def _pursuit_chunk_function(
    vehicle: VehicleTrailer, step: float, runs: int, capacity: int, chunk: int, window: int
) -> ca.Function:
    """``F(x (5, runs), nearest (1, runs), references (capacity, 2 runs), ahead (1, runs), m, limit)`` ->
    ``(states (5, chunk runs), nearest (1, runs), deviations (1, chunk runs))``: ``chunk`` samples of
    :class:`PathPursuit` in one call.

    Per run and sample, as :meth:`PathPursuit.run` does it: the nearest of the ``window`` reference points
    from the last nearest one on (the first of equals; indices clipped to the ``m`` points in use), its
    distance (the deviation of this sample), then one RK4 step towards the point ``ahead`` samples past it.
    The reference points are read at computed indices (CasADi's parametric indexing), so the search runs in
    the compiled code, not in a Python loop.
    """
    one = _pursuit_step_function(vehicle, step)
    x0, nearest0 = ca.MX.sym("x0", 5), ca.MX.sym("nearest")
    reference, ahead = ca.MX.sym("reference", capacity, 2), ca.MX.sym("ahead")
    m, limit = ca.MX.sym("m"), ca.MX.sym("limit")
    rx, ry = reference[:, 0], reference[:, 1]
    last = m - 1
    x, nearest = x0, nearest0
    states, deviations = [], []
    for _ in range(chunk):
        best_index, best = nearest, ca.MX(ca.inf)
        for w in range(window):
            index = ca.fmin(nearest + w, last)
            distance = ca.hypot(rx[index] - x[0], ry[index] - x[1])
            closer = distance < best
            best_index = ca.if_else(closer, index, best_index)
            best = ca.if_else(closer, distance, best)
        nearest = best_index
        deviations.append(best)
        target = ca.fmin(nearest + ahead, last)
        x = one(x, ca.vertcat(rx[target], ry[target]), limit)
        states.append(x)
    run = ca.Function(
        "pursuit_chunk",
        [x0, nearest0, reference, ahead, m, limit],
        [ca.horzcat(*states), nearest, ca.horzcat(*deviations)],
    )
    return run.map(runs)


class GoalShot:
    """Reverse runs onto the goal line for several look-aheads at once (the planner's end-game)."""

    #: Samples integrated per call; a run stops being extended once every run has ended.
    CHUNK = 40

    def __init__(self, vehicle: VehicleTrailer, step: float, lookaheads: tuple[float, ...]):
        vehicle.require_hitch_offset()
        self.step = step
        self.lookaheads = np.asarray(lookaheads, dtype=float)
        self._function = native(_shot_function(vehicle, step, len(lookaheads), self.CHUNK))

    def run(self, start: np.ndarray, limit: float, length: float, ended: Callable[[np.ndarray], bool]) -> np.ndarray:
        """(x, y, yaw, hitch, steer) of each run from ``start`` (5,) in the goal frame: (runs, samples + 1, 5).

        Integrates chunk after chunk up to ``length`` metres, and stops early once ``ended`` says of the
        runs so far (an array like the result, asked again as it grows by each chunk) that none can still
        arrive.
        """
        n, chunk = len(self.lookaheads), self.CHUNK
        lookaheads = np.tile(self.lookaheads, chunk)[None, :]
        limits = np.full((1, n * chunk), limit)
        x = np.repeat(np.asarray(start, dtype=float)[:, None], n, axis=1)
        chunks = max(1, math.ceil(length / self.step / chunk))
        runs = np.empty((n, chunks * chunk + 1, 5))  # filled chunk by chunk
        runs[:, 0] = x.T
        for c in range(chunks):
            out = np.asarray(self._function(x, lookaheads, limits))  # (5, chunk * n), sample-major
            block = out.reshape(5, chunk, n).transpose(2, 1, 0)
            runs[:, 1 + c * chunk : 1 + (c + 1) * chunk] = block
            x = block[:, -1, :].T
            if ended(runs[:, : 1 + (c + 1) * chunk]):
                return runs[:, : 1 + (c + 1) * chunk]
        return runs


class PathPursuit:
    """Reverse runs of the trailer axle along reference paths by pure pursuit (the analytic end-game).

    Each run pursues, one look-ahead along its reference, the point past the reference point nearest the
    trailer axle (searched a little ahead of the last one, so a run never jumps back along its path).
    """

    #: How far ahead along the reference [samples] the nearest point is searched at each step.
    WINDOW = 12

    #: Samples integrated between two questions to ``ended`` (see :meth:`run`).
    CHECK_EVERY = 8

    #: The compiled sizes of reference (points) :meth:`prepare` builds: references of up to 102 m at the
    #: default 0.1 m a sample (the five scenes' plans use 256 and 1024); a longer one compiles when met.
    PREPARED = (256, 512, 1024)

    def __init__(self, vehicle: VehicleTrailer, step: float, runs: int):
        vehicle.require_hitch_offset()
        self.vehicle = vehicle
        self.step = step
        self.runs = runs

    def prepare(self) -> None:
        """Compile (or load) the chunks of the :data:`PREPARED` sizes now, before a search's clock starts."""
        for capacity in self.PREPARED:
            self._chunk(capacity)

    def _chunk(self, capacity: int) -> Any:
        """The compiled :data:`CHECK_EVERY` samples of every run, for references of up to ``capacity`` points."""
        function = _pursuit_chunk_function(self.vehicle, self.step, self.runs, capacity, self.CHECK_EVERY, self.WINDOW)
        return native(function)

    def run(
        self,
        start: np.ndarray,
        references: np.ndarray,
        lookaheads: np.ndarray,
        limit: float,
        ended: Callable[[np.ndarray, np.ndarray], np.ndarray],
        settles: Callable[[np.ndarray], bool] | None = None,
        within: int | None = None,
    ) -> np.ndarray:
        """(x, y, yaw, hitch, steer) of each run from ``start`` (5,): shape (runs, samples + 1, 5).

        ``references`` (runs, m, 2): points ``step`` apart, the path of each run (padded with its last
        point); ``lookaheads`` (runs,) [m]. A run is integrated until ``ended(states, deviation)`` says of
        its state and its distance from the reference that it cannot still arrive (or has); all stop when
        every run has, or at the end of the references. ``ended`` judges each row alone (states (n, 5),
        deviations (n,)): it is asked about :data:`CHECK_EVERY` samples of every run at once (the samples
        one compiled call integrates), and a run that ended is then given as if it had been stopped there.

        For a caller that wants the run that ends first: all stop once ``settles`` says True of a run that
        ended (its samples up to where it ended, (k + 1, 5)), or after ``within`` samples. Every run that
        ends within the samples integrated so far is in the answer, as it would have been otherwise.
        """
        runs, m = references.shape[0], references.shape[1]
        if runs != self.runs:
            raise ValueError(f"PathPursuit: {runs} references, built for {self.runs}")
        every = self.CHECK_EVERY
        capacity = max(256, 1 << (m - 1).bit_length())  # a few compiled sizes, the references padded
        table = np.zeros((capacity, 2 * runs), order="F")  # as the compiled code lays it out: no copy per call
        table[:m] = np.asarray(references, dtype=float).transpose(1, 0, 2).reshape(m, 2 * runs)
        ahead = np.maximum(1, np.round(np.asarray(lookaheads) / self.step))[None, :]
        chunk = self._chunk(capacity)
        x = np.repeat(np.asarray(start, dtype=float)[:, None], runs, axis=1)
        nearest = np.zeros((1, runs))
        total = m + self.WINDOW  # samples whose nearest point is searched, at most
        if within is not None:
            total = min(total, within)
        path = np.empty((runs, total + 1, 5))  # sample i of every run, filled as they come
        path[:, 0] = x.T
        deviation = np.empty((runs, total))  # sample i's distance from the reference, once its nearest is known
        samples, known = 1, 0  # samples in path, deviations known
        end = np.full(runs, -1)  # the sample where each run ended (-1: not yet)
        checked = 0  # samples asked about so far
        stopped = False
        while known < total and not stopped:
            out, nearest, far = chunk(x, nearest, table, ahead, m, limit)
            block = np.asarray(out).reshape(5, runs, every).transpose(1, 2, 0)  # (runs, every, 5)
            k = min(every, total - known)
            deviation[:, known : known + k] = np.asarray(far).reshape(runs, every)[:, :k]
            known += k
            if known - checked == every:  # a whole chunk: ask about it, its samples but the last in path
                path[:, samples : samples + k - 1] = block[:, : k - 1]
                samples += k - 1
                before = end >= 0
                checked = self._ended(path, deviation, checked, known, end, ended)
                if (end >= 0).all() or self._settled(path, end, before, settles):
                    stopped = True
                    break
                path[:, samples] = block[:, k - 1]
                samples += 1
            else:
                path[:, samples : samples + k] = block[:, :k]
                samples += k
            x = block[:, -1, :].T.copy()
        if not stopped:
            self._ended(path, deviation, checked, known, end, ended)
        path = path[:, :samples].copy()  # (runs, samples, 5)
        if (end >= 0).all():
            path = path[:, : end.max() + 1]
        for r in np.flatnonzero(end >= 0):
            path[r, end[r] + 1 :] = path[r, end[r]]
        return path

    @staticmethod
    def _settled(
        path: np.ndarray, end: np.ndarray, before: np.ndarray, settles: Callable[[np.ndarray], bool] | None
    ) -> bool:
        """Whether ``settles`` says True of a run that ended since ``before`` (each asked once, in run order)."""
        if settles is None:
            return False
        for r in np.flatnonzero((end >= 0) & ~before):
            if settles(path[r, : end[r] + 1].copy()):
                return True
        return False

    @staticmethod
    def _ended(
        path: np.ndarray,
        deviation: np.ndarray,
        checked: int,
        upto: int,
        end: np.ndarray,
        ended: Callable[[np.ndarray, np.ndarray], np.ndarray],
    ) -> int:
        """Ask ``ended`` about samples ``checked`` to ``upto`` (their deviations known); note in ``end`` where
        each run first ended. The samples asked about so far."""
        if upto <= checked:
            return checked
        block = path[:, checked:upto]  # (runs, k, 5)
        runs, k = block.shape[0], block.shape[1]
        flags = np.asarray(ended(block.reshape(runs * k, 5), deviation[:, checked:upto].ravel()))
        flags = flags.reshape(runs, k)
        first = np.where(flags.any(axis=1), checked + np.argmax(flags, axis=1), -1)
        new = (end < 0) & (first >= 0)
        end[new] = first[new]
        return upto
