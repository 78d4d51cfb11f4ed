"""The goal tree: the single reverse runs into the goal, grown once per scene by driving out of it forward.

The model is driftless (Eqs. 19-24 are linear in the speed): a motion driven forward from the goal, read
backwards, is a reverse motion into it, with the same front steer at every point. Driving out of a
driveway, a bay or a dock is forward, where the combination is stable, so the tree grows as a driver
pulls out: from the goal (hitch and steer straight) forward primitives of a held front steer, rate-limited
(:class:`~hitchpark.planning.motion.PrimitiveBatch`), a uniform-cost search over the search's cells, every
motion screened by the fast check of :mod:`~hitchpark.planning.discs`. Each node's chain back to the goal,
read backwards, is a reverse run from the node into the goal: the tree holds every way in of a single
reverse run, up to :data:`TREE_MAX_M` of trailer-axle path and :data:`TREE_NODES` nodes (counts: the same
tree on any machine).

The forward steer is held within the cap of :func:`~hitchpark.control.pure_pursuit.forward_steer_limit`, as
the search's forward primitives, and at the goal it may be set at standstill (a run in may end with the
wheels turned).

The primitives branch a primitive apart: out of a narrow place whose way out turns between two branches (a
driveway's mouth onto a street, for a car longer than believed) the tree may hold nothing but its straight
trunk, or that and a branch that barely turns. A tree that never gets :data:`STUNTED_M` off the goal line is
grown again from straight trunks of a third and two thirds of a primitive, and the tree of the most nodes kept
(measured: ``driveway_fence`` with the lengths' 10% of doubt, 97 nodes none past the mouth, then 1,356 reaching
the street).

The search uses it two ways (:mod:`~hitchpark.planning.search`): *tree shots*, reverse runs from an
expanded node along the paths of the nearest tree nodes (pure pursuit of the trailer axle, as the Dubins
shots), and the tree's cost as the heuristic of the cells it holds. Built once per vehicle, goal, scene and
settings, kept in the process and on disk beside the compiled solvers.
"""

from __future__ import annotations

import functools
import hashlib
import heapq
import math
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from ..control.pure_pursuit import forward_steer_limit
from ..model.scene import Scene
from ..model.state import Pose, goal_frame_position
from ..model.vehicle import VehicleTrailer
from ..native import jit_available
from .cache import cached_arrays
from .grid import Screen
from .motion import PrimitiveBatch
from .raster import distance_grid
from .settings import PlannerSettings

__all__ = ["TREE_MAX_M", "TREE_NODES", "GoalTree", "cell_key", "goal_tree", "tree_cache_key"]

#: The most nodes the tree expands.
TREE_NODES = 6000

#: The tree holds runs of at most this much trailer-axle path [m].
TREE_MAX_M = 45.0

#: A tree none of whose nodes is farther than this from the goal line [m] never turned out of it (a car's width
#: and a bit: the trees of the shipped places that turn out get 3.1 m off it or more) ...
STUNTED_M = 2.5

#: ... and is grown again with its straight trunk out of the goal shifted by these fractions of a primitive.
TRUNK_SHIFTS = (1 / 3, 2 / 3)

#: Nodes expanded in one call of the compiled primitives (the lowest-cost first, all at once).
TREE_BATCH = 16

#: A tree shot pursues the paths of tree nodes within this distance of the node it starts from, in the
#: metric of :meth:`GoalTree.near` (metres of trailer axle, and metres per radian of heading and hitch).
NEAR_M = 2.5

#: ... weighing heading by this [m/rad] ...
NEAR_YAW_M = 3.0

#: ... and hitch by this [m/rad].
NEAR_HITCH_M = 2.0


def cell_key(state: np.ndarray, settings: PlannerSettings, max_hitch: float) -> tuple[int, int, int, int]:
    """The search's cell of a configuration (x, y, yaw, hitch): one node is kept per cell."""
    s = settings
    yaw_cell = 2 * math.pi / s.yaw_bins
    hitch_cell = 2 * max_hitch / s.hitch_bins
    return (
        math.floor(state[0] / s.xy_resolution_m),
        math.floor(state[1] / s.xy_resolution_m),
        math.floor((float(state[2]) % (2 * math.pi)) / yaw_cell) % s.yaw_bins,
        math.floor((state[3] + max_hitch) / hitch_cell),
    )


class GoalTree:
    """See the module text. ``states`` (n, 5): each node's (x, y, yaw, hitch, steer), node 0 the goal;
    ``parent`` (n,), ``cost`` (n,) [m of trailer-axle path to the goal], ``samples`` (n, k, 5): the motion from
    the parent to the node (forward, its last row the node); ``cells``: each cell's least cost."""

    def __init__(
        self,
        vehicle: VehicleTrailer,
        goal: Pose,
        scene: Scene,
        settings: PlannerSettings,
        bounds: tuple[float, float, float, float],
        arrays: dict[str, np.ndarray] | None = None,
    ):
        self.vehicle, self.goal, self.settings = vehicle, goal, settings
        if arrays is None:
            arrays = self._grown(vehicle, goal, scene, settings, bounds)
        self.states, self.parent = arrays["states"], arrays["parent"].astype(np.int64)
        self.cost, self.samples = arrays["cost"], arrays["samples"]
        self._index = cKDTree(self._features(self.states[:, :4]))
        self._places = cKDTree(self.states[:, :2])

    @property
    def arrays(self) -> dict[str, np.ndarray]:
        return {"states": self.states, "parent": self.parent, "cost": self.cost, "samples": self.samples}

    @classmethod
    def _grown(
        cls,
        vehicle: VehicleTrailer,
        goal: Pose,
        scene: Scene,
        settings: PlannerSettings,
        bounds: tuple[float, float, float, float],
    ) -> dict[str, np.ndarray]:
        """The tree's arrays: grown from the goal; where that tree never leaves the goal line (every node within
        :data:`STUNTED_M` of it), grown again with its straight trunk out of the goal shifted by
        :data:`TRUNK_SHIFTS` of a primitive, and the tree of the most nodes kept (the goal's own on a tie).

        The trunk branches only every ``primitive_length_m``: where the way out of a narrow place turns within a
        few decimetres (a driveway's mouth onto a street), every branch may miss it, and the tree holds nothing
        but the trunk."""
        arrays = cls._grow(vehicle, goal, scene, settings, bounds)
        if not _stunted(arrays["states"], goal):
            return arrays
        for shift in TRUNK_SHIFTS:
            trunk = round(shift * settings.primitive_length_m / settings.sample_step_m) * settings.sample_step_m
            other = cls._grow(vehicle, goal, scene, settings, bounds, trunk)
            if len(other["states"]) > len(arrays["states"]):
                arrays = other
        return arrays

    @staticmethod
    def _grow(
        vehicle: VehicleTrailer,
        goal: Pose,
        scene: Scene,
        settings: PlannerSettings,
        bounds: tuple[float, float, float, float],
        trunk: float = 0.0,
    ) -> dict[str, np.ndarray]:
        """The tree's arrays (see the class): a uniform-cost search on the cells of ``settings`` from the goal;
        ``trunk`` > 0: from the end of a straight of that length out of the goal instead (node 1, its motion the
        straight's samples, the rows before them nan)."""
        s = settings
        screen = Screen(vehicle, scene, distance_grid(scene, bounds, s.collision_cell_m), s.min_clearance_m)
        hitch_limit = vehicle.max_hitch - s.hitch_margin
        cap = forward_steer_limit(vehicle, length_tolerance=s.forward_length_tolerance)
        commands = np.linspace(-cap, cap, s.steer_samples)
        m = len(commands)
        batch = PrimitiveBatch(vehicle, s.primitive_length_m, s.samples, TREE_BATCH * m)
        root = np.array([goal.x, goal.y, goal.yaw, 0.0, 0.0])
        states, parents, costs = [root], [-1], [0.0]
        samples = [np.zeros((s.samples, 5))]
        heap: list[tuple[float, int]] = [(0.0, 0)]
        if trunk > 0.0:
            n = round(trunk / s.sample_step_m)
            along = s.sample_step_m * np.arange(1, n + 1)
            c, sn = math.cos(goal.yaw), math.sin(goal.yaw)
            straight = np.zeros((s.samples, 5))
            straight[: s.samples - n] = np.nan
            straight[s.samples - n :, 0], straight[s.samples - n :, 1] = goal.x + c * along, goal.y + sn * along
            straight[s.samples - n :, 2] = goal.yaw
            states.append(straight[-1].copy())
            parents.append(0)
            costs.append(float(along[-1]))
            samples.append(straight)
            heap = [(costs[1], 1)]
            if not screen.clear(np.vstack([root, straight[s.samples - n :]])[None, :, :4])[0]:
                heap = []  # the straight does not keep clear: the goal alone
                states, parents, costs, samples = states[:1], parents[:1], costs[:1], samples[:1]
        best: dict[tuple[int, int, int, int], float] = {cell_key(states[-1], s, vehicle.max_hitch): costs[-1]}
        closed: set[tuple[int, int, int, int]] = set()
        expanded = 0
        while heap and expanded < TREE_NODES:
            picked: list[int] = []
            while heap and len(picked) < TREE_BATCH and expanded + len(picked) < TREE_NODES:
                _, index = heapq.heappop(heap)
                key = cell_key(states[index], s, vehicle.max_hitch)
                if key in closed:
                    continue
                closed.add(key)
                picked.append(index)
            if not picked:
                break
            expanded += len(picked)
            starts = np.repeat(np.array([states[i][:4] for i in picked]), m, axis=0)
            steer0 = np.repeat([states[i][4] for i in picked], m)
            if picked[0] == 0:  # the goal: a run in may end with the wheels turned, straightened at standstill
                steer0[:m] = commands
            motions = batch.run_from(starts, steer0, np.tile(commands, len(picked)), np.ones(len(starts)))
            ok = np.all(np.abs(motions[:, 1:, 3]) <= hitch_limit, axis=1) & np.all(np.isfinite(motions), axis=(1, 2))
            ok = screen.clear(motions[:, :, :4], ok)
            steps = np.hypot(np.diff(motions[:, :, 0], axis=1), np.diff(motions[:, :, 1], axis=1)).sum(axis=1)
            change = np.abs(motions[:, -1, 4] - motions[:, 0, 4])
            for row in np.flatnonzero(ok):
                parent = picked[row // m]
                cost = costs[parent] + steps[row] + s.weight_steer_change * change[row]
                if cost > TREE_MAX_M:
                    continue
                end = motions[row, -1]
                key = cell_key(end, s, vehicle.max_hitch)
                if key in closed or best.get(key, math.inf) <= cost:
                    continue
                best[key] = cost
                states.append(end.copy())
                parents.append(parent)
                costs.append(cost)
                samples.append(motions[row, 1:].copy())
                heapq.heappush(heap, (cost, len(states) - 1))
        return {
            "states": np.array(states),
            "parent": np.array(parents),
            "cost": np.array(costs),
            "samples": np.array(samples),
        }

    def _features(self, states: np.ndarray) -> np.ndarray:
        """Points of the metric :meth:`near` measures in: x, y, heading and hitch scaled to metres."""
        yaw = states[:, 2]
        return np.column_stack(
            [
                states[:, 0],
                states[:, 1],
                NEAR_YAW_M * np.cos(yaw),
                NEAR_YAW_M * np.sin(yaw),
                NEAR_HITCH_M * states[:, 3],
            ]
        )

    def near(self, state: np.ndarray, count: int) -> np.ndarray:
        """Up to ``count`` tree nodes (not the goal) within :data:`NEAR_M` of ``state``, nearest first."""
        k = min(count + 1, len(self.states))
        distance, index = self._index.query(self._features(np.asarray(state, float)[None, :4])[0], k=k)
        distance, index = np.atleast_1d(distance), np.atleast_1d(index)
        keep = (distance <= NEAR_M) & (index > 0) & (index < len(self.states))
        return index[keep][:count]

    def estimate(self, states: np.ndarray, within: float = NEAR_M) -> np.ndarray:
        """Cost-to-go [m] of configurations (n, >=4) by way of the tree: the least, over the 4 tree nodes nearest
        within ``within`` (:data:`NEAR_M`; ``inf``: all), of a node's cost and its distance; ``inf`` where none is
        near."""
        k = min(4, len(self.states))
        distance, index = self._index.query(self._features(np.asarray(states, float)), k=k, distance_upper_bound=within)
        distance, index = distance.reshape(len(states), k), index.reshape(len(states), k)
        found = index < len(self.states)
        cost = np.where(found, self.cost[np.minimum(index, len(self.states) - 1)] + distance, np.inf)
        return cost.min(axis=1)

    def nearest_places(self, xy: np.ndarray, count: int) -> np.ndarray:
        """The ``count`` tree nodes nearest each point (n, 2) by position alone: indices (n, count)."""
        k = min(count, len(self.states))
        _, index = self._places.query(np.asarray(xy, dtype=float), k=k)
        return np.asarray(index).reshape(len(xy), k)

    def path(self, node: int) -> np.ndarray:
        """The reverse run from ``node`` into the goal: (x, y, yaw, hitch, steer) rows, the node's state first and
        the goal's last, :attr:`settings`' sample step apart (the tree's motions read backwards). The run arrives
        with the steer it drove the last sample with (the first motion out of the goal was steered at
        standstill): the goal's row carries that steer, not the root's."""
        parts = []
        i = node
        while i > 0:
            part = self.samples[i][::-1]
            parts.append(part[~np.isnan(part[:, 0])])  # (a shifted trunk's straight: fewer rows, nan before them)
            i = int(self.parent[i])
        goal = self.states[:1].copy()
        if len(parts):
            goal[0, 4] = parts[-1][-1, 4]
        parts.append(goal)
        return np.vstack(parts)


def _stunted(states: np.ndarray, goal: Pose) -> bool:
    """Whether no tree node is farther than :data:`STUNTED_M` from the goal line."""
    _, across = goal_frame_position(goal, states[:, 0], states[:, 1])
    return bool(np.abs(across).max() <= STUNTED_M)


def tree_cache_key(
    kind: str, vehicle: VehicleTrailer, goal: Pose, scene: Scene, settings: PlannerSettings, bounds: tuple[float, ...]
) -> str:
    """The cache name of a per-scene structure ``kind`` grown by this code from these."""
    obstacles = [(o.name, np.asarray(o.polygon).round(9).tolist()) for o in scene.obstacles]
    area = None if scene.area is None else np.asarray(scene.area.boundary).round(9).tolist()
    # Compiled primitives and CasADi's virtual machine agree to rounding, not to the bit: their trees apart.
    text = repr((kind, _code(), jit_available(), vehicle, goal, obstacles, area, settings, bounds))
    return hashlib.sha256(text.encode()).hexdigest()[:24]


@functools.cache
def _code() -> str:
    """A hash of the code a tree is grown by (the planner's and the model's modules, Python and C): a change to
    any, the collision checks' included, builds anew rather than load a tree another version grew."""
    digest = hashlib.sha256()
    for folder in (Path(__file__).parent, Path(__file__).parent.parent / "model"):
        for path in sorted(folder.glob("*.py")) + sorted(folder.glob("*.c")):
            digest.update(path.name.encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()


@functools.lru_cache(maxsize=8)
def goal_tree(
    vehicle: VehicleTrailer,
    goal: Pose,
    scene: Scene,
    settings: PlannerSettings,
    bounds: tuple[float, float, float, float],
) -> GoalTree:
    """The :class:`GoalTree` of these, built once: kept in the process and on disk (:mod:`.cache`)."""
    arrays = cached_arrays(
        f"planner-tree-{tree_cache_key('goal-tree', vehicle, goal, scene, settings, bounds)}",
        ("states", "parent", "cost", "samples"),
        lambda: GoalTree(vehicle, goal, scene, settings, bounds).arrays,
    )
    return GoalTree(vehicle, goal, scene, settings, bounds, arrays)
