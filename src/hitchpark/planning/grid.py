"""The planner's screen of motions against the scene, and its obstacle-aware heuristic.

**Screen.** The fast check of :mod:`.discs` on the distance grid of :mod:`.raster`, and for a motion it
cannot decide, the exact swept clearance.

**Heuristic.** The cost-to-go of the trailer axle on an 8-connected grid around the obstacles (Dijkstra
from the goal, :func:`scipy.sparse.csgraph.dijkstra`), over cells where the axle keeps half the trailer's
width and the clearance from the scene. It is also the quick ``no_path``: a start the goal cannot reach
on this grid has no path.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import sparse
from scipy.sparse import csgraph

from ..model.collision import MAX_STEP_M, swept_clearance
from ..model.scene import Scene
from ..model.vehicle import VehicleTrailer
from .discs import Discs
from .raster import DistanceGrid

__all__ = ["SKIM_EVERY", "HolonomicHeuristic", "Screen"]


#: :meth:`Screen.clear` looks at every this many samples of a long motion first: a body surely too near there
#: refuses it without the look at every sample.
SKIM_EVERY = 4


class Screen:
    """Which motions keep ``clearance`` from a scene: the fast check of :class:`Discs` on a :class:`DistanceGrid`,
    and, for a motion it refuses where the grid does not show a body surely too near, the exact swept
    clearance (the fast check's error, about 0.12 m, is more than a goal at a curb leaves), its sub-steps at most
    ``max_step_m`` (its bound low by at most half that)."""

    def __init__(
        self,
        vehicle: VehicleTrailer,
        scene: Scene,
        grid: DistanceGrid,
        clearance: float,
        max_step_m: float = MAX_STEP_M,
    ):
        self.vehicle, self.scene, self.grid, self.clearance = vehicle, scene, grid, clearance
        self.max_step_m = max_step_m
        self.discs = Discs(vehicle)

    def fast(self, motions: np.ndarray) -> np.ndarray:
        """Per motion (n, k + 1, 4): clear by the fast check alone (samples 1..k)."""
        return self.discs.margins(self.grid, motions, self.clearance)[0] > self.clearance

    def clear(self, motions: np.ndarray, asked: np.ndarray | None = None) -> np.ndarray:
        """Per motion (n, k + 1, 4): clear by the fast check, or else by the exact swept clearance (samples
        0..k) where the grid does not show a body surely too near; ``asked``: only these (the others False)."""
        ok, maybe = self.triage(motions, asked)
        for row in np.flatnonzero(maybe):
            ok[row] = self.exact(motions[row])
        return ok

    def triage(self, motions: np.ndarray, asked: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Per motion (n, k + 1, 4): clear by the fast check; and, of the rest, those the grid does not show a body
        surely too near (:meth:`exact` decides them). A motion padded with its last sample is judged as it is."""
        if asked is None:
            asked = np.ones(len(motions), dtype=bool)
        if motions.shape[1] > 4 * SKIM_EVERY:  # a long motion: first a look at every few samples for a body
            skim = self.discs.margins(self.grid, motions[:, ::SKIM_EVERY], self.clearance)[1]
            asked = asked & (skim >= self.clearance)
        sure, most = self.discs.margins(self.grid, motions, self.clearance)
        ok = (sure > self.clearance) & asked
        return ok, ~ok & (most >= self.clearance) & asked

    def blocked(self, states: np.ndarray) -> np.ndarray:
        """Per configuration (n, 4): a body surely nearer the scene than the clearance (the grid's distance and its
        error below it at some point); a motion through one is refused by :meth:`clear`."""
        most = self.discs.least(self.grid, states[:, None, :4], np.zeros((len(states), 1)), self.clearance)[1]
        return most < self.clearance

    def exact(self, motion: np.ndarray) -> bool:
        """Whether one motion (k + 1, 4) keeps the clearance by the exact swept clearance."""
        return bool(swept_clearance(self.vehicle, self.scene, motion[:, :4], self.max_step_m)[0] >= self.clearance)


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
