"""The scene rasterised for the planner: the distance of every cell from it.

**Distance grid.** The scene is rasterised on cells of ``cell`` metres: a cell is blocked when its centre
lies within half a cell diagonal of an obstacle or of the outside of the area, so every obstacle point
lies in a blocked cell. The Euclidean distance transform (:func:`scipy.ndimage.distance_transform_edt`)
of the free cells gives, at a point's cell, a distance that overestimates the true distance to the
scene by at most one cell diagonal; :meth:`~.discs.Discs.margins` subtracts that.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import shapely
from scipy import ndimage

from ..model.scene import Scene

__all__ = ["DistanceGrid", "distance_grid"]


class DistanceGrid:
    """Distance [m] from the scene on a grid of ``cell`` metres over ``bounds`` (xmin, ymin, xmax, ymax)."""

    def __init__(self, scene: Scene, bounds: tuple[float, float, float, float], cell: float):
        xmin, ymin, xmax, ymax = bounds
        self.cell = cell
        self._bordered: np.ndarray | None = None
        self.origin = np.array([xmin, ymin])
        self.shape = (max(1, math.ceil((xmax - xmin) / cell)), max(1, math.ceil((ymax - ymin) / cell)))
        self.error = cell * math.sqrt(2.0)  # the grid's distance exceeds the true one by at most this
        if scene.is_empty:  # all free: a read-only view of one number, not megabytes filled each plan
            self.distance = np.broadcast_to(np.inf, self.shape)
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
            self.distance = np.broadcast_to(np.inf, self.shape)
        self.distance.flags.writeable = False  # shared between plans (distance_grid)

    def bordered(self) -> np.ndarray:
        """The grid in a frame of -inf (a point off it reads the frame, no mask needed), C-contiguous."""
        if self._bordered is None:
            framed = np.pad(np.asarray(self.distance, dtype=float), 1, constant_values=-np.inf)
            self._bordered = np.ascontiguousarray(framed)
        return self._bordered

    def lookup(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Grid distance at world points; ``-inf`` outside the grid (out of bounds counts as blocked)."""
        bordered = self.bordered()
        nx, ny = self.shape
        i = np.floor((x - self.origin[0]) / self.cell)
        j = np.floor((y - self.origin[1]) / self.cell)
        # Off the grid by any amount (or not a number): the frame.
        i = np.where((i >= 0) & (i < nx), i + 1, 0).astype(np.intp)
        j = np.where((j >= 0) & (j < ny), j + 1, 0).astype(np.intp)
        return bordered[i, j]


@functools.lru_cache(maxsize=8)
def distance_grid(scene: Scene, bounds: tuple[float, float, float, float], cell: float) -> DistanceGrid:
    """:class:`DistanceGrid` of ``scene``, made once per scene, bounds and cell: a sweep over a scene with an area
    plans every case on the same grid (its bounds are the area's)."""
    return DistanceGrid(scene, bounds, cell)
