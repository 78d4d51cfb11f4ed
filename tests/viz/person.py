"""A scripted person who backs the bay scene's trailer into its space with the knob, as a driver would.

They look where the trailer should go (a path of its axle: back down the aisle, a quarter turn of 4 m radius,
straight into the bay) and turn the knob towards the curvature that brings the trailer onto it a few metres on
(pure pursuit of the trailer axle, the knob's curvature signed on the trailer's own heading as the assist reads
it). Like a person at the keys, they move the knob a few key presses (0.1 each) a look at most, and let go of the pedal
(Esc) once the trailer axle reaches the goal line's end.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

#: The quarter turn's end on the goal line [m] and its radius [m]: the bay's start (8.5, 6) is on its way in.
TURN_END_X, TURN_RADIUS = 4.5, 4.0

#: How far ahead along the path they look [m].
LOOK_AHEAD_M = 3.0

#: The knob's step per key press (the live page's arrow keys).
KEY_STEP = 0.1

#: The most key presses they make in one look (a tick of the car, or more when they look less often).
MAX_PRESSES = 3

#: They press Esc once the trailer axle is this far from the back of the bay's goal line [m].
STOP_AT_X = 0.05


def bay_path(start_y: float = 6.0) -> np.ndarray:
    """The trailer axle's path, in the order driven, 0.1 m apart (world frame of the bay scene)."""
    e, r = TURN_END_X, TURN_RADIUS
    down = [(e + r, y) for y in np.arange(start_y, r, -0.1)]
    turn = [(e + r * math.cos(a), r - r * math.sin(a)) for a in np.linspace(0.0, math.pi / 2, 200)]
    into = [(e - d, 0.0) for d in np.arange(0.1, e + 3.0, 0.1)]
    return np.array(down + turn + into)


class Person:
    """Knob and pedal from what they see: :meth:`look` each tick with the trailer's (x, y, yaw)."""

    def __init__(self, kappa_max: float, path: np.ndarray | None = None):
        self.kappa_max = kappa_max
        self.path = bay_path() if path is None else path
        self.knob = 0.0
        self._along = 0  # how far along the path they have come (index)

    def wanted(self, x: float, y: float, yaw: float) -> float:
        """The knob that turns the trailer onto the path :data:`LOOK_AHEAD_M` on."""
        p = self.path
        near = np.hypot(p[self._along : self._along + 80, 0] - x, p[self._along : self._along + 80, 1] - y)
        self._along += int(np.argmin(near))
        ahead = np.flatnonzero(np.hypot(p[self._along :, 0] - x, p[self._along :, 1] - y) >= LOOK_AHEAD_M)
        tx, ty = p[self._along + ahead[0]] if len(ahead) else p[-1]
        c, s = math.cos(yaw), math.sin(yaw)
        lx, ly = c * (tx - x) + s * (ty - y), -s * (tx - x) + c * (ty - y)  # in the trailer's frame
        kappa = 2.0 * ly / (lx * lx + ly * ly)  # the arc through the point, tangent to the trailer's axis
        return max(-1.0, min(1.0, kappa / self.kappa_max))

    def look(self, x: float, y: float, yaw: float) -> list[str]:
        """The keys they press this tick: ``Escape``, or up to :data:`MAX_PRESSES` of ``ArrowLeft`` or
        ``ArrowRight`` towards the knob they want (none when it is within half a step)."""
        if x <= STOP_AT_X:
            return ["Escape"]
        want = self.wanted(x, y, yaw)
        keys: list[str] = []
        while len(keys) < MAX_PRESSES and abs(want - self.knob) > KEY_STEP / 2:
            up = want > self.knob
            self.knob = max(-1.0, min(1.0, round(self.knob + (KEY_STEP if up else -KEY_STEP), 2)))
            keys.append("ArrowLeft" if up else "ArrowRight")
        return keys


def in_the_bay(result: Any) -> None:
    """Assert that a drive ended with the trailer in the bay's space: near the goal, along it, nothing touched."""
    x, y, yaw = (result.trajectory[k][-1] for k in ("x_trailer", "y_trailer", "yaw_trailer"))
    assert -0.5 <= x <= 0.3 and abs(y) <= 0.3 and abs(math.degrees(yaw)) <= 5.0, (x, y, math.degrees(yaw))
    assert not result.collision and result.min_clearance_m >= 0.2
    assert result.max_abs_hitch_deg < math.degrees(result.vehicle.max_hitch)
