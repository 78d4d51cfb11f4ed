"""The scene around a maneuver: obstacles to keep clear of and an area to stay inside, in the world frame.

A :class:`Scene` holds :class:`Obstacle` polygons (a parked car, a fence, a wall) and optionally an
:class:`Area` whose boundary the bodies must stay inside (the drivable ground). Coordinates are
metres in the world frame, the frame of the start and goal poses.

Every polygon is checked on construction: a list of at least 3 distinct ``[x, y]`` vertices, finite,
within +-``MAX_COORDINATE`` m, and a simple polygon (its edges do not cross or touch but at
consecutive vertices, and it encloses a non-zero area). Either orientation is accepted; a closing
vertex equal to the first is dropped. Shapely decides validity (:func:`shapely.is_valid`).

The vertices are kept as read-only ``(n, 2)`` NumPy float arrays. Arrays are neither hashable nor
comparable with ``==``, so :class:`Obstacle` and :class:`Area` define equality (same name, same
vertices in the same order) and a hash of their own: a :class:`Scene`, and so a scenario or a
maneuver result holding one, compares and hashes by value like the other frozen dataclasses.

Dictionary form (:meth:`Scene.to_dict`, :meth:`Scene.from_dict`; the ``[[obstacles]]`` and ``[area]``
tables of a scenario file, the ``obstacles`` and ``area`` keys of ``maneuver.json``)::

    {"obstacles": [{"name": "parked car", "polygon": [[x, y], [x, y], [x, y], ...]}, ...],
     "area": {"boundary": [[x, y], ...]}}       # "area": null or left out: no area
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely

from ..checks import MAX_COORDINATE, InputError, check_keys, check_text, check_values, shown

__all__ = ["MAX_OBSTACLES", "MAX_VERTICES", "Area", "Obstacle", "Scene", "check_polygon"]

#: Most vertices of one polygon: far more than any outline of a car, a fence or a car park needs.
MAX_VERTICES = 10_000

#: Most obstacles in a scene.
MAX_OBSTACLES = 10_000

#: Longest obstacle name (it labels the obstacle in figures and names it in messages).
MAX_NAME_LENGTH = 100


def check_polygon(what: str, value: Any) -> np.ndarray:
    """The vertices of a simple polygon as a read-only ``(n, 2)`` float array, or an :class:`InputError`.

    ``value`` is a list (or array) of ``[x, y]`` points [m]: at least 3 distinct ones, finite, within
    +-``MAX_COORDINATE``, forming a simple polygon of non-zero area, in either orientation. A last
    vertex equal to the first (a closed ring) is dropped. ``what`` names the field in messages.
    """
    if isinstance(value, str | bytes) or not isinstance(value, list | tuple | np.ndarray):
        raise InputError(f"{what} must be a list of [x, y] points, got {shown(value)}")
    if len(value) > MAX_VERTICES + 1:
        raise InputError(f"{what} must have at most {MAX_VERTICES} vertices, got {len(value)}")
    points = check_values(what, value, ndim=2, low=-MAX_COORDINATE, high=MAX_COORDINATE, unit="m")
    if points.shape[1] != 2:
        raise InputError(f"{what} must be a list of [x, y] points, got points of {points.shape[1]} numbers")
    if len(points) > 1 and np.array_equal(points[0], points[-1]):
        points = points[:-1]
    distinct = len(np.unique(points, axis=0))
    if distinct < 3:
        raise InputError(f"{what} must have at least 3 distinct vertices, got {distinct}")
    if not shapely.MultiPoint(points).convex_hull.area > 0.0:
        raise InputError(f"{what} must enclose a non-zero area, got vertices on one line")
    polygon = shapely.Polygon(points)
    if not shapely.is_valid(polygon):
        reason = shapely.is_valid_reason(polygon)
        raise InputError(f"{what} must be a simple polygon (edges that do not cross or touch), got {reason}")
    points = np.array(points, dtype=float)
    points.flags.writeable = False
    return points


def _named(what: str, name: str) -> str:
    """``what`` with the obstacle's name, as messages give it: ``obstacles[2] ("parked car")``."""
    return f'{what} ("{name}")' if name else what


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape == b.shape and bool(np.array_equal(a, b))


@dataclass(frozen=True, eq=False)
class Obstacle:
    """A polygon the bodies must keep clear of.

    Parameters
    ----------
    name : str
        What it is ("parked car", "fence"); may be empty. Labels the obstacle in figures and names
        it in messages; at most 100 characters.
    polygon : array_like, shape (n, 2)
        Its outline, ``[x, y]`` vertices in the world frame [m], see :func:`check_polygon`. Stored
        as a read-only float array without the closing vertex.
    """

    name: str
    polygon: np.ndarray

    def __post_init__(self) -> None:
        check_text("obstacle name", self.name, max_length=MAX_NAME_LENGTH)
        object.__setattr__(self, "polygon", check_polygon(_named("obstacle", self.name) + ".polygon", self.polygon))

    def to_dict(self) -> dict[str, Any]:
        return {"name": self.name, "polygon": self.polygon.tolist()}

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Obstacle):
            return NotImplemented
        return self.name == other.name and _same(self.polygon, other.polygon)

    def __hash__(self) -> int:
        return hash((self.name, self.polygon.shape, self.polygon.tobytes()))


@dataclass(frozen=True, eq=False)
class Area:
    """The ground the bodies must stay inside: a simple polygon ``boundary`` [m], world frame.

    ``boundary`` is checked as :func:`check_polygon` says and stored as a read-only ``(n, 2)`` float array.
    """

    boundary: np.ndarray

    def __post_init__(self) -> None:
        object.__setattr__(self, "boundary", check_polygon("area.boundary", self.boundary))

    def to_dict(self) -> dict[str, Any]:
        return {"boundary": self.boundary.tolist()}

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Area):
            return NotImplemented
        return _same(self.boundary, other.boundary)

    def __hash__(self) -> int:
        return hash((self.boundary.shape, self.boundary.tobytes()))


@dataclass(frozen=True)
class Scene:
    """Obstacles and an optional area, world frame. The default, ``Scene()``, is empty: nothing to hit.

    ``obstacles`` may be given as any sequence of :class:`Obstacle` and is stored as a tuple.
    """

    obstacles: tuple[Obstacle, ...] = ()
    area: Area | None = None

    def __post_init__(self) -> None:
        obstacles = self.obstacles
        if isinstance(obstacles, str | bytes) or not isinstance(obstacles, Sequence):
            raise InputError(f"obstacles must be a list of Obstacle, got {shown(obstacles)}")
        if len(obstacles) > MAX_OBSTACLES:
            raise InputError(f"obstacles must be at most {MAX_OBSTACLES}, got {len(obstacles)}")
        for i, obstacle in enumerate(obstacles):
            if not isinstance(obstacle, Obstacle):
                raise InputError(
                    f"obstacles[{i}] must be an Obstacle (hitchpark.model.scene.Obstacle(name, polygon)), "
                    f"got {shown(obstacle)}"
                )
        if self.area is not None and not isinstance(self.area, Area):
            hint = "hitchpark.model.scene.Area(boundary)"
            raise InputError(f"area must be an Area ({hint}) or None, got {shown(self.area)}")
        object.__setattr__(self, "obstacles", tuple(obstacles))

    @property
    def is_empty(self) -> bool:
        """True if there is nothing to keep clear of: no obstacle and no area."""
        return not self.obstacles and self.area is None

    def describe(self, index: int) -> str:
        """How messages name obstacle ``index``: ``obstacles[2] ("parked car")``."""
        return _named(f"obstacles[{index}]", self.obstacles[index].name)

    def to_dict(self) -> dict[str, Any]:
        """``{"obstacles": [{"name", "polygon"}, ...], "area": {"boundary"} or None}``, lists of ``[x, y]``."""
        return {
            "obstacles": [o.to_dict() for o in self.obstacles],
            "area": None if self.area is None else self.area.to_dict(),
        }

    @classmethod
    def from_dict(cls, data: Any) -> Scene:
        """From ``{"obstacles": [...], "area": {...}}`` (both optional; ``area`` may be None), checked strictly.

        Each obstacle is a table with ``polygon`` and an optional ``name`` (default empty); the area a
        table with ``boundary``. A refusal names the entry: ``obstacles[2] ("parked car").polygon``.
        """
        table = check_keys("scene", data, ("obstacles", "area"), "key {!r} of a scene")
        entries = table.get("obstacles", [])
        if not isinstance(entries, list | tuple):
            raise InputError(f"obstacles must be a list of obstacle tables, got {shown(entries)}")
        if len(entries) > MAX_OBSTACLES:
            raise InputError(f"obstacles must be at most {MAX_OBSTACLES}, got {len(entries)}")
        obstacles = []
        for i, entry in enumerate(entries):
            entry = check_keys(f"obstacles[{i}]", entry, ("name", "polygon"))
            name = check_text(f"obstacles[{i}].name", entry.get("name", ""), max_length=MAX_NAME_LENGTH)
            what = _named(f"obstacles[{i}]", name)
            if "polygon" not in entry:
                raise InputError(f"{what}.polygon is missing: an obstacle needs a polygon of [x, y] points")
            obstacles.append(Obstacle(name, check_polygon(f"{what}.polygon", entry["polygon"])))
        area = table.get("area")
        if area is not None:
            area_table = check_keys("area", area, ("boundary",))
            if "boundary" not in area_table:
                raise InputError("area.boundary is missing: an area needs a boundary of [x, y] points")
            area = Area(area_table["boundary"])
        return cls(tuple(obstacles), area)
