"""Hybrid A* over the trailer-axle pose and hitch angle, with primitives of the exact full model."""

from __future__ import annotations

import heapq
import math
import time
from collections.abc import Callable
from dataclasses import replace

import numpy as np

from ..control.pure_pursuit import forward_steer_limit
from ..model.collision import swept_clearance
from ..model.scene import Scene
from ..model.state import Pose, State, goal_frame_position, goal_frame_yaw
from ..model.vehicle import VehicleTrailer
from .endgame import EndGame, Landing, TreeLanding
from .grid import HolonomicHeuristic, Screen
from .heuristic import CostToGo, trailer_table
from .motion import PrimitiveBatch
from .nodes import Node, distance_to_goal, path_of, stuck_detail
from .opening import OPENING_FORWARD_M, opening
from .prepare import scene_bounds
from .raster import distance_grid
from .settings import NEAR_START_MARGIN_M, NEAR_START_STEP_M, START_MARGIN_M, Plan, PlannerSettings, arrived
from .tree import NEAR_M, TREE_MAX_M, GoalTree, cell_key

__all__ = ["Search"]

#: Cell of the holonomic heuristic's grid [m].
HEURISTIC_CELL_M = 0.25

#: Dubins shots are tried from the start and from every this many expanded nodes.
DUBINS_EVERY = 10


#: Cap on the nodes of one search (memory bound; ``max_expansions`` ends a search first).
MAX_NODES = 2_000_000


class Search:
    def __init__(
        self,
        vehicle: VehicleTrailer,
        start: State,
        goal: Pose,
        scene: Scene,
        settings: PlannerSettings,
        began: float,
        tree: GoalTree | None = None,
    ):
        self.vehicle, self.goal, self.scene, self.began = vehicle, goal, scene, began
        self.start = start.as_array()
        s = settings
        self.rate = vehicle.max_steer_rate
        self.hitch_limit = vehicle.max_hitch - s.hitch_margin
        self._set_limit(settings, settings.virtual_limit)
        opening_samples = round(OPENING_FORWARD_M / s.sample_step_m)
        self.opening_batch = PrimitiveBatch(vehicle, OPENING_FORWARD_M, opening_samples, s.steer_samples)
        self.bounds = scene_bounds(vehicle, goal, scene, s, self.start)
        self.grid = distance_grid(scene, self.bounds, s.collision_cell_m)
        self.screen = Screen(vehicle, scene, self.grid, s.min_clearance_m)
        self.holonomic: HolonomicHeuristic | None = None
        if not scene.is_empty:
            keep = vehicle.trailer_width / 2 + s.min_clearance_m
            self.holonomic = HolonomicHeuristic(
                self.grid, (goal.x, goal.y), keep, HEURISTIC_CELL_M, self.start[None, :2]
            )
        table = None
        if s.heuristic_radius_m > 0:
            table = trailer_table(s.heuristic_radius_m, 0.5, 72, 1.0, s.weight_forward, s.weight_reverse)
        self.tree = tree
        self._heuristic = CostToGo(goal, s, self.holonomic, table, tree)
        self.tried: set[tuple[int, ...]] = set()  # the sets of tree nodes shots were taken along
        self.expanded = 0
        self.closest: Node | None = None  # the expanded node nearest the goal (for a plan that finds nothing)
        self.exhausted = False  # set when the open set ran empty: nothing more at this resolution

    # --- set-up ------------------------------------------------------------------------------------------

    def _set_limit(self, settings: PlannerSettings, limit: float) -> None:
        """The primitives and end-games of ``settings`` with the virtual steer within +-``limit``."""
        s = self.settings = replace(settings, virtual_limit=limit)
        cap = forward_steer_limit(self.vehicle, length_tolerance=s.forward_length_tolerance)
        forward = np.linspace(-cap, cap, s.steer_samples)
        reverse = np.linspace(-limit, limit, s.steer_samples)
        self.commands = np.concatenate([forward, reverse])
        self._tan_commands = np.tan(self.commands)  # Eq. (45) of each node's start steer takes their tangents
        self.directions = np.concatenate([np.ones(s.steer_samples), -np.ones(s.steer_samples)])
        self.straight_back = s.steer_samples + int(np.argmin(np.abs(reverse)))  # the reverse command nearest 0
        self.batch = PrimitiveBatch(self.vehicle, s.primitive_length_m, s.samples, 2 * s.steer_samples)
        # one direction's commands
        self.half_batch = PrimitiveBatch(self.vehicle, s.primitive_length_m, s.samples, s.steer_samples)
        self.steer_samples_forward = forward
        self.endgame = EndGame(self.vehicle, self.goal, s) if s.shot_length_m else None

    def _openings(self, nodes: list[Node], h_start: float) -> int | None:
        """The opening (:mod:`.opening`) at ``virtual_limit``, then among obstacles at ``obstacle_virtual_limit``.

        The search that follows keeps ``virtual_limit`` (measured: the loading dock's opening and search
        find nothing in 3 s at 0.6 rad, the driveway's opening only at 0.6 rad).
        """
        s = self.settings
        found = opening(self, nodes, h_start)
        if found is not None or self.scene.is_empty or s.obstacle_virtual_limit <= s.virtual_limit:
            return found
        self._set_limit(s, s.obstacle_virtual_limit)
        try:
            return opening(self, nodes, h_start)
        finally:
            self._set_limit(s, s.virtual_limit)

    def _key(self, state: np.ndarray) -> tuple[int, int, int, int]:
        return cell_key(state, self.settings, self.vehicle.max_hitch)

    def _initial_steer(self, hitch: float) -> np.ndarray:
        """The steer each command sets at standstill: the front steer itself forward, Eq. (45) in reverse."""
        v = self.vehicle
        sn, c, t = math.sin(hitch), math.cos(hitch), self._tan_commands
        reverse = np.arctan(v.wheelbase / v.hitch_offset * (sn - c * t) / (c + sn * t))  # Eq. (45)
        return np.where(self.directions > 0, self.commands, np.minimum(np.maximum(reverse, -v.max_steer), v.max_steer))

    def _at_goal(self, states: np.ndarray) -> np.ndarray:
        gx, gy = goal_frame_position(self.goal, states[..., 0], states[..., 1])
        yaw = states[..., 2]
        return arrived(self.settings, gx, gy, lambda: goal_frame_yaw(self.goal, yaw), states[..., 3])

    def clear(self, states: np.ndarray) -> np.ndarray:
        """Per primitive (n, k+1, 4): True if samples 1..k keep clear (the fast approximation)."""
        if self.scene.is_empty:
            x_ok = (states[:, 1:, 0] > self.bounds[0]) & (states[:, 1:, 0] < self.bounds[2])
            y_ok = (states[:, 1:, 1] > self.bounds[1]) & (states[:, 1:, 1] < self.bounds[3])
            return np.all(x_ok & y_ok, axis=1)
        return self.screen.fast(states)

    # --- search ------------------------------------------------------------------------------------------

    def _done(self, status: str, detail: str, nodes: list[Node] | None = None, last: int = -1) -> Plan:
        path: dict[str, np.ndarray] = {}
        switches, length = 0, 0.0
        if nodes is not None:
            path = self._path(nodes, last)
            d = path["direction"]
            switches = int(np.count_nonzero(d[1:] != d[:-1]))
            length = float(path["s"][-1])
        return Plan(
            status=status,
            path=path,
            direction_switches=switches,
            length_m=length,
            planning_s=time.perf_counter() - self.began,
            expanded=self.expanded,
            detail=detail,
            closest=None if status == "found" or self.closest is None else self.closest.state[:4].copy(),
        )

    def run(self) -> Plan:
        s = self.settings
        scene_empty = self.scene.is_empty
        if not scene_empty:
            exact, _ = swept_clearance(self.vehicle, self.scene, self.start[None, :])
            if exact < s.min_clearance_m - s.start_slack_m:
                return self._done("no_path", f"the start keeps only {exact:.3g} m from the scene")
            if s.start_slack_m > 0.0 and exact < s.min_clearance_m + START_MARGIN_M:
                # Within the slack, or just clear: the path keeps what the start keeps, less the margin (any
                # turn away from a kerb the start stands by swings some body nearer it), checked finely.
                keep = max(min(s.min_clearance_m, exact - NEAR_START_MARGIN_M), s.min_clearance_m - s.start_slack_m)
                self.screen = Screen(self.vehicle, self.scene, self.grid, keep, NEAR_START_STEP_M)
            # Exactly (the fast check is conservative by a few decimetres, and a goal in a tight space is the point).
            at_goal, _ = swept_clearance(
                self.vehicle, self.scene, np.array([[self.goal.x, self.goal.y, self.goal.yaw, 0.0]])
            )
            if at_goal < s.min_clearance_m:
                return self._done(
                    "no_path", f"the goal is blocked: the bodies at the goal keep only {at_goal:.3g} m from the scene"
                )
            assert self.holonomic is not None
            if not np.isfinite(self.holonomic(self.start[:1], self.start[1:2])[0]):
                return self._done("no_path", "the goal cannot be reached from the start around the obstacles")
        if self._at_goal(self.start)[()]:
            nodes = [Node(self.start, 0.0, -1, 0.0, -1, np.zeros((0, 4)), np.zeros(0))]
            return self._done("found", "the start is within the goal tolerance", nodes, 0)
        nodes = [Node(self.start, 0.0, 0, 0.0, -1, np.zeros((0, 4)), np.zeros(0))]
        h_start = float(self._heuristic(self.start[None, :])[0])
        if time.perf_counter() - self.began > s.time_limit_s:  # the safety net (a tiny one, say)
            return self._done("planner_timeout", f"no path within the safety net of {s.time_limit_s:g} s")
        if self.endgame is not None:
            found = self._openings(nodes, h_start)
            if found is not None:
                return self._done("found", "within the goal tolerance (opening)", nodes, found)
        status, found = self.astar(nodes, h_start, budget=s.max_expansions)
        if status == "found":
            return self._done("found", "within the goal tolerance", nodes, found)
        if status == "planner_timeout":
            return self._done("planner_timeout", f"no path within the safety net of {s.time_limit_s:g} s")
        if status == "budget":
            spent = f"the search spent its budget of {s.max_expansions} expansions"
            return self._done("no_path", f"{spent}; {self._stuck(nodes)}")
        self.exhausted = True
        return self._done(
            "no_path",
            f"the search space is exhausted at a {s.xy_resolution_m:g} m grid: no path reaches the goal tolerance",
        )

    def astar(
        self,
        nodes: list[Node],
        h_start: float,
        budget: int,
        only: int = 0,
        heuristic: Callable[[np.ndarray], np.ndarray] | None = None,
    ) -> tuple[str, int]:
        """Hybrid A* from node 0: ("found", goal node), ("planner_timeout" | "budget" | "exhausted", -1).

        ``only``: 0, both directions; -1, reverse primitives only (the single reverse runs of the opening); 1,
        forward ones only (and the end-games, one reverse run). ``budget``: the most nodes this call expands, and
        the plan's :attr:`expanded` stays within ``max_expansions``. ``heuristic``: of end configurations (n, 4),
        the search's own if None.
        """
        s = self.settings
        # The forward primitives are the first half of the commands, the reverse ones the second.
        pick = slice(0, None) if only == 0 else slice(s.steer_samples, None) if only < 0 else slice(0, s.steer_samples)
        commands, dirs = self.commands[pick], self.directions[pick]
        batch = self.batch if only == 0 else self.half_batch
        estimate = self._heuristic if heuristic is None else heuristic
        heap: list[tuple[float, int]] = [(h_start, 0)]
        best_g: dict[tuple[int, int, int, int], float] = {self._key(self.start): 0.0}
        closed: set[tuple[int, int, int, int]] = set()
        expanded = 0
        while heap:
            if expanded >= budget or self.expanded >= s.max_expansions or len(nodes) > MAX_NODES:
                return "budget", -1
            if time.perf_counter() - self.began > s.time_limit_s:  # the safety net, never the budget
                return "planner_timeout", -1
            _, index = heapq.heappop(heap)
            node = nodes[index]
            key = self._key(node.state)
            if key in closed:
                continue
            closed.add(key)
            self.expanded += 1
            expanded += 1
            if self.closest is None or self._remaining(node) < self._remaining(self.closest):
                self.closest = node
            if self.endgame is not None and index > 0:
                found = self.land(nodes, index, dubins=expanded % DUBINS_EVERY == 0, max_length=s.shot_length_m)
                if found is not None:
                    return "found", found
            # Forward primitives hold a front steer, reverse ones a virtual steer (Eq. 45). The steer carries
            # on within a direction; at a change of direction (at standstill) it is set to what the command
            # asks at once.
            steer0 = self._initial_steer(float(node.state[3]))[pick]
            steer0[dirs == node.direction] = node.steer
            motions = batch.run(node.state, steer0, commands, dirs)
            ok = np.all(np.abs(motions[:, 1:, 3]) <= self.hitch_limit, axis=1) & np.all(
                np.isfinite(motions), axis=(1, 2)
            )
            fast = ok & self.clear(motions)
            # Where the fast check refuses every motion (a start near a wall, say), the exact check decides.
            ok = fast if fast.any() or self.scene.is_empty else self.screen.clear(motions[:, :, :4], ok)
            if not ok.any():
                continue
            candidates = np.flatnonzero(ok)
            steers = motions[candidates, :, 4]
            motions = motions[candidates, :, :4]
            arrived = self._at_goal(motions[:, 1:, :])
            trailer_steps = np.hypot(np.diff(motions[:, :, 0], axis=1), np.diff(motions[:, :, 1], axis=1))
            for hit in np.flatnonzero(arrived.any(axis=1)):
                k = int(np.argmax(arrived[hit])) + 1
                c = candidates[hit]
                goal_node = Node(motions[hit, k], float(steers[hit, k]), dirs[c], 0.0, index,
                                  motions[hit, 1 : k + 1], steers[hit, 1 : k + 1])  # fmt: skip
                nodes.append(goal_node)
                if self._confirmed(nodes, len(nodes) - 1):
                    return "found", len(nodes) - 1
            ends = motions[:, -1, :]
            h = estimate(ends)
            child_dirs = dirs[candidates]
            length = trailer_steps.sum(axis=1)
            g_all = node.g + length * np.where(child_dirs > 0, s.weight_forward, s.weight_reverse)
            g_all += length * (
                s.weight_steer * np.abs(steers[:, 1:]).mean(axis=1) + s.weight_hitch * np.abs(ends[:, 3])
            )
            g_all += s.weight_steer_change * np.abs(steers[:, -1] - steers[:, 0])
            if node.direction != 0:
                g_all += s.weight_switch * (child_dirs != node.direction)
            for row in range(len(candidates)):
                g = float(g_all[row])
                child_key = self._key(ends[row])
                if child_key in closed or best_g.get(child_key, math.inf) <= g:
                    continue
                best_g[child_key] = g
                d = int(child_dirs[row])
                nodes.append(Node(ends[row], float(steers[row, -1]), d, g, index, motions[row, 1:], steers[row, 1:]))
                heapq.heappush(heap, (g + float(h[row]), len(nodes) - 1))
        return "exhausted", -1

    def _remaining(self, node: Node) -> float:
        """How far ``node`` is from the goal (:func:`~.nodes.distance_to_goal`)."""
        return distance_to_goal(self.goal, node.state)

    def _stuck(self, nodes: list[Node]) -> str:
        """Where a search that found nothing got to: its node nearest the goal, and what is nearest to it."""
        node = self.closest if self.closest is not None else nodes[0]
        return stuck_detail(self.vehicle, self.scene, self.goal, node)

    def estimate(self, state: np.ndarray) -> float:
        """Length [m] of a single reverse run from ``state`` into the goal: by way of the goal tree where a node
        of it is near, else the shortest Dubins reference (:meth:`.endgame.EndGame.dubins_estimate`)."""
        assert self.endgame is not None
        by_tree = math.inf if self.tree is None else float(self.tree.estimate(state[None, :4])[0])
        return min(by_tree, self.endgame.dubins_estimate(state))

    def length(self, nodes: list[Node], last: int) -> float:
        """Trailer-axle length [m] of the path ending at node ``last``, and of the straight along the goal line
        from its end to the goal that follows it (a path to the goal line's far end is that much longer)."""
        assert self.endgame is not None
        remaining = max(self.endgame.in_goal_frame(nodes[last].state)[0], 0.0)
        return float(self._path(nodes, last)["s"][-1]) + remaining

    def land(self, nodes: list[Node], index: int, dubins: bool, max_length: float) -> int | None:
        """End-games from node ``index`` (:mod:`.endgame`); the new goal node's index if one lands clear.

        The landings are tried shortest (in samples) first; those longer than ``max_length`` (trailer axle) are
        passed over, except along the goal tree (its paths are as long as it holds them,
        :data:`~.tree.TREE_MAX_M`, and the pursuit's start within :data:`~.tree.NEAR_M` of them).
        """
        assert self.endgame is not None
        node = nodes[index]
        steer = node.steer
        if node.direction != -1:  # at standstill: the steer the run asks first (virtual steer 0 as a stand-in)
            steer = float(self._initial_steer(float(node.state[3]))[self.straight_back])
        landings = self.endgame.line_shots(node.state, steer)
        along_tree: list[TreeLanding] = []
        if self.tree is not None:
            along_tree = self.endgame.tree_shots(node.state, steer, self.tree, self.tried, self.screen)
        if dubins:
            takes, within = None, None
            if self.scene.is_empty:
                # Nothing but its length and the search's bounds decides whether a landing is taken here, so
                # the Dubins runs can stop once none still to come is shorter than one that is.
                def takes(landing: Landing) -> bool:
                    return not self._too_long(node, landing[0], max_length) and self._fast_clear(node, landing[0])

                within = min((len(landing[0]) for landing in landings if takes(landing)), default=None)
            screen = None if self.scene.is_empty else self.screen
            landings += self.endgame.dubins_shots(node.state, steer, max_length, takes, within, screen)
        # (landing, longest, how many of its first samples to screen: a tree path's keep clear by the tree's making)
        candidates = [(landing, max_length, len(landing[0])) for landing in landings]
        candidates += [((world, steers), TREE_MAX_M + 2 * NEAR_M, pursued + 1) for world, steers, pursued in along_tree]
        for (world, steers), limit, screened in sorted(candidates, key=lambda c: len(c[0][0])):
            if self._too_long(node, world, limit) or not self._landing_clear(node, world[:screened]):
                continue
            nodes.append(Node(world[-1], float(steers[-1]), -1, 0.0, index, world, steers))
            if self._confirmed(nodes, len(nodes) - 1):
                return len(nodes) - 1
        return None

    @staticmethod
    def _too_long(node: Node, world: np.ndarray, max_length: float) -> bool:
        """A landing's samples ``world`` from ``node`` run longer than ``max_length`` (trailer axle)."""
        xy = np.vstack([node.state[None, :2], world[:, :2]])
        return bool(np.hypot(*np.diff(xy, axis=0).T).sum() > max_length)

    def _fast_clear(self, node: Node, world: np.ndarray) -> bool:
        """A landing's samples ``world`` from ``node`` keep clear by the fast check (:meth:`_clear`)."""
        return bool(self.clear(np.vstack([node.state[None, :], world])[None])[0])

    def _landing_clear(self, node: Node, world: np.ndarray) -> bool:
        """A landing's samples ``world`` from ``node`` keep clear: by the fast check, or else exactly (among
        obstacles: the fast check's error, about 0.12 m, is more than a goal at a curb leaves;
        :class:`~.grid.Screen`)."""
        if self.scene.is_empty:
            return self._fast_clear(node, world)
        return bool(self.screen.clear(np.vstack([node.state[None, :4], world[:, :4]])[None])[0])

    def _confirmed(self, nodes: list[Node], last: int) -> bool:
        """The exact swept clearance of the path ending at node ``last`` keeps ``min_clearance_m`` (or what a start
        within ``start_slack_m`` of it keeps)."""
        if self.scene.is_empty:
            return True
        states = self._path(nodes, last)
        configs = np.column_stack([states[k] for k in ("x_trailer", "y_trailer", "yaw_trailer", "hitch")])
        bound, _ = swept_clearance(self.vehicle, self.scene, configs, self.screen.max_step_m)
        return bound >= self.screen.clearance

    def _path(self, nodes: list[Node], last: int) -> dict[str, np.ndarray]:
        return path_of(nodes, last, self.start, self.settings.primitive_length_m / self.settings.samples)
