"""Non-holonomic heuristic without obstacles: cost-to-go of the trailer seen as a car, from a table.

The trailer axle moves like the rear axle of a car steered at the hitch (Eq. 42): along arcs whose
radius is bounded, forward and in reverse. The table holds, in the goal's parking frame, the shortest
such path to the goal from every cell of a grid in (x, y, heading): arcs of radius ``radius`` either way
and straight lines, ``step`` metres long, forward and in reverse, their ends snapped to the grid (Dijkstra,
:func:`scipy.sparse.csgraph.dijkstra`). It knows that a trailer beside the goal or facing away from it
has far to go where the Euclidean distance does not; it ignores the hitch (its own term in the search)
and the obstacles (the holonomic heuristic of :mod:`.grid`). Built once per set of parameters and cached
in the process and on disk (building takes about 1 s on this machine, loading a few ms).
"""

from __future__ import annotations

import functools
import hashlib
import math
from typing import TYPE_CHECKING

import numpy as np
from scipy import sparse
from scipy.sparse import csgraph

from ..model.state import Pose, to_goal_frame
from .cache import cached_arrays
from .settings import PlannerSettings

if TYPE_CHECKING:
    from .grid import HolonomicHeuristic
    from .tree import GoalTree

__all__ = ["VIA_TREE_NODES", "CostToGo", "TrailerTable", "trailer_table"]


class TrailerTable:
    """Cost-to-go [m] in the parking frame, on cells of ``cell`` m and ``yaw_bins`` headings over ``extent``."""

    def __init__(
        self,
        radius: float,
        cell: float,
        yaw_bins: int,
        extent: tuple[float, float, float, float],
        step: float,
        weight_forward: float,
        weight_reverse: float,
        cost: np.ndarray | None = None,
    ):
        xmin, ymin, xmax, ymax = extent
        self.cell, self.yaw_bins, self.origin = cell, yaw_bins, np.array([xmin, ymin])
        nx, ny = math.ceil((xmax - xmin) / cell), math.ceil((ymax - ymin) / cell)
        self.shape = (nx, ny, yaw_bins)
        if cost is not None and cost.shape == (nx * ny * yaw_bins,):
            self.cost = cost
            return
        i, j, k = np.meshgrid(np.arange(nx), np.arange(ny), np.arange(yaw_bins), indexing="ij")
        x = xmin + (i.ravel() + 0.5) * cell
        y = ymin + (j.ravel() + 0.5) * cell
        yaw = k.ravel() * 2 * math.pi / yaw_bins
        source = np.arange(nx * ny * yaw_bins)
        rows, cols, costs = [], [], []
        for direction, weight in ((1.0, weight_forward), (-1.0, weight_reverse)):
            arc = direction * step
            for curvature in (-1.0 / radius, 0.0, 1.0 / radius):
                if curvature == 0.0:
                    x1, y1, yaw1 = x + arc * np.cos(yaw), y + arc * np.sin(yaw), yaw
                else:
                    yaw1 = yaw + curvature * arc
                    x1 = x + (np.sin(yaw1) - np.sin(yaw)) / curvature
                    y1 = y - (np.cos(yaw1) - np.cos(yaw)) / curvature
                target = self.index(x1, y1, yaw1)
                keep = target >= 0
                rows.append(source[keep])
                cols.append(target[keep])
                costs.append(np.full(int(keep.sum()), weight * step))
        size = nx * ny * yaw_bins
        graph = sparse.csr_matrix(
            (np.concatenate(costs), (np.concatenate(rows), np.concatenate(cols))), shape=(size, size)
        )
        goal = int(self.index(np.array([0.0]), np.array([0.0]), np.array([0.0]))[0])
        # Cost from every cell to the goal: Dijkstra from the goal over the reversed edges.
        self.cost = csgraph.dijkstra(graph.T.tocsr(), directed=True, indices=goal)

    def index(self, x: np.ndarray, y: np.ndarray, yaw: np.ndarray) -> np.ndarray:
        """Flat cell index of parking-frame poses; -1 outside the table."""
        nx, ny, nk = self.shape
        i = np.floor((x - self.origin[0]) / self.cell).astype(np.int64)
        j = np.floor((y - self.origin[1]) / self.cell).astype(np.int64)
        k = np.round(np.asarray(yaw) / (2 * math.pi / nk)).astype(np.int64) % nk
        inside = (i >= 0) & (i < nx) & (j >= 0) & (j < ny)
        i, j = np.minimum(np.maximum(i, 0), nx - 1), np.minimum(np.maximum(j, 0), ny - 1)  # np.clip, cheaper
        return np.where(inside, (i * ny + j) * nk + k, -1)

    def __call__(self, x: np.ndarray, y: np.ndarray, yaw: np.ndarray) -> np.ndarray:
        """Cost-to-go [m] at parking-frame poses; ``nan`` outside the table."""
        flat = self.index(np.asarray(x), np.asarray(y), np.asarray(yaw))
        return np.where(flat >= 0, self.cost[np.maximum(flat, 0)], np.nan)


#: Where the table spans in the parking frame [m]: xmin, ymin, xmax, ymax.
EXTENT = (-12.0, -20.0, 28.0, 20.0)


@functools.lru_cache(maxsize=4)
def trailer_table(
    radius: float, cell: float, yaw_bins: int, step: float, weight_forward: float, weight_reverse: float
) -> TrailerTable:
    """The table for these parameters over :data:`EXTENT`, cached in the process and on disk.

    On disk beside the compiled solvers (:func:`~hitchpark.solvers.compiled.cache_dir`), keyed by the
    parameters; a cache that cannot be read or written is recomputed, never an error.
    """
    args = (radius, cell, yaw_bins, EXTENT, step, weight_forward, weight_reverse)
    key = hashlib.sha256(repr(("trailer-table-v1", *args)).encode()).hexdigest()[:20]
    arrays = cached_arrays(f"planner-table-{key}", ("cost",), lambda: {"cost": TrailerTable(*args).cost})
    return TrailerTable(*args, cost=arrays["cost"])  # (one of another shape is built again)


#: Away from the goal tree, the search's heuristic goes by way of this many of its nodes nearest in place.
VIA_TREE_NODES = 24


class CostToGo:
    """The search's heuristic [m], inflated by ``heuristic_weight``: the largest of the straight distance (around
    the obstacles, :class:`~.grid.HolonomicHeuristic`, where there are some) with ``heuristic_yaw_m`` per radian
    of heading, and the trailer's obstacle-free cost (:class:`TrailerTable`); ``heuristic_hitch_m`` per radian
    of hitch more. With a goal tree (:mod:`.tree`): the tree's cost where a node of it is near (a single reverse
    run in is known from there); elsewhere a change of direction more than the larger of that and the way by
    the tree's nodes nearest in place (the table's cost to a node's pose and the node's cost: the search is
    drawn to where a way in begins, heading as it does, not only towards the goal)."""

    def __init__(
        self,
        goal: Pose,
        settings: PlannerSettings,
        holonomic: HolonomicHeuristic | None,
        table: TrailerTable | None,
        tree: GoalTree | None,
    ):
        self.goal, self.settings, self.holonomic, self.table, self.tree = goal, settings, holonomic, table, tree

    def __call__(self, states: np.ndarray) -> np.ndarray:
        """Of configurations (n, 4)."""
        s = self.settings
        gx, gy, gyaw = to_goal_frame(self.goal, states[:, 0], states[:, 1], states[:, 2])
        distance = np.hypot(gx, gy)
        if self.holonomic is not None:
            distance = np.maximum(distance, self.holonomic(states[:, 0], states[:, 1]))
        h = distance + s.heuristic_yaw_m * np.abs(gyaw)
        if self.table is not None:
            h = np.fmax(h, self.table(gx, gy, gyaw))  # nan (off the table) leaves h
        h = h + s.heuristic_hitch_m * np.abs(states[:, 3])
        if self.tree is not None:
            by_tree = self.tree.estimate(states)
            far = np.maximum(h, self._via_tree(states)) + s.weight_switch
            h = np.where(np.isfinite(by_tree), by_tree, far)
        return np.asarray(s.heuristic_weight * h, dtype=float)

    def _via_tree(self, states: np.ndarray) -> np.ndarray:
        """Cost-to-go [m] by way of the tree's :data:`VIA_TREE_NODES` nodes nearest in place: a node's cost and
        the table's cost from the configuration to the node's pose (the node as its goal). 0 where there is no
        table or no node is on it (the other terms then decide)."""
        assert self.tree is not None
        if self.table is None:
            return np.zeros(len(states))
        index = self.tree.nearest_places(states[:, :2], VIA_TREE_NODES)  # (n, k)
        node = self.tree.states[index]  # (n, k, 5)
        c, sn = np.cos(node[..., 2]), np.sin(node[..., 2])
        dx, dy = states[:, None, 0] - node[..., 0], states[:, None, 1] - node[..., 1]
        to_node = self.table(c * dx + sn * dy, -sn * dx + c * dy, states[:, None, 2] - node[..., 2])
        total = np.where(np.isnan(to_node), np.inf, to_node + self.tree.cost[index])
        best = total.min(axis=1)
        return np.where(np.isfinite(best), best, 0.0)
