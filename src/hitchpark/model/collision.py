"""Exact clearance between the bodies and a :class:`~.scene.Scene`, at one configuration and along a motion.

The bodies are those of :func:`~.geometry.body_outlines`: the vehicle and trailer rectangles, the
drawbar (trailer body front to the hitch) and the tow bar (vehicle body rear to the hitch, when the
hitch lies behind the body). Distances are Shapely's, exact to rounding, between the bodies and each
obstacle polygon, and between the bodies and the area's boundary.

The clearance of a configuration is the smallest of these distances [m]: 0 when a body touches or
overlaps an obstacle, and 0 when a body is not wholly inside the area (touching its boundary or
outside it). A scene with no obstacle and no area has clearance ``math.inf`` everywhere.

Along a motion (:func:`swept_clearance`) the configuration between two recorded samples is taken
linear in (x, y, yaw, hitch); at dt = 0.1 s the kinematics hardly bend within a step. Each step is cut
into sub-steps so short that no point of any body moves more than ``max_step_m`` from one sub-sample
to the next; then any instant lies within half a sub-step of a sub-sample, so the clearance at any
instant is at least the clearance at the nearest sub-sample less half that sub-step's largest body
movement. :func:`swept_clearance` returns this lower bound, floored at 0: a motion that passes through
an obstacle between samples is caught, and a pass closer than half a sub-step (at most
``max_step_m / 2``) also counts as touching. The movement bound of a step: a point of the trailer
(body, drawbar) at distance ``r_t`` from the trailer axle moves at most ``|dc| + |dyaw| r_t``, a
point of the vehicle (body, tow bar) at distance ``r_v`` from the hitch at most
``|dc| + |dyaw| L_T + |dyaw + dhitch| r_v``, with ``dc`` the trailer-axle displacement and ``r_t``,
``r_v`` the largest such distances of the bodies.

The distances at many configurations are :class:`~.checker.SceneChecker`'s (compiled where it can be, else
Shapely's on arrays); the nearest pair of a :class:`Contact` is Shapely's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely

from ..checks import InputError, check_instance, check_number, check_range, check_values
from .checker import SceneChecker, body_geometries
from .geometry import body_corners, body_outlines, body_reaches, has_tow_bar
from .scene import Scene
from .state import wrap_angle
from .vehicle import VehicleTrailer, check_vehicle

__all__ = [
    "BODIES",
    "MAX_STEP_M",
    "Contact",
    "SceneChecker",
    "body_shapes",
    "clearance",
    "closest",
    "collides",
    "swept_clearance",
    "swept_contact",
]

#: The bodies checked, as :func:`body_shapes` names them.
BODIES = ("vehicle", "trailer", "drawbar", "tow_bar")

#: How messages name a body.
BODY_NAMES = {"vehicle": "the vehicle", "trailer": "the trailer", "drawbar": "the drawbar", "tow_bar": "the tow bar"}

#: Default largest movement of a body point between the sub-samples of :func:`swept_clearance` [m].
MAX_STEP_M = 0.05

#: Most sub-samples one call of :func:`swept_clearance` checks (a 10-minute maneuver at 1 m/s and
#: 5 cm sub-steps needs about 50 000): beyond it the states jump, they are not a motion.
MAX_SUBSAMPLES = 5_000_000

#: Sub-samples whose bodies are made and checked at once (bounds the memory of a call).
_CHUNK = 20_000


@dataclass(frozen=True)
class Contact:
    """The nearest pair of one configuration: which body, what (an obstacle or the area boundary), how far.

    ``distance`` [m] is the clearance (0 when touching, overlapping, or outside the area); ``body`` one of
    :data:`BODIES`; ``other`` names the obstacle as messages do (``obstacles[2] ("parked car")``) or is
    ``"area boundary"``; ``points`` is a (2, 2) array: the nearest point of the body, then of the other.
    """

    distance: float
    body: str
    other: str
    points: np.ndarray

    def describe(self) -> str:
        """One phrase: ``the trailer is 0.12 m from obstacles[1] ("fence")``, or that it touches or leaves."""
        body = BODY_NAMES[self.body]
        if self.other == "area boundary" and self.distance == 0.0:
            return f"{body} reaches or leaves the area boundary"
        if self.distance == 0.0:
            return f"{body} touches {self.other}"
        return f"{body} is {self.distance:.3g} m from {self.other}"


def body_shapes(vehicle: VehicleTrailer, state: Any) -> dict[str, shapely.Geometry]:
    """The bodies at ``state`` = (x_trailer [m], y_trailer [m], yaw_trailer [rad], hitch [rad]), world frame.

    ``"vehicle"`` and ``"trailer"``: Shapely polygons; ``"drawbar"`` and ``"tow_bar"``: line strings
    (the tow bar only when it has a length, i.e. the hitch lies behind the vehicle body). From
    :func:`~.geometry.body_outlines`; with a ``length_tolerance``, each over the lengths' range (convex hulls,
    the drawbar a line string still).
    """
    x, y, yaw, hitch = _config(state)
    if check_vehicle(vehicle).length_tolerance > 0.0:  # the bodies over the lengths' range
        names = body_corners(vehicle, x, y, yaw, hitch)
        return dict(zip(names, body_geometries(vehicle, np.array([[x, y, yaw, hitch]]))[0], strict=True))
    outlines = body_outlines(vehicle, x, y, yaw, hitch)
    shapes: dict[str, shapely.Geometry] = {
        "vehicle": shapely.Polygon(outlines["vehicle"]),
        "trailer": shapely.Polygon(outlines["trailer"]),
        "drawbar": shapely.LineString(outlines["drawbar"]),
    }
    if has_tow_bar(vehicle):
        shapes["tow_bar"] = shapely.LineString(outlines["tow_bar"])
    return shapes


def clearance(vehicle: VehicleTrailer, scene: Scene, x_t: Any, y_t: Any, yaw_t: Any, hitch: Any) -> float:
    """Smallest distance [m] from any body to any obstacle and to the area's boundary, at one configuration.

    0 if a body touches or overlaps an obstacle or is not wholly inside the area; ``math.inf`` for an
    empty scene. ``x_t``, ``y_t`` [m], ``yaw_t`` [rad]: the trailer-axle pose; ``hitch`` [rad].
    """
    vehicle, scene = _checked(vehicle, scene)
    config = np.array([_config((x_t, y_t, yaw_t, hitch))])
    return float(SceneChecker(vehicle, scene).clearances(config)[0])


def collides(vehicle: VehicleTrailer, scene: Scene, x_t: Any, y_t: Any, yaw_t: Any, hitch: Any) -> bool:
    """True if a body touches or overlaps an obstacle, or is not wholly inside the area (clearance 0)."""
    return clearance(vehicle, scene, x_t, y_t, yaw_t, hitch) == 0.0


def closest(vehicle: VehicleTrailer, scene: Scene, x_t: Any, y_t: Any, yaw_t: Any, hitch: Any) -> Contact | None:
    """The nearest body and obstacle (or area boundary) at one configuration; ``None`` for an empty scene.

    Its ``distance`` equals :func:`clearance`; a body outside the area has distance 0 to the boundary.
    """
    vehicle, scene = _checked(vehicle, scene)
    shapes = body_shapes(vehicle, (x_t, y_t, yaw_t, hitch))
    best: Contact | None = None
    for body, shape in shapes.items():
        candidates = [(scene.describe(i), shapely.Polygon(o.polygon)) for i, o in enumerate(scene.obstacles)]
        for other, geometry in candidates:
            distance = float(shapely.distance(shape, geometry))
            if best is None or distance < best.distance:
                best = Contact(distance, body, other, _nearest_points(shape, geometry))
        if scene.area is not None:
            area = shapely.Polygon(scene.area.boundary)
            distance = float(shapely.distance(shape, area.exterior)) if shapely.within(shape, area) else 0.0
            if best is None or distance < best.distance:
                best = Contact(distance, body, "area boundary", _nearest_points(shape, area.exterior))
    return best


def swept_clearance(
    vehicle: VehicleTrailer, scene: Scene, states: Any, max_step_m: float = MAX_STEP_M
) -> tuple[float, int]:
    """A lower bound on the clearance [m] over the continuous motion through ``states``, and where it is least.

    Parameters
    ----------
    vehicle : VehicleTrailer
        The lengths and bodies of the combination that moved (a plant's real car).
    scene : Scene
        Obstacles and area, world frame.
    states : array_like, shape (n, 4)
        The recorded configurations, rows (x_trailer [m], y_trailer [m], yaw_trailer [rad], hitch [rad]).
    max_step_m : float
        Largest movement of any body point between sub-samples [m], in (0, 10]. The bound returned is
        low by at most ``max_step_m / 2``.

    Returns
    -------
    (float, int)
        The bound, floored at 0 (so 0 also when a pass came within half a sub-step), ``math.inf`` for
        an empty scene; and the row of ``states`` that begins the step where it is least (``n - 1`` if
        it is the last state): of sub-samples with equal bounds (several zeros, say), the one with the
        least exact clearance, the first of those (so a collision's first touch, where there is one).
        See the module's description for the bound.
    """
    best, row, _ = _sweep(vehicle, scene, states, max_step_m)
    return best, row


def swept_contact(
    vehicle: VehicleTrailer, scene: Scene, states: Any, max_step_m: float = MAX_STEP_M
) -> tuple[float, int, Contact | None]:
    """:func:`swept_clearance`, and the nearest pair (:func:`closest`) at the sub-sample where the bound is least.

    The contact is ``None`` for an empty scene. Its distance is that sub-sample's exact clearance, which
    the bound undercuts by at most ``max_step_m / 2``.
    """
    best, row, config = _sweep(vehicle, scene, states, max_step_m)
    return best, row, None if config is None else closest(vehicle, scene, *config)


# --- internals ------------------------------------------------------------------------------------------


def _sweep(vehicle: Any, scene: Any, states: Any, max_step_m: Any) -> tuple[float, int, np.ndarray | None]:
    """The bound, its row and the sub-sample configuration where it is least (None for an empty scene)."""
    vehicle, scene = _checked(vehicle, scene)
    states = check_values("states", states, ndim=2)
    if states.shape[1] != 4 or len(states) < 1:
        raise InputError(f"states must be an (n, 4) array of x, y, yaw, hitch with n >= 1, got shape {states.shape}")
    max_step_m = check_range("max_step_m", max_step_m, 0.0, 10.0, low_open=True, unit="m")
    if scene.is_empty:
        return math.inf, 0, None
    configs, rows, half_steps = _subsamples(vehicle, states, max_step_m)
    checker = SceneChecker(vehicle, scene)
    best, best_exact, best_at, where = math.inf, math.inf, 0, configs[0]
    for first in range(0, len(configs), _CHUNK):
        part = slice(first, first + _CHUNK)
        bound, exact = checker.bounds(configs[part], half_steps[part])
        k = int(np.lexsort((exact, bound))[0])  # least bound; of equal bounds (zeros), the least exact clearance
        if (bound[k], exact[k]) < (best, best_exact):
            best, best_exact, best_at, where = float(bound[k]), float(exact[k]), int(rows[part][k]), configs[part][k]
    return best, best_at, where


def _checked(vehicle: Any, scene: Any) -> tuple[VehicleTrailer, Scene]:
    check_vehicle(vehicle)
    check_instance("scene", scene, Scene, "hitchpark.model.scene.Scene(obstacles, area)")
    return vehicle, scene


def _config(state: Any) -> tuple[float, float, float, float]:
    values = tuple(state)
    if len(values) != 4:
        raise InputError(f"a configuration must be x, y, yaw, hitch (4 numbers), got {len(values)}")
    x, y, yaw, hitch = (check_number(name, v) for name, v in zip(("x", "y", "yaw", "hitch"), values, strict=True))
    return x, y, yaw, hitch


def _nearest_points(a: shapely.Geometry, b: shapely.Geometry) -> np.ndarray:
    return np.asarray(shapely.get_coordinates(shapely.shortest_line(a, b)), dtype=float)


def _subsamples(
    vehicle: VehicleTrailer, states: np.ndarray, max_step_m: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Configurations along the motion, the row each belongs to, and the half sub-step to subtract there."""
    n = len(states)
    if n == 1:
        return states.copy(), np.zeros(1, dtype=int), np.zeros(1)
    delta = np.diff(states, axis=0)
    delta[:, 2:] = wrap_angle(delta[:, 2:])  # the short way round (a heading recorded wrapped)
    reach_t, hitch_reach, reach_v = body_reaches(vehicle)
    shift = np.hypot(delta[:, 0], delta[:, 1])
    turn_t, turn_v = np.abs(delta[:, 2]), np.abs(delta[:, 2] + delta[:, 3])
    moves = shift + np.maximum(turn_t * reach_t, turn_t * hitch_reach + turn_v * reach_v)
    counts = np.maximum(1, np.ceil(moves / max_step_m)).astype(np.int64)
    total = int(counts.sum()) + 1
    if total > MAX_SUBSAMPLES:
        raise InputError(
            f"states move too far between rows for max_step_m = {max_step_m:g} m: {total} sub-samples needed, "
            f"at most {MAX_SUBSAMPLES} checked"
        )
    half = moves / counts / 2
    rows = np.repeat(np.arange(n - 1), counts)
    starts = np.cumsum(counts) - counts
    fraction = (np.arange(total - 1) - starts[rows]) / counts[rows]
    configs = states[rows] + fraction[:, None] * delta[rows]
    half_steps = half[rows]
    # A recorded state belongs to the steps on both sides: the larger half step holds for it.
    before = np.concatenate([[0.0], half[:-1]])
    half_steps[starts] = np.maximum(half, before)
    configs = np.vstack([configs, states[-1:]])
    return configs, np.append(rows, n - 1), np.append(half_steps, half[-1])
