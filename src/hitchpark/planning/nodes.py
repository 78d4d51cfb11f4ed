"""The nodes of the planner's search tree, the path along a chain of them, and where a search got stuck."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..model.collision import closest
from ..model.scene import Scene
from ..model.state import Pose, to_goal_frame
from ..model.vehicle import VehicleTrailer

__all__ = ["Node", "distance_to_goal", "path_of", "stuck_detail"]


@dataclass
class Node:
    """A node of the search: the motion from its parent's end to its own (the start has none)."""

    state: np.ndarray  # (4,) end configuration
    steer: float  # front steer at the end
    direction: int  # +1 forward, -1 reverse, 0 for the start
    g: float
    parent: int
    samples: np.ndarray  # (k, 4) configurations after the parent's end, up to and including this one
    steers: np.ndarray  # (k,) front steer at those samples


def path_of(nodes: list[Node], last: int, start: np.ndarray, sample_dt: float) -> dict[str, np.ndarray]:
    """The path from ``start`` to node ``last`` through its parents: the columns of
    :data:`~.settings.PATH_COLUMNS` (``t`` at ``sample_dt`` a sample)."""
    chain = []
    i = last
    while i >= 0:
        chain.append(nodes[i])
        i = nodes[i].parent
    chain.reverse()
    parts = [c for c in chain[1:] if len(c.samples)]
    states = np.vstack([start[None, :]] + [c.samples for c in parts])
    first_direction = parts[0].direction if parts else -1
    first_steer = parts[0].steers[0] if parts else 0.0
    steer = np.concatenate([[first_steer]] + [c.steers for c in parts])
    direction = np.concatenate([[first_direction]] + [np.full(len(c.samples), c.direction) for c in parts])
    steps = np.hypot(np.diff(states[:, 0]), np.diff(states[:, 1]))
    return {
        "x_trailer": states[:, 0],
        "y_trailer": states[:, 1],
        "yaw_trailer": states[:, 2],
        "hitch": states[:, 3],
        "front_steer": steer,
        "direction": direction.astype(float),
        "s": np.concatenate([[0.0], np.cumsum(steps)]),
        "t": np.arange(len(states)) * sample_dt,
    }


def distance_to_goal(goal: Pose, state: np.ndarray) -> float:
    """How far a configuration is from the goal: its trailer-axle distance and 3 m per radian of heading."""
    gx, gy, gyaw = to_goal_frame(goal, float(state[0]), float(state[1]), float(state[2]))
    return math.hypot(gx, gy) + 3.0 * abs(gyaw)


def stuck_detail(vehicle: VehicleTrailer, scene: Scene, goal: Pose, node: Node) -> str:
    """Where a search got to (``node``, its nearest to the goal) and what of the scene is nearest to it there."""
    gx, gy, gyaw = to_goal_frame(goal, float(node.state[0]), float(node.state[1]), float(node.state[2]))
    where = (
        f"closest: trailer axle at ({node.state[0]:.2f}, {node.state[1]:.2f}) m, {math.hypot(gx, gy):.2f} m and "
        f"{math.degrees(abs(gyaw)):.0f} deg from the goal, hitch {math.degrees(node.state[3]):.0f} deg"
    )
    if scene.is_empty:
        return where
    contact = closest(vehicle, scene, *(float(v) for v in node.state[:4]))
    return where if contact is None else f"{where}; there {contact.describe()}"
