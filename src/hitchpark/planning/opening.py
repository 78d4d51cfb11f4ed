"""The opening of the planner: paths with at most one change of direction, tried before searching.

Most starts of the sweep's region in open space are parked by a single reverse run that bends (the
trailer steered by its virtual steer, Eqs. 42 and 45) or by pulling forward and then one: the end-games
of :mod:`.endgame` find them in tens of milliseconds where the search, greedy towards the goal, spends
hundreds of nodes and often settles for more changes of direction.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Protocol

import numpy as np

from ..model.scene import Scene
from .endgame import EndGame
from .motion import PrimitiveBatch
from .nodes import Node
from .settings import PlannerSettings
from .tree import GoalTree

__all__ = ["OPENING_FORWARD_M", "opening"]

#: The opening (before searching): single reverse runs up to this long are tried from the start [m].
OPENING_MAX_LENGTH_M = 60.0

#: The opening: the most nodes its search of reverse primitives expands.
OPENING_REVERSE_NODES = 150

#: The opening: how far the forward runs before a reverse one go [m] ...
OPENING_FORWARD_M = 9.0

#: ... every how many samples their ends are candidates ...
OPENING_STRIDE = 10

#: ... and how many of these are tried (the most promising first) ...
OPENING_TRIES = 4

#: ... of those that end with the hitch within this [rad] (a reverse run from a larger one folds it).
OPENING_MAX_HITCH = math.radians(20.0)

#: The opening among obstacles, when none of that lands: the most nodes its search of forward primitives
#: towards the goal tree expands.
OPENING_FORWARD_NODES = 300

OPENING_TREE_WEIGHT = 2.5


class Searcher(Protocol):
    """What the opening uses of a search (:class:`~.search.Search` has it)."""

    settings: PlannerSettings
    scene: Scene
    start: np.ndarray
    tree: GoalTree | None
    endgame: EndGame | None
    hitch_limit: float
    steer_samples_forward: np.ndarray
    opening_batch: PrimitiveBatch

    def estimate(self, state: np.ndarray) -> float: ...

    def clear(self, states: np.ndarray) -> np.ndarray: ...

    def length(self, nodes: list[Node], last: int) -> float: ...

    def land(self, nodes: list[Node], index: int, dubins: bool, max_length: float) -> int | None: ...

    def astar(
        self,
        nodes: list[Node],
        h_start: float,
        budget: int,
        only: int = 0,
        heuristic: Callable[[np.ndarray], np.ndarray] | None = None,
    ) -> tuple[str, int]: ...


def opening(search: Searcher, nodes: list[Node], h_start: float) -> int | None:
    """Before searching: a single reverse run from the start, or forward and then one (:mod:`.endgame`).

    The goal node's index in ``nodes`` of ``search`` (a :class:`~.search.Search`), or None: the cheapest
    in trailer-axle length plus ``weight_switch`` per change of direction of the end-games from the start,
    a search of reverse primitives only (:data:`OPENING_REVERSE_NODES` nodes at most), and forward and
    then a Dubins shot. An end-game from the start is taken at once when within ``weight_switch`` of the
    straight distance to the goal. Forward runs hold a front steer of the forward lattice for up to
    :data:`OPENING_FORWARD_M`; their ends are tried in the order of the forward length plus that of the
    shortest Dubins reference from there (and ``heuristic_hitch_m`` per radian of hitch), at most
    :data:`OPENING_TRIES` of them.
    """
    endgame = search.endgame
    assert endgame is not None
    s = search.settings
    distance = math.hypot(*endgame.in_goal_frame(search.start)[:2])
    direct = search.land(nodes, 0, dubins=True, max_length=OPENING_MAX_LENGTH_M)
    best, best_cost = None, math.inf
    if direct is not None:
        best, best_cost = direct, search.length(nodes, direct)
        if best_cost <= distance + s.weight_switch:
            return best
    if search.tree is None:  # (a goal tree holds the single reverse runs in already: its shots tried them)
        status, found = search.astar(nodes, h_start, budget=OPENING_REVERSE_NODES, only=-1)
        if status == "found" and search.length(nodes, found) < best_cost:
            best, best_cost = found, search.length(nodes, found)
    forward = search.steer_samples_forward
    motions = search.opening_batch.run(search.start, forward, forward, np.ones(len(forward)))
    candidates = []
    for arc in motions:
        ok = np.cumprod((np.abs(arc[1:, 3]) <= search.hitch_limit) & np.all(np.isfinite(arc[1:]), axis=1))
        trailer = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(arc[:, :2], axis=0).T))])
        for k in range(OPENING_STRIDE, len(arc), OPENING_STRIDE):
            if ok[k - 1] and abs(arc[k, 3]) <= OPENING_MAX_HITCH and search.clear(arc[None, : k + 1, :4])[0]:
                estimate_k = trailer[k] + search.estimate(arc[k])
                candidates.append((estimate_k + s.heuristic_hitch_m * abs(arc[k, 3]), arc[: k + 1]))
    candidates.sort(key=lambda c: c[0])
    for estimate_k, arc in candidates[:OPENING_TRIES]:
        if estimate_k + s.weight_switch >= best_cost:
            break
        nodes.append(Node(arc[-1, :4], float(arc[-1, 4]), 1, 0.0, 0, arc[1:, :4], arc[1:, 4]))
        landed = search.land(nodes, len(nodes) - 1, dubins=True, max_length=best_cost - s.weight_switch)
        if landed is not None:
            cost = search.length(nodes, landed) + s.weight_switch
            if cost < best_cost:
                best, best_cost = landed, cost
            break
    if best is None and search.tree is not None and not search.scene.is_empty:
        # Forward as far as it takes, then one reverse run: a search of forward primitives drawn to the goal
        # tree's nodes (their cost and the distance to them), landing by the end-games from every node.
        def to_tree(states: np.ndarray) -> np.ndarray:
            assert search.tree is not None
            return OPENING_TREE_WEIGHT * search.tree.estimate(states, within=math.inf)

        h = float(to_tree(search.start[None, :4])[0])
        status, found = search.astar(nodes, h, budget=OPENING_FORWARD_NODES, only=1, heuristic=to_tree)
        if status == "found":
            best = found
    return best
