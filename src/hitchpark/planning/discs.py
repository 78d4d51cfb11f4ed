"""The planner's fast collision check: points on the bodies' outlines, looked up on a distance grid.

**Outline points.** Points at most 0.1 m apart on the outlines of the vehicle and trailer bodies, the
drawbar and the tow bar. A configuration is clear when every point is more than half the spacing,
``min_clearance_m`` and the grid's error from the scene; a motion sample, in addition, by half the
largest body movement to the next sample. Conservative: the exact check
(:func:`~hitchpark.model.collision.swept_clearance`) confirms the final path. (Discs along the centre
line were tried first: they overshoot the ends of a body by about half its width and blocked the
driveway's goal, 0.5 m from its back fence.)

Compiled where a C compiler is (``discs.c``: each point's numbers NumPy's to the last bit, groups of points the
grid shows clear passed over whole), else NumPy's (:meth:`Discs.least_numpy`).
"""

from __future__ import annotations

import ctypes
import functools
import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from ..model.geometry import body_reaches
from ..model.vehicle import VehicleTrailer
from ..native import jit_available, source_function
from .raster import DistanceGrid

__all__ = ["GROUP_M", "POINT_SPACING", "Discs", "prepare_discs"]

#: Spacing of the points on the body outlines [m].
POINT_SPACING = 0.1

#: The compiled check groups the points by cells of this side [m] of their body's frame (and 5% of scale): a
#: group the grid shows clear at its centre is passed over whole.
GROUP_M = 0.7


class Discs:
    """Points on the outlines of the bodies, each standing for a disc of radius ``POINT_SPACING / 2``.

    Body-fixed coordinates: the trailer's outline and the drawbar in the trailer frame (origin at its
    axle, x forward), the vehicle's outline and the tow bar in the vehicle frame (origin at its rear
    axle). Only outlines: an obstacle can only get inside a body by crossing its outline, which some
    sample then sees (the start itself is checked exactly).
    """

    def __init__(self, vehicle: VehicleTrailer):
        v, f = vehicle, vehicle.length_tolerance
        grow = 1.0 + f
        tx, ty = _outline(-v.trailer_rear, v.trailer_front, v.trailer_width / 2)
        dx = _segment(v.trailer_front, grow * v.trailer_length)
        vx, vy = _outline(-v.rear_overhang, v.wheelbase + v.front_overhang, v.vehicle_width / 2)
        tow = v.hitch_offset > v.rear_overhang
        bx = _segment(-v.hitch_offset, -v.rear_overhang) if tow else np.zeros(0)
        self.trailer_x, self.trailer_y = np.concatenate([tx, dx]), np.concatenate([ty, np.zeros(len(dx))])
        self.vehicle_x, self.vehicle_y = np.concatenate([vx, bx]), np.concatenate([vy, np.zeros(len(bx))])
        # With a length tolerance f, the vehicle's points stand at scales g of L_H and L_T (the rear axle at
        # the hitch g L_T ahead of the trailer axle, g L_H ahead of the hitch): its outline at 1 - f and
        # 1 + f, its corners and tow bar at scales whose shifts are at most POINT_SPACING apart, so the
        # points cover the outline of the body over the lengths' range (the hull of its two ends).
        self.scale: np.ndarray | None = None
        if f > 0.0:
            n = 1 + math.ceil(2.0 * f * (v.trailer_length + v.hitch_offset) / POINT_SPACING)
            scales = np.linspace(1.0 - f, 1.0 + f, n + 1)
            corners_x = np.array([-v.rear_overhang, v.wheelbase + v.front_overhang] * 2)
            corners_y = np.repeat([-v.vehicle_width / 2, v.vehicle_width / 2], 2)
            xs, ys, gs = [vx, vx], [vy, vy], [np.full(len(vx), 1.0 - f), np.full(len(vx), 1.0 + f)]
            for g in scales:  # (shorter than the rear overhang, the tow bar lies within the vehicle's body)
                sticks_out = tow and g * v.hitch_offset > v.rear_overhang
                bar = _segment(-g * v.hitch_offset, -v.rear_overhang) if sticks_out else np.zeros(0)
                xs += [corners_x, bar]
                ys += [corners_y, np.zeros(len(bar))]
                gs += [np.full(4 + len(bar), g)]
            self.vehicle_x, self.vehicle_y, self.scale = np.concatenate(xs), np.concatenate(ys), np.concatenate(gs)
        self.radius = np.full(len(self.trailer_x) + len(self.vehicle_x), POINT_SPACING / 2)
        self.vehicle = vehicle
        # The compiled check's operands: each vehicle point's lengths (the same numbers as centres' scalars), and
        # the points in groups of neighbours.
        self._lengths = (
            np.full(len(self.vehicle_x), v.trailer_length) if self.scale is None else v.trailer_length * self.scale,
            np.full(len(self.vehicle_x), v.hitch_offset) if self.scale is None else v.hitch_offset * self.scale,
        )
        self._groups = self._group()
        # Largest distance of a body point from the trailer axle, of the hitch from it, of a vehicle point from the
        # hitch (the movement bound), the lengths at the top of their range.
        self.reach_trailer, self.reach_hitch, self.reach_vehicle = body_reaches(v)

    def _group(self) -> tuple[np.ndarray, ...]:
        """The points in groups of neighbours (see ``discs.c``): each group's points (``order``, ``starts``), body,
        centre and lengths, and reach (its farthest point from the centre, over its lengths, and its disc)."""
        nt = len(self.trailer_x)
        lt, lh = self._lengths
        scale = np.ones(len(self.vehicle_x)) if self.scale is None else self.scale
        body = np.concatenate([np.zeros(nt, dtype=int), np.ones(len(self.vehicle_x), dtype=int)])
        x, y = np.concatenate([self.trailer_x, self.vehicle_x]), np.concatenate([self.trailer_y, self.vehicle_y])
        lengths_t, lengths_h = np.concatenate([np.zeros(nt), lt]), np.concatenate([np.zeros(nt), lh])
        keys = np.column_stack(
            [
                body,
                np.floor(x / GROUP_M),
                np.floor(y / GROUP_M),
                np.floor((np.concatenate([np.ones(nt), scale]) - 1.0) / 0.05),
            ]
        )
        _, which = np.unique(keys, axis=0, return_inverse=True)
        order = np.argsort(which.ravel(), kind="stable")
        counts = np.bincount(which.ravel())
        starts = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        columns: list[list[float]] = [[], [], [], [], [], []]
        for g in range(len(counts)):
            members = order[starts[g] : starts[g + 1]]
            cx, cy = float(x[members].mean()), float(y[members].mean())
            gt, gh = float(lengths_t[members].mean()), float(lengths_h[members].mean())
            far = np.hypot(x[members] - cx, y[members] - cy) + np.abs(lengths_t[members] - gt)
            far += np.abs(lengths_h[members] - gh)
            values = (body[members[0]], cx, cy, gt, gh, far.max() + self.radius[members].max())
            for column, value in zip(columns, values, strict=True):
                column.append(value)
        vehicle = np.array(columns[0], dtype=np.intc)
        return (order.astype(np.int64), starts, vehicle, *(np.array(c, dtype=float) for c in columns[1:]))

    def centres(self, states: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """World x, y of every point at ``states`` (..., 4): arrays of shape (..., points)."""
        x, y, yaw, hitch = states[..., 0:1], states[..., 1:2], states[..., 2:3], states[..., 3:4]
        c, s = np.cos(yaw), np.sin(yaw)
        L_T: float | np.ndarray = self.vehicle.trailer_length
        L_H: float | np.ndarray = self.vehicle.hitch_offset
        if self.scale is not None:  # each point's own lengths
            L_T, L_H = L_T * self.scale, L_H * self.scale
        xt, yt = x + c * self.trailer_x - s * self.trailer_y, y + s * self.trailer_x + c * self.trailer_y
        yaw_v = yaw + hitch
        cv, sv = np.cos(yaw_v), np.sin(yaw_v)
        x_r, y_r = x + L_T * c + L_H * cv, y + L_T * s + L_H * sv  # rear axle, Eqs. (25)-(28)
        xv, yv = x_r + cv * self.vehicle_x - sv * self.vehicle_y, y_r + sv * self.vehicle_x + cv * self.vehicle_y
        return np.concatenate([xt, xv], axis=-1), np.concatenate([yt, yv], axis=-1)

    def margins(self, grid: DistanceGrid, states: np.ndarray, stop: float = -math.inf) -> tuple[np.ndarray, np.ndarray]:
        """Per motion (n, k + 1, 4), over samples 1..k and every point, from one look-up on ``grid``: the least
        sure clearance (the grid's distance less its error, the point's disc and half the bodies' movement to
        the next sample), and the least distance a point may have at most (the grid's distance and its error:
        half a diagonal to its cell's centre, the grid's distance to a blocked cell's centre, half a diagonal
        from there to the scene). A motion is surely clear by ``c`` when the first exceeds it; a body surely
        comes nearer than ``c`` when the second is below it. With ``stop``, only these two answers for ``c =
        stop`` are sure: a motion's look may end once both are known (the compiled check's, where most motions of a
        tight place are refused by their first samples)."""
        return self.least(grid, states[:, 1:, :], 0.5 * self.movement(states), stop)

    def least(
        self, grid: DistanceGrid, samples: np.ndarray, half: np.ndarray, stop: float = -math.inf
    ) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`margins` of configurations ``samples`` (n, k, 4), ``half`` (n, k) the half movement into each:
        compiled (``discs.c``) where it can be, else :meth:`least_numpy`, whose answers these are to the last bit
        (with ``stop``, the answers to the two questions for it)."""
        kernel = _kernel(jit_available(), os.environ.get("HITCHPARK_CACHE"))
        if kernel is None:
            return self.least_numpy(grid, samples, half)
        samples = np.ascontiguousarray(samples[..., :4], dtype=float)
        n, k = samples.shape[:2]
        yaw, turned = samples[..., 2], samples[..., 2] + samples[..., 3]
        trig = np.ascontiguousarray(np.stack([np.cos(yaw), np.sin(yaw), np.cos(turned), np.sin(turned)], axis=-1))
        half = np.ascontiguousarray(np.broadcast_to(half, (n, k)), dtype=float)
        sure, most = np.empty(n), np.empty(n)
        bordered = grid.bordered()
        lt, lh = self._lengths
        order, starts, vehicle, cx, cy, gt, gh, reach = self._groups
        kernel(
            n, k, samples.ctypes.data, trig.ctypes.data, half.ctypes.data,
            len(self.trailer_x), self.trailer_x.ctypes.data, self.trailer_y.ctypes.data,
            len(self.vehicle_x), self.vehicle_x.ctypes.data, self.vehicle_y.ctypes.data, lt.ctypes.data, lh.ctypes.data,
            self.radius.ctypes.data, bordered.ctypes.data, grid.shape[0], grid.shape[1],
            float(grid.origin[0]), float(grid.origin[1]), float(grid.cell), float(grid.error), float(stop),
            len(starts) - 1, order.ctypes.data, starts.ctypes.data, vehicle.ctypes.data, cx.ctypes.data,
            cy.ctypes.data, gt.ctypes.data, gh.ctypes.data, reach.ctypes.data, sure.ctypes.data, most.ctypes.data,
        )  # fmt: skip
        return sure, most

    def least_numpy(self, grid: DistanceGrid, samples: np.ndarray, half: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`least` in NumPy."""
        x, y = self.centres(samples)  # (n, k, points)
        distance = grid.lookup(x, y)
        sure = distance - grid.error - self.radius[None, None, :] - half[:, :, None]
        return sure.min(axis=(1, 2)), (distance + grid.error).min(axis=(1, 2))

    def movement(self, states: np.ndarray) -> np.ndarray:
        """Largest body-point movement [m] between consecutive samples along axis -2 of ``states`` (..., k, 4)."""
        delta = np.diff(states, axis=-2)
        shift = np.hypot(delta[..., 0], delta[..., 1])
        turn_t, turn_v = np.abs(delta[..., 2]), np.abs(delta[..., 2] + delta[..., 3])
        return shift + np.maximum(turn_t * self.reach_trailer, turn_t * self.reach_hitch + turn_v * self.reach_vehicle)


#: The compiled :meth:`Discs.least_numpy`.
DISCS_SOURCE = Path(__file__).with_name("discs.c")

_INT, _PTR, _REAL = ctypes.c_longlong, ctypes.c_void_p, ctypes.c_double

#: hp_disc_margins' arguments, in order (see ``discs.c``).
_DISC_ARGS = [_INT, _INT, _PTR, _PTR, _PTR, _INT, _PTR, _PTR, _INT, _PTR, _PTR, _PTR, _PTR, _PTR, _PTR]
_DISC_ARGS += [_INT, _INT, _REAL, _REAL, _REAL, _REAL, _REAL, _INT, _PTR, _PTR, _PTR, _PTR, _PTR]
_DISC_ARGS += [_PTR, _PTR, _PTR, _PTR, _PTR]


@functools.lru_cache(maxsize=8)
def _kernel(compiling: bool, cache: str | None) -> Any:
    """The compiled check, or None where nothing compiles (per compilation switch and cache folder)."""
    if not compiling:
        return None
    return source_function("discs", DISCS_SOURCE, "hp_disc_margins", _DISC_ARGS)


def prepare_discs() -> bool:
    """Compile (or load) the compiled check now, not inside a planner's clock; False where it does not compile
    (:meth:`Discs.least` then runs NumPy's)."""
    return _kernel(jit_available(), os.environ.get("HITCHPARK_CACHE")) is not None


def _segment(a: float, b: float) -> np.ndarray:
    """Points from ``a`` to ``b`` (both included) at most ``POINT_SPACING`` apart."""
    n = max(1, math.ceil(abs(b - a) / POINT_SPACING))
    return np.linspace(a, b, n + 1)


def _outline(back: float, front: float, half_width: float) -> tuple[np.ndarray, np.ndarray]:
    """Points around the rectangle [back, front] x [-half_width, half_width], at most ``POINT_SPACING`` apart."""
    along, across = _segment(back, front), _segment(-half_width, half_width)[1:-1]
    xs = np.concatenate([along, along, np.full(len(across), back), np.full(len(across), front)])
    ys = np.concatenate([np.full(len(along), -half_width), np.full(len(along), half_width), across, across])
    return xs, ys
