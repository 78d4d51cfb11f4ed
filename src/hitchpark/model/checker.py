"""The scene made ready for many clearance queries (:class:`SceneChecker`), the workhorse of
:mod:`.collision`: the exact distance of every body from every obstacle and from the area's boundary at many
configurations.

Compiled where a C compiler is (``distance.c``: the same distances in a few loops, the bounding boxes pruning,
equal to Shapely's to rounding); else Shapely 2 on arrays: the bodies of all configurations made at once
(:func:`shapely.polygons`, :func:`shapely.linestrings`, convex hulls over a length tolerance), the nearest
obstacle of each from an :class:`shapely.STRtree` query, the area from :func:`shapely.within` and
:func:`shapely.distance`.
"""

from __future__ import annotations

import ctypes
import functools
import math
import os
from pathlib import Path
from typing import Any

import numpy as np
import shapely

from ..native import jit_available, source_function
from .geometry import tolerant_corners
from .scene import Scene
from .vehicle import VehicleTrailer

__all__ = ["DISTANCE_SOURCE", "SceneChecker", "body_geometries", "prepare_distances"]

#: The compiled distances.
DISTANCE_SOURCE = Path(__file__).with_name("distance.c")

_INT, _PTR = ctypes.c_longlong, ctypes.c_void_p


@functools.lru_cache(maxsize=8)
def _kernel(compiling: bool, cache: str | None) -> Any:
    """The compiled distances, or None where nothing compiles (per compilation switch and cache folder)."""
    if not compiling:
        return None
    return source_function(
        "distance",
        DISTANCE_SOURCE,
        "hp_scene_clearances",
        [_INT, _INT, _PTR, _PTR, _PTR, _INT, _PTR, _PTR, _PTR, _INT, _PTR, _PTR],
    )


def prepare_distances() -> bool:
    """Compile (or load) the compiled distances now, not inside a tick or a planner's clock; False where they
    do not compile (Shapely's are used then)."""
    return _kernel(jit_available(), os.environ.get("HITCHPARK_CACHE")) is not None


class SceneChecker:
    """The scene made ready for many queries: its vertices for the compiled distances; for Shapely's, an STRtree
    of the obstacles, the area and its ring."""

    def __init__(self, vehicle: VehicleTrailer, scene: Scene):
        self.vehicle = vehicle
        polygons = [np.asarray(o.polygon, dtype=float) for o in scene.obstacles]
        self._starts = np.cumsum([0] + [len(p) for p in polygons], dtype=np.int64)
        self._vertices = np.ascontiguousarray(np.concatenate(polygons) if polygons else np.zeros((0, 2)))
        self._ring = np.ascontiguousarray(scene.area.boundary if scene.area is not None else np.zeros((0, 2)), float)
        self.obstacles = np.array([shapely.Polygon(o.polygon) for o in scene.obstacles], dtype=object)
        self.boxes = shapely.bounds(self.obstacles).reshape(-1, 4)  # xmin, ymin, xmax, ymax of each
        self.tree = shapely.STRtree(self.obstacles) if scene.obstacles else None
        self.area = shapely.Polygon(scene.area.boundary) if scene.area is not None else None
        if self.area is not None:
            shapely.prepare(self.area)
        self.ring = self.area.exterior if self.area is not None else None

    def clearances(self, configs: np.ndarray) -> np.ndarray:
        """Clearance [m] of each configuration, rows (x, y, yaw, hitch)."""
        compiled = self.compiled(configs)
        return self.clearances_shapely(configs) if compiled is None else compiled

    def compiled(self, configs: np.ndarray) -> np.ndarray | None:
        """:meth:`clearances` by the compiled distances; None where they do not compile."""
        kernel = _kernel(jit_available(), os.environ.get("HITCHPARK_CACHE"))
        if kernel is None:
            return None
        configs = np.asarray(configs, dtype=float).reshape(-1, 4)
        parts = tolerant_corners(self.vehicle, configs)
        hulls = self.vehicle.length_tolerance > 0.0
        kinds = [2 if hulls and name in ("vehicle", "tow_bar") else int(xy.shape[1] > 2) for name, xy in parts.items()]
        counts = np.array([xy.shape[1] for xy in parts.values()], dtype=np.int64)
        kind = np.array(kinds, dtype=np.intc)
        points = np.ascontiguousarray(np.concatenate(list(parts.values()), axis=1), dtype=float)
        out = np.empty(len(configs))
        boxes = np.ascontiguousarray(self.boxes, dtype=float)
        failed = kernel(
            len(configs), len(counts), kind.ctypes.data, counts.ctypes.data, points.ctypes.data,
            len(self._starts) - 1, self._starts.ctypes.data, self._vertices.ctypes.data, boxes.ctypes.data,
            len(self._ring), self._ring.ctypes.data, out.ctypes.data,
        )  # fmt: skip
        if failed:  # pragma: no cover (a body of more corners than the kernel holds: none is made so)
            raise ValueError(f"the compiled distances hold at most 16 points a body, got {counts.tolist()}")
        return out

    def clearances_shapely(self, configs: np.ndarray) -> np.ndarray:
        """:meth:`clearances` by Shapely."""
        bodies = body_geometries(self.vehicle, configs)  # (m, b)
        flat = bodies.ravel()
        nearest = np.full(len(flat), math.inf)
        if self.tree is not None:
            (which, _), distance = self.tree.query_nearest(flat, return_distance=True, all_matches=False)
            np.minimum.at(nearest, which, distance)
        if self.area is not None:
            inside = shapely.within(flat, self.area)
            nearest = np.minimum(nearest, np.where(inside, shapely.distance(flat, self.ring), 0.0))
        return nearest.reshape(bodies.shape).min(axis=1)

    def bounds(self, configs: np.ndarray, half: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """For a sweep: ``max(clearance - half, 0)`` and the clearance of each configuration, where it matters.

        Exact for every configuration whose bound could be the least of ``configs``; the others may come
        out larger (up to inf) than they are. Pruned by bounding boxes: a body's distance to an obstacle is
        computed only when the distance between their boxes, less the half step, does not exceed a bound
        already reached (the distance to the obstacle whose box is nearest, or the area's). Compiled, every
        configuration's is exact.
        """
        compiled = self.compiled(configs)
        if compiled is not None:
            return np.maximum(compiled - half, 0.0), compiled
        bodies = body_geometries(self.vehicle, configs)  # (m, b)
        flat = bodies.ravel()
        slack = np.repeat(half, bodies.shape[1])  # the half step of each body's configuration
        near = np.full(len(flat), math.inf)
        if self.area is not None:
            near = self._area_distances(flat)
        if len(self.obstacles):
            boxes = shapely.bounds(flat)
            gap_x = np.maximum(self.boxes[None, :, 0] - boxes[:, None, 2], boxes[:, None, 0] - self.boxes[None, :, 2])
            gap_y = np.maximum(self.boxes[None, :, 1] - boxes[:, None, 3], boxes[:, None, 1] - self.boxes[None, :, 3])
            low = np.hypot(np.maximum(gap_x, 0.0), np.maximum(gap_y, 0.0))  # (n, k) lower bounds
            first = np.argmin(low, axis=1)
            near = np.minimum(near, shapely.distance(flat, self.obstacles[first]))
            reached = max(float(np.min(near - slack)), 0.0)  # the least bound is at most this
            low[np.arange(len(flat)), first] = math.inf  # computed already
            body, obstacle = np.nonzero(low - slack[:, None] <= reached)
            if len(body):
                np.minimum.at(near, body, shapely.distance(flat[body], self.obstacles[obstacle]))
        exact = near.reshape(bodies.shape).min(axis=1)
        return np.maximum(exact - half, 0.0), exact

    def _area_distances(self, flat: np.ndarray) -> np.ndarray:
        """Distance of each body to the area's boundary, 0 if it is not wholly inside the area.

        A body clear of the boundary lies wholly inside or wholly outside: one of its points decides.
        """
        distance = shapely.distance(flat, self.ring)
        coords, index = shapely.get_coordinates(flat, return_index=True)
        x, y = coords[np.searchsorted(index, np.arange(len(flat)))].T
        return np.where(shapely.contains_xy(self.area, x, y), distance, 0.0)


def body_geometries(vehicle: VehicleTrailer, configs: np.ndarray) -> np.ndarray:
    """The bodies of :func:`body_shapes` for many configurations at once: an (m, b) array of geometries.

    With a ``length_tolerance``, each body is the region it covers over the lengths' range: the convex hull of
    the points of :func:`~.geometry.tolerant_corners`.
    """
    configs = np.asarray(configs, dtype=float).reshape(-1, 4)
    hulls = vehicle.length_tolerance > 0.0
    columns = []
    for name, xy in tolerant_corners(vehicle, configs).items():  # (m, k, 2) each
        if hulls and name in ("vehicle", "tow_bar"):
            m, k = xy.shape[:2]
            columns.append(
                shapely.convex_hull(shapely.multipoints(xy.reshape(-1, 2), indices=np.repeat(np.arange(m), k)))
            )
        elif xy.shape[1] > 2:
            columns.append(shapely.polygons(np.concatenate([xy, xy[:, :1]], 1)))
        else:
            columns.append(shapely.linestrings(xy))
    return np.stack(columns, axis=1)
