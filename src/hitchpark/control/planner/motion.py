"""Motion primitives on the exact full model (Eqs. 19-24), integrated for many primitives in one call.

A primitive drives the rear axle ``length`` metres at 1 m/s. The front steer is a state: it moves
towards a commanded steer at most ``max_steer_rate`` (d delta / dt = clip((cmd - delta) / tau, -rate,
rate), tau one sample), so it never jumps within a direction and its rate bound holds between samples
by construction (each RK4 increment is a weighted mean of slopes within the bound).

- **Forward**, the command is a front steer, held (within the forward cap that cannot jackknife).
- **In reverse**, the command is a *virtual steer* (Section 3): the trailer is steered as a vehicle of
  its own, the front steer commanded at every instant by Eq. (45) from the current hitch angle, clipped
  to ``max_steer``. A held front steer in reverse drives the hitch away exponentially (the
  unstable mode of a reversing trailer) and a front-steer lattice finds almost no long reverse
  motions; a held virtual steer gives the trailer axle an arc and the hitch settles.

One RK4 step per sample. Built once per vehicle and sampling as a CasADi function mapped over a batch
of primitives: evaluating 14 primitives of 10 samples takes about 0.3 ms, against about 1.8 ms for the
same RK4 vectorised in NumPy (measured on this 2-core machine). The batch functions are compiled to C
where a compiler is at hand (:func:`~hitchpark.native.native`), about half the
time again.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable

import casadi as ca
import numpy as np

from ...model.inverse import front_steer_from_virtual
from ...model.kinematics import full_rhs
from ...model.vehicle import VehicleTrailer
from ...native import native

__all__ = ["GoalShot", "PrimitiveBatch", "commanded_steer"]


def commanded_steer(vehicle: VehicleTrailer, hitch: ca.SX, command: ca.SX, direction: ca.SX | float) -> ca.SX:
    """The front steer commanded: ``command`` itself forward; Eq. (45) of the virtual steer in reverse."""
    front = front_steer_from_virtual(vehicle, hitch, command)  # Eq. (45)
    limited = ca.fmin(ca.fmax(front, -vehicle.max_steer), vehicle.max_steer)
    return ca.if_else(direction > 0, command, limited)


def _actuated_rhs(vehicle: VehicleTrailer, x: ca.SX, target: ca.SX, direction: ca.SX | float, tau: float) -> ca.SX:
    """d/dt of (x, y, yaw, hitch, steer): the full model at 1 m/s, the steer towards ``target`` rate-limited."""
    rate = vehicle.max_steer_rate
    steer_rate = ca.fmin(ca.fmax((target - x[4]) / tau, -rate), rate)
    return ca.vertcat(full_rhs(vehicle, x[:4], ca.vertcat(direction, x[4])), steer_rate)


def _rk4_columns(f: Callable[[ca.SX], ca.SX], x0: ca.SX, h: float, samples: int) -> ca.SX:
    """The state at each of ``samples`` RK4 steps of ``h`` from ``x0`` (``x0`` first), as columns."""
    x, columns = x0, [x0]
    for _ in range(samples):
        k1 = f(x)
        k2 = f(x + 0.5 * h * k1)
        k3 = f(x + 0.5 * h * k2)
        k4 = f(x + h * k3)
        x = x + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        columns.append(x)
    return ca.horzcat(*columns)


def _pursuit_rhs(
    vehicle: VehicleTrailer, x: ca.SX, tx: ca.SX | float, ty: ca.SX | float, limit: ca.SX, tau: float
) -> ca.SX:
    """d/dt of (x, y, yaw, hitch, steer) in reverse, the trailer axle pursuing the point (``tx``, ``ty``).

    Pure pursuit of the trailer axle driven backwards: the virtual steer with the curvature
    2 sin(alpha) / l_d, alpha the bearing of the point from the backward heading and l_d its distance,
    within +-``limit``; the trailer turns by Eq. (42), the front steer follows from Eq. (45), rate-limited
    as in the primitives.
    """
    dx, dy = tx - x[0], ty - x[1]
    distance = ca.fmax(ca.sqrt(dx**2 + dy**2), 1e-6)
    bearing = ca.atan2(dy, dx) - (x[2] + np.pi)
    alpha = ca.atan2(ca.sin(bearing), ca.cos(bearing))
    virtual = ca.atan(-2.0 * vehicle.trailer_length * ca.sin(alpha) / distance)
    virtual = ca.fmin(ca.fmax(virtual, -limit), limit)
    return _actuated_rhs(vehicle, x, commanded_steer(vehicle, x[3], virtual, -1.0), -1.0, tau)


@functools.lru_cache(maxsize=16)
def _shot_function(vehicle: VehicleTrailer, step: float, runs: int, chunk: int) -> ca.Function:
    """``F(x0 (5, runs), lookaheads (1, runs * chunk), limits) -> (5, runs * chunk)``: reverse runs onto the goal line.

    In the goal frame. The trailer axle pursues the point of the line y = 0 one look-ahead behind it (the
    foot of the perpendicular when the line is farther). One RK4 step as a function, mapped over the runs
    and accumulated over ``chunk`` samples (CasADi ``mapaccum``): cheap to build, and the end-game can
    stop after any chunk.
    """
    x0, lookahead, limit = ca.SX.sym("x0", 5), ca.SX.sym("lookahead"), ca.SX.sym("limit")

    def rhs(x: ca.SX) -> ca.SX:
        ahead = ca.sqrt(ca.fmax(lookahead**2 - x[1] ** 2, 0.0))
        return _pursuit_rhs(vehicle, x, x[0] - ahead, 0.0, limit, step)

    one = ca.Function("shot_step", [x0, lookahead, limit], [_rk4_columns(rhs, x0, step, 1)[:, 1]])
    return one.map(runs).mapaccum("goal_shot", chunk)


@functools.lru_cache(maxsize=16)
def _pursuit_function(vehicle: VehicleTrailer, step: float, runs: int) -> ca.Function:
    """``F(x (5, runs), targets (2, runs), limit) -> (5, runs)``: one RK4 step of each run towards its point."""
    x0, target, limit = ca.SX.sym("x0", 5), ca.SX.sym("target", 2), ca.SX.sym("limit")

    def rhs(x: ca.SX) -> ca.SX:
        return _pursuit_rhs(vehicle, x, target[0], target[1], limit, step)

    one = ca.Function("pursuit_step", [x0, target, limit], [_rk4_columns(rhs, x0, step, 1)[:, 1]])
    return one.map(runs)


@functools.lru_cache(maxsize=16)
def _primitive_function(vehicle: VehicleTrailer, length: float, samples: int) -> ca.Function:
    """``F(x0[5], command, direction) -> (5, samples + 1)``: (x, y, yaw, hitch, steer) at the samples."""
    x0, command, d = ca.SX.sym("x0", 5), ca.SX.sym("command"), ca.SX.sym("d")
    h = length / samples

    def rhs(x: ca.SX) -> ca.SX:
        return _actuated_rhs(vehicle, x, commanded_steer(vehicle, x[3], command, d), d, h)

    return ca.Function("primitive", [x0, command, d], [_rk4_columns(rhs, x0, h, samples)])


@functools.lru_cache(maxsize=16)
def _primitive_batch_function(vehicle: VehicleTrailer, length: float, samples: int, size: int) -> ca.Function:
    """:func:`_primitive_function` mapped over ``size`` primitives."""
    return _primitive_function(vehicle, length, samples).map(size)


@functools.lru_cache(maxsize=16)
def _initial_steer_function(vehicle: VehicleTrailer) -> ca.Function:
    hitch, command, d = ca.SX.sym("hitch"), ca.SX.sym("command"), ca.SX.sym("d")
    return ca.Function("initial_steer", [hitch, command, d], [commanded_steer(vehicle, hitch, command, d)])


class PrimitiveBatch:
    """Integrates up to ``size`` primitives of one vehicle and sampling at once."""

    def __init__(self, vehicle: VehicleTrailer, length: float, samples: int, size: int):
        vehicle.require_hitch_offset()  # Eq. (45) divides by L_H
        self.samples = samples
        self.size = size
        self.times = np.linspace(0.0, length, samples + 1)
        self._mapped = native(_primitive_batch_function(vehicle, length, samples, size))
        self._initial = _initial_steer_function(vehicle).map(size)

    def initial_steer(self, hitch: float, command: np.ndarray, direction: np.ndarray) -> np.ndarray:
        """The steer set at standstill before a primitive starts: what it commands at its first instant."""
        n = len(command)
        pad = self.size - n
        out = self._initial(
            np.full(self.size, hitch), np.pad(np.asarray(command, float), (0, pad)), np.pad(direction, (0, pad))
        )
        return np.asarray(out, dtype=float).ravel()[:n]

    def run(self, start: np.ndarray, steer0: np.ndarray, command: np.ndarray, direction: np.ndarray) -> np.ndarray:
        """Configurations and steer, shape ``(n, samples + 1, 5)``, of ``n <= size`` primitives from ``start``.

        ``start``: (x, y, yaw, hitch); ``steer0``, ``command``, ``direction`` (+1 forward, -1 reverse): one
        per primitive.
        """
        n = len(command)
        x0 = np.zeros((5, self.size))
        x0[:4] = np.asarray(start, dtype=float)[:4, None]
        x0[4, :n] = steer0
        c = np.zeros(self.size)
        c[:n] = command
        d = np.ones(self.size)
        d[:n] = direction
        out = np.asarray(self._mapped(x0, c, d))  # (5, size * (samples + 1))
        return out.reshape(5, self.size, self.samples + 1).transpose(1, 2, 0)[:n]


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
        runs so far (an array like the result) that none can still arrive.
        """
        n, chunk = len(self.lookaheads), self.CHUNK
        lookaheads = np.tile(self.lookaheads, chunk)[None, :]
        limits = np.full((1, n * chunk), limit)
        x = np.repeat(np.asarray(start, dtype=float)[:, None], n, axis=1)
        parts = [x.T[:, None, :]]
        for _ in range(max(1, math.ceil(length / self.step / chunk))):
            out = np.asarray(self._function(x, lookaheads, limits))  # (5, chunk * n), sample-major
            block = out.reshape(5, chunk, n).transpose(2, 1, 0)
            parts.append(block)
            x = block[:, -1, :].T
            runs = np.concatenate(parts, axis=1)
            if ended(runs):
                return runs
        return np.concatenate(parts, axis=1)


class PathPursuit:
    """Reverse runs of the trailer axle along reference paths by pure pursuit (the analytic end-game).

    Each run pursues, one look-ahead along its reference, the point past the reference point nearest the
    trailer axle (searched a little ahead of the last one, so a run never jumps back along its path).
    """

    #: How far ahead along the reference [samples] the nearest point is searched at each step.
    WINDOW = 12

    #: Samples integrated between two questions to ``ended`` (see :meth:`run`).
    CHECK_EVERY = 8

    def __init__(self, vehicle: VehicleTrailer, step: float, runs: int):
        vehicle.require_hitch_offset()
        self.step = step
        self.runs = runs
        self._function = native(_pursuit_function(vehicle, step, runs))

    def run(
        self,
        start: np.ndarray,
        references: np.ndarray,
        lookaheads: np.ndarray,
        limit: float,
        ended: Callable[[np.ndarray, np.ndarray], np.ndarray],
    ) -> np.ndarray:
        """(x, y, yaw, hitch, steer) of each run from ``start`` (5,): shape (runs, samples + 1, 5).

        ``references`` (runs, m, 2): points ``step`` apart, the path of each run (padded with its last
        point); ``lookaheads`` (runs,) [m]. A run is integrated until ``ended(states, deviation)`` says of
        its state and its distance from the reference that it cannot still arrive (or has); all stop when
        every run has, or at the end of the references. ``ended`` judges each row alone (states (n, 5),
        deviations (n,)): it is asked about :data:`CHECK_EVERY` samples of every run at once, and a run
        that ended is then held at the sample where it did, as if it had been stopped there.
        """
        runs, m = references.shape[0], references.shape[1]
        ahead = np.maximum(1, np.round(np.asarray(lookaheads) / self.step)).astype(np.int64)
        rows = np.arange(runs)
        x = np.repeat(np.asarray(start, dtype=float)[:, None], runs, axis=1)
        nearest = np.zeros(runs, dtype=np.int64)
        window = np.arange(self.WINDOW)
        limits = np.full((1, runs), limit)
        states = [x.T.copy()]  # sample i of every run
        deviation: list[np.ndarray] = []  # its distance from the reference, once its nearest point is known
        end = np.full(runs, -1)  # the sample where each run ended (-1: not yet)
        checked = 0  # samples asked about so far
        for i in range(m + self.WINDOW):
            candidates = np.minimum(nearest[:, None] + window[None, :], m - 1)
            gap = references[rows[:, None], candidates] - x[:2].T[:, None, :]
            distance = np.hypot(gap[..., 0], gap[..., 1])
            best = np.argmin(distance, axis=1)
            nearest = candidates[rows, best]
            deviation.append(distance[rows, best])
            if i + 1 - checked == self.CHECK_EVERY:
                checked = self._ended(states, deviation, checked, end, ended)
                if (end >= 0).all():
                    break
            targets = references[rows, np.minimum(nearest + ahead, m - 1)].T
            x = np.asarray(self._function(x, targets, limits))
            held = end >= 0
            x[:, held] = states[-1].T[:, held]  # a run that ended stays where it ended
            states.append(x.T.copy())
        else:
            self._ended(states, deviation, checked, end, ended)
        path = np.stack(states, axis=1)  # (runs, samples, 5)
        if (end >= 0).all():
            path = path[:, : end.max() + 1]
        for r in np.flatnonzero(end >= 0):
            path[r, end[r] + 1 :] = path[r, end[r]]
        return path

    @staticmethod
    def _ended(
        states: list[np.ndarray],
        deviation: list[np.ndarray],
        checked: int,
        end: np.ndarray,
        ended: Callable[[np.ndarray, np.ndarray], np.ndarray],
    ) -> int:
        """Ask ``ended`` about the samples from ``checked`` on that have a deviation; note in ``end`` where each
        run first ended. The samples asked about so far."""
        upto = len(deviation)
        if upto <= checked:
            return checked
        block = np.stack(states[checked:upto], axis=1)  # (runs, k, 5)
        runs, k = block.shape[0], block.shape[1]
        flags = np.asarray(ended(block.reshape(runs * k, 5), np.stack(deviation[checked:upto], axis=1).ravel()))
        flags = flags.reshape(runs, k)
        first = np.where(flags.any(axis=1), checked + np.argmax(flags, axis=1), -1)
        new = (end < 0) & (first >= 0)
        end[new] = first[new]
        return upto
