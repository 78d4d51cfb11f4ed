"""The nodes of the planner's search tree."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Node"]


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
