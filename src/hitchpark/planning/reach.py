"""Whether a goal can be left at all: a flood out of it, forward and in reverse, on each of the search's grids.

A path into the goal, read backwards, drives out of it (the model is driftless, Eqs. 19-24). Where the goal
tree (:mod:`.tree`, the single reverse runs in) reaches no farther than :data:`REACH_CHECK_M` from the goal,
the goal may be closed in: too tight a place to turn out of at the planner's clearance. The flood tells: from
the goal (hitch straight, the wheels set at standstill) it drives every primitive out, forward with a held
front steer within ``max_steer`` (read backwards, a reverse run in) and in reverse with a held virtual steer
within ``obstacle_virtual_limit`` whose front steer keeps the forward cap (read backwards, a forward run the
tracker can steer), the hitch within its margin, every motion screened as the search screens its own
(:class:`~.grid.Screen`), one node a cell, as far as it goes. It is run on the search's grid and on each finer
one a search that exhausts its grid goes on to (:data:`~.settings.REFINEMENTS`), and stops at the first where
it is still spreading after :data:`REACH_NODES` expansions: such a goal is not closed, and nothing is said.

Where every grid's flood runs out first, the goal is *closed*: no search on those grids reaches a start outside
the cells the finest flood filled, at the planner's clearance (a count-bounded claim, as the search's own
"exhausted at a grid"). :func:`~.planner.plan` then answers ``no_path`` for such a start at once, with how far
the combination gets out, instead of spending the search's budget. Built once per vehicle, goal, scene and
settings, before the planning clock starts, kept in the process and on disk as the goal tree is.
"""

from __future__ import annotations

import functools
import heapq
import math
from dataclasses import dataclass

import numpy as np

from ..control.pure_pursuit import forward_steer_limit
from ..model.scene import Scene
from ..model.state import Pose
from ..model.vehicle import VehicleTrailer
from .cache import cached_arrays
from .grid import Screen
from .motion import PrimitiveBatch
from .raster import distance_grid
from .settings import REFINEMENTS, PlannerSettings, finer
from .tree import GoalTree, cell_key, tree_cache_key

__all__ = ["REACH_CHECK_M", "REACH_NODES", "GoalReach", "goal_reach", "needs_reach"]

#: The flood is run where the goal tree's farthest node is within this of the goal [m of trailer axle].
REACH_CHECK_M = 10.0

#: A flood still spreading after this many expansions on a grid: the goal is not closed.
REACH_NODES = 2000

#: Nodes expanded in one call of the compiled primitives.
REACH_BATCH = 8


@dataclass(frozen=True)
class GoalReach:
    """A flood's result (see the module text). ``closed``: every grid's flood ran out; ``states`` (n, 4): the
    configurations the last flood reached, the goal first (where closed, the finest grid's, whose cells
    :meth:`holds` looks in); ``expanded``: expansions over all grids."""

    states: np.ndarray
    closed: bool
    expanded: int
    settings: PlannerSettings
    max_hitch: float

    @functools.cached_property
    def _cells(self) -> frozenset[tuple[int, int, int, int]]:
        return frozenset(cell_key(state, self.settings, self.max_hitch) for state in self.states)

    def holds(self, state: np.ndarray) -> bool:
        """Whether ``state`` (x, y, yaw, hitch) is in a cell the flood filled."""
        return cell_key(np.asarray(state, dtype=float), self.settings, self.max_hitch) in self._cells

    def farthest(self, goal: Pose) -> np.ndarray:
        """The configuration reached farthest from the goal (trailer axle)."""
        return self.states[int(np.argmax(np.hypot(self.states[:, 0] - goal.x, self.states[:, 1] - goal.y)))]


def _flood(
    vehicle: VehicleTrailer,
    goal: Pose,
    screen: Screen,
    settings: PlannerSettings,
) -> tuple[np.ndarray, bool, int]:
    """One grid's flood: the configurations reached (n, 4), whether it ran out within :data:`REACH_NODES`, and
    its expansions."""
    s = settings
    hitch_limit = vehicle.max_hitch - s.hitch_margin
    in_forward_cap = forward_steer_limit(vehicle, length_tolerance=s.forward_length_tolerance)
    m = s.steer_samples
    commands = np.concatenate(
        [
            np.linspace(-vehicle.max_steer, vehicle.max_steer, m),
            np.linspace(-s.obstacle_virtual_limit, s.obstacle_virtual_limit, m),
        ]
    )
    directions = np.concatenate([np.ones(m), -np.ones(m)])
    batch = PrimitiveBatch(vehicle, s.primitive_length_m, s.samples, REACH_BATCH * 2 * m)
    # (x, y, yaw, hitch, steer, direction): node 0 the goal, its wheels set at standstill by the first motion
    states = [np.array([goal.x, goal.y, goal.yaw, 0.0, 0.0, 0.0])]
    costs = [0.0]
    best = {cell_key(states[0], s, vehicle.max_hitch): 0.0}
    closed: set[tuple[int, int, int, int]] = set()
    heap: list[tuple[float, int]] = [(0.0, 0)]
    expanded = 0
    while heap:
        if expanded >= REACH_NODES:
            return np.array(states)[:, :4], False, expanded
        picked: list[int] = []
        while heap and len(picked) < REACH_BATCH:
            _, index = heapq.heappop(heap)
            key = cell_key(states[index], s, vehicle.max_hitch)
            if key not in closed:
                closed.add(key)
                picked.append(index)
        if not picked:
            break
        expanded += len(picked)
        starts = np.repeat(np.array([states[i][:4] for i in picked]), 2 * m, axis=0)
        steer0 = np.concatenate(
            [
                # A motion on in its node's direction carries its steer; at a change of direction (at standstill),
                # the steer is what the command asks at once.
                np.where(
                    directions == states[i][5], states[i][4], batch.initial_steer(states[i][3], commands, directions)
                )
                for i in picked
            ]
        )
        motions = batch.run_from(starts, steer0, np.tile(commands, len(picked)), np.tile(directions, len(picked)))
        reverse = np.tile(directions, len(picked)) < 0
        ok = np.all(np.abs(motions[:, 1:, 3]) <= hitch_limit, axis=1) & np.all(np.isfinite(motions), axis=(1, 2))
        ok &= ~reverse | np.all(np.abs(motions[:, :, 4]) <= in_forward_cap, axis=1)
        ok = screen.clear(motions[:, :, :4], ok)
        steps = np.hypot(np.diff(motions[:, :, 0], axis=1), np.diff(motions[:, :, 1], axis=1)).sum(axis=1)
        for row in np.flatnonzero(ok):
            cost = costs[picked[row // (2 * m)]] + steps[row]
            end = motions[row, -1]
            key = cell_key(end, s, vehicle.max_hitch)
            if key in closed or best.get(key, math.inf) <= cost:
                continue
            best[key] = cost
            states.append(np.append(end, -1.0 if reverse[row] else 1.0))
            costs.append(cost)
            heapq.heappush(heap, (cost, len(states) - 1))
    return np.array(states)[:, :4], True, expanded


def _grids(settings: PlannerSettings) -> list[PlannerSettings]:
    """The search's grid and each finer one a search that exhausts its grid goes on to, coarsest first."""
    grids = [settings]
    for _ in range(REFINEMENTS):
        grids.append(finer(grids[-1]))
    return grids


def _grow(
    vehicle: VehicleTrailer,
    goal: Pose,
    scene: Scene,
    settings: PlannerSettings,
    bounds: tuple[float, float, float, float],
) -> dict[str, np.ndarray]:
    screen = Screen(vehicle, scene, distance_grid(scene, bounds, settings.collision_cell_m), settings.min_clearance_m)
    total = 0
    for grid in _grids(settings):
        states, ran_out, expanded = _flood(vehicle, goal, screen, grid)
        total += expanded
        if not ran_out:
            break
    return {"states": states, "closed": np.array(ran_out), "expanded": np.array(total)}


@functools.lru_cache(maxsize=8)
def goal_reach(
    vehicle: VehicleTrailer,
    goal: Pose,
    scene: Scene,
    settings: PlannerSettings,
    bounds: tuple[float, float, float, float],
) -> GoalReach:
    """The :class:`GoalReach` of these (``settings``: :func:`~.prepare.reach_settings`), built once: kept in the
    process and on disk (:mod:`.cache`)."""
    key = tree_cache_key("goal-reach", vehicle, goal, scene, settings, bounds)
    arrays = cached_arrays(
        f"planner-reach-{key}",
        ("states", "closed", "expanded"),
        lambda: _grow(vehicle, goal, scene, settings, bounds),
    )
    return GoalReach(
        states=arrays["states"],
        closed=bool(arrays["closed"]),
        expanded=int(arrays["expanded"]),
        settings=_grids(settings)[-1],
        max_hitch=vehicle.max_hitch,
    )


def needs_reach(tree: GoalTree) -> bool:
    """Whether the goal tree reaches so little of the scene that the flood is run (:data:`REACH_CHECK_M`)."""
    far = np.hypot(tree.states[:, 0] - tree.goal.x, tree.states[:, 1] - tree.goal.y)
    return bool(far.max() < REACH_CHECK_M)
