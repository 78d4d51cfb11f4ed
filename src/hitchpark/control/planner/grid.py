"""The fast collision approximation and the obstacle-aware heuristic of the planner.

**Distance grid.** The scene is rasterised on cells of ``cell`` metres: a cell is blocked when its centre
lies within half a cell diagonal of an obstacle or of the outside of the area, so every obstacle point
lies in a blocked cell. The Euclidean distance transform (:func:`scipy.ndimage.distance_transform_edt`)
of the free cells gives, at a point's cell, a distance that overestimates the true distance to the
scene by at most one cell diagonal; :meth:`DistanceGrid.clear` subtracts that.

**Discs.** Each body is covered by discs on its centre line: a rectangle of width ``w`` by ``n`` discs of
radius ``hypot(w / 2, l / (2 n))`` spaced ``l / n`` (``n`` so that the spacing is at most 0.8 m), the
drawbar and the tow bar by small discs along them. A configuration is clear when every disc's centre is
more than its radius, ``min_clearance_m`` and the grid's error from the scene; a motion sample, in
addition, by half the largest body movement to the next sample. Conservative: the exact check
(:func:`~hitchpark.model.collision.swept_clearance`) confirms the final path.

**Heuristic.** The cost-to-go of the trailer axle on an 8-connected grid around the obstacles (Dijkstra
from the goal, :func:`scipy.sparse.csgraph.dijkstra`), over cells where the axle keeps half the trailer's
width and the clearance from the scene. It is also the quick ``no_path``: a start the goal cannot reach
on this grid has no path.
"""

from __future__ import annotations

import math

import numpy as np
import shapely
from scipy import ndimage, sparse
from scipy.sparse import csgraph

from ...model.scene import Scene
from ...model.vehicle import VehicleTrailer

__all__ = ["Discs", "DistanceGrid", "HolonomicHeuristic"]

#: Largest spacing of the discs along a body [m].
DISC_SPACING = 0.8


class Discs:
    """Disc cover of the bodies: centres in body-fixed coordinates and radii."""

    def __init__(self, vehicle: VehicleTrailer):
        v = vehicle
        # Trailer discs: along the trailer axis, in the trailer frame (origin at its axle).
        t_local, t_radius = _cover(-v.trailer_rear, v.trailer_front, v.trailer_width)
        # Vehicle discs: along the vehicle axis, in the vehicle frame (origin at its rear axle).
        v_local, v_radius = _cover(-v.rear_overhang, v.wheelbase + v.front_overhang, v.vehicle_width)
        # Drawbar: trailer nose to hitch, on the trailer axis; tow bar: hitch to the vehicle bumper.
        draw = max(v.trailer_length - v.trailer_front, 1e-9)
        n_draw = max(1, math.ceil(draw / 0.2))
        d_local = v.trailer_front + (np.arange(n_draw) + 0.5) * draw / n_draw
        self.trailer_x = np.concatenate([t_local, d_local])
        self.trailer_r = np.concatenate([np.full(len(t_local), t_radius), np.full(n_draw, draw / n_draw / 2)])
        tow = max(v.hitch_offset - v.rear_overhang, 0.0)
        n_tow = max(1, math.ceil(tow / 0.2)) if tow > 0 else 0
        tow_local = -v.hitch_offset + (np.arange(n_tow) + 0.5) * tow / max(n_tow, 1)
        self.vehicle_x = np.concatenate([v_local, tow_local])
        self.vehicle_r = np.concatenate([np.full(len(v_local), v_radius), np.full(n_tow, tow / max(n_tow, 1) / 2)])
        self.radius = np.concatenate([self.trailer_r, self.vehicle_r])
        self.vehicle = vehicle
        # Largest distance of a body point from the trailer axle / from the hitch (movement bound).
        self.reach_trailer = max(
            math.hypot(max(v.trailer_rear, v.trailer_front), v.trailer_width / 2), v.trailer_length
        )
        self.reach_vehicle = math.hypot(v.hitch_offset + v.wheelbase + v.front_overhang, v.vehicle_width / 2)

    def centres(self, states: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """World x, y of every disc at ``states`` (..., 4): arrays of shape (..., discs)."""
        x, y, yaw, hitch = states[..., 0:1], states[..., 1:2], states[..., 2:3], states[..., 3:4]
        c, s = np.cos(yaw), np.sin(yaw)
        L_T, L_H = self.vehicle.trailer_length, self.vehicle.hitch_offset
        xt, yt = x + c * self.trailer_x, y + s * self.trailer_x
        yaw_v = yaw + hitch
        cv, sv = np.cos(yaw_v), np.sin(yaw_v)
        x_r, y_r = x + L_T * c + L_H * cv, y + L_T * s + L_H * sv  # rear axle, Eqs. (25)-(28)
        xv, yv = x_r + cv * self.vehicle_x, y_r + sv * self.vehicle_x
        return np.concatenate([xt, xv], axis=-1), np.concatenate([yt, yv], axis=-1)

    def movement(self, states: np.ndarray) -> np.ndarray:
        """Largest body-point movement [m] between consecutive samples along axis -2 of ``states`` (..., k, 4)."""
        delta = np.diff(states, axis=-2)
        shift = np.hypot(delta[..., 0], delta[..., 1])
        turn_t, turn_v = np.abs(delta[..., 2]), np.abs(delta[..., 2] + delta[..., 3])
        L_T = self.vehicle.trailer_length
        return shift + np.maximum(turn_t * self.reach_trailer, turn_t * L_T + turn_v * self.reach_vehicle)


def _cover(back: float, front: float, width: float) -> tuple[np.ndarray, float]:
    """Centres along [back, front] and the common radius of discs covering that rectangle of ``width``."""
    length = front - back
    n = max(1, math.ceil(length / DISC_SPACING))
    spacing = length / n
    return back + (np.arange(n) + 0.5) * spacing, math.hypot(width / 2, spacing / 2)


class DistanceGrid:
    """Distance [m] from the scene on a grid of ``cell`` metres over ``bounds`` (xmin, ymin, xmax, ymax)."""

    def __init__(self, scene: Scene, bounds: tuple[float, float, float, float], cell: float):
        xmin, ymin, xmax, ymax = bounds
        self.cell = cell
        self.origin = np.array([xmin, ymin])
        self.shape = (max(1, math.ceil((xmax - xmin) / cell)), max(1, math.ceil((ymax - ymin) / cell)))
        self.error = cell * math.sqrt(2.0)  # the grid's distance exceeds the true one by at most this
        if scene.is_empty:
            self.distance = np.full(self.shape, np.inf)
            return
        xs = xmin + (np.arange(self.shape[0]) + 0.5) * cell
        ys = ymin + (np.arange(self.shape[1]) + 0.5) * cell
        gx, gy = np.meshgrid(xs, ys, indexing="ij")
        half = cell * math.sqrt(2.0) / 2
        blocked = np.zeros(self.shape, dtype=bool)
        for obstacle in scene.obstacles:
            grown = shapely.Polygon(obstacle.polygon).buffer(half)
            blocked |= shapely.contains_xy(grown, gx, gy)
        if scene.area is not None:
            inner = shapely.Polygon(scene.area.boundary).buffer(-half)
            blocked |= ~shapely.contains_xy(inner, gx, gy)
        if blocked.any():
            self.distance = ndimage.distance_transform_edt(~blocked) * cell
        else:
            self.distance = np.full(self.shape, np.inf)

    def lookup(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Grid distance at world points; ``-inf`` outside the grid (out of bounds counts as blocked)."""
        i = np.floor((x - self.origin[0]) / self.cell).astype(np.int64)
        j = np.floor((y - self.origin[1]) / self.cell).astype(np.int64)
        inside = (i >= 0) & (i < self.shape[0]) & (j >= 0) & (j < self.shape[1])
        out = np.full(np.shape(x), -np.inf)
        out[inside] = self.distance[i[inside], j[inside]]
        return out

    def clear(self, x: np.ndarray, y: np.ndarray, need: np.ndarray) -> np.ndarray:
        """True where the true distance from the scene surely exceeds ``need`` (broadcast with x, y)."""
        return self.lookup(x, y) - self.error > need


class HolonomicHeuristic:
    """Shortest 8-connected distance [m] of the trailer axle to the goal around the obstacles."""

    def __init__(
        self, grid: DistanceGrid, goal_xy: tuple[float, float], keep: float, cell: float, also_free: np.ndarray
    ):
        factor = max(1, round(cell / grid.cell))
        self.cell = grid.cell * factor
        self.origin = grid.origin
        # A coarse cell is free when its sampled distance keeps the axle ``keep`` from the scene.
        coarse = grid.distance[factor // 2 :: factor, factor // 2 :: factor]
        free = coarse - grid.error >= keep - self.cell
        self.shape = coarse.shape
        # The goal's and the start's cells are free whatever the coarse sampling says: they are given.
        points = np.vstack(
            [np.asarray(goal_xy, dtype=float)[None, :], np.asarray(also_free, dtype=float).reshape(-1, 2)]
        )
        cells = self._index(points[:, 0], points[:, 1])
        free.flat[cells[cells >= 0]] = True
        nx, ny = self.shape
        index = np.arange(nx * ny).reshape(nx, ny)
        rows, cols, weights = [], [], []
        for di, dj in ((1, 0), (0, 1), (1, 1), (1, -1)):
            a = index[max(0, -di) : nx - max(0, di), max(0, -dj) : ny - max(0, dj)]
            b = index[max(0, di) : nx + min(0, di) or None, max(0, dj) : ny + min(0, dj) or None]
            ok = free.ravel()[a.ravel()] & free.ravel()[b.ravel()]
            rows.append(a.ravel()[ok])
            cols.append(b.ravel()[ok])
            weights.append(np.full(int(ok.sum()), self.cell * math.hypot(di, dj)))
        r, c, w = np.concatenate(rows), np.concatenate(cols), np.concatenate(weights)
        graph = sparse.csr_matrix((w, (r, c)), shape=(nx * ny, nx * ny))
        goal = self._index(np.array([goal_xy[0]]), np.array([goal_xy[1]]))[0]
        if goal < 0:
            self.cost = np.full(self.shape, np.inf)
        else:
            self.cost = csgraph.dijkstra(graph, directed=False, indices=int(goal)).reshape(self.shape)

    def _index(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        i = np.floor((x - self.origin[0]) / self.cell).astype(np.int64)
        j = np.floor((y - self.origin[1]) / self.cell).astype(np.int64)
        inside = (i >= 0) & (i < self.shape[0]) & (j >= 0) & (j < self.shape[1])
        return np.where(inside, np.clip(i, 0, self.shape[0] - 1) * self.shape[1] + np.clip(j, 0, self.shape[1] - 1), -1)

    def __call__(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Cost-to-go [m] at world points (``inf`` where the goal is out of reach or off the grid)."""
        k = self._index(np.atleast_1d(x), np.atleast_1d(y))
        return np.where(k >= 0, self.cost.ravel()[np.maximum(k, 0)], np.inf)
