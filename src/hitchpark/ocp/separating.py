"""The line separating a convex body from a segment of the scene, with its distance (the obstacle OCP's
geometry, :mod:`.obstacles`).

For each body (its corners) and each edge of a piece of the scene: the nearest pair of points over the
body's corners to the edge and the edge's ends to the body's edges, the unit normal from the edge towards
the body, and the offset of the edge's farthest end along it. Where they overlap, distance 0 and the
edge's free normal. Compiled C (``separating_lines.c``: the same operations in the same order as
:func:`separating_lines_numpy`, to the last bit), NumPy where nothing compiles.
"""

from __future__ import annotations

import ctypes
import functools
import os
from pathlib import Path
from typing import Any

import numpy as np

from ..native import jit_available, source_function

__all__ = ["SEPARATING_LINES_SOURCE", "prepare_lines", "separating_lines", "separating_lines_numpy"]

_INT, _PTR = ctypes.c_longlong, ctypes.c_void_p


def _cross(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]


def _nearest_on(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The point of segment a-b nearest to p (all broadcast, last axis xy)."""
    d = b - a
    t = np.sum((p - a) * d, -1) / np.maximum(np.sum(d * d, -1), 1e-300)
    return a + np.clip(t, 0.0, 1.0)[..., None] * d


#: The compiled :func:`separating_lines_numpy`.
SEPARATING_LINES_SOURCE = Path(__file__).with_name("separating_lines.c")


@functools.lru_cache(maxsize=8)
def _kernel(compiling: bool, cache: str | None) -> Any:
    """The compiled function, or None where nothing compiles (per compilation switch and cache folder)."""
    if not compiling:
        return None
    return source_function(
        "separating_lines",
        SEPARATING_LINES_SOURCE,
        "hp_separating_lines",
        [_INT, _INT, _PTR, _INT, _PTR, ctypes.c_int, _PTR, ctypes.c_int, _PTR, _PTR, _PTR],
    )


def prepare_lines() -> bool:
    """Compile (or load) the compiled lines now, not inside a tick or a planner's clock; False where they
    do not compile (:func:`separating_lines` then runs NumPy's)."""
    return _kernel(jit_available(), os.environ.get("HITCHPARK_CACHE")) is not None


def separating_lines(
    points: np.ndarray, ends: np.ndarray, free: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Distance, normal and offset of the line separating each convex body from each segment: see
    :func:`separating_lines_numpy`, whose answers these are to the last bit, compiled where it can be."""
    kernel = _kernel(jit_available(), os.environ.get("HITCHPARK_CACHE"))
    if kernel is None:
        return separating_lines_numpy(points, ends, free)
    points = np.ascontiguousarray(points, dtype=float)
    ends = np.ascontiguousarray(ends if np.ndim(ends) == 4 else np.asarray(ends)[None], dtype=float)
    free = np.ascontiguousarray(free if np.ndim(free) == 3 else np.asarray(free)[None], dtype=float)
    if points.ndim != 3 or points.shape[1] < 2 or points.shape[2] != 2:
        raise ValueError(f"bodies must be (k, c >= 2, 2), got {points.shape}")
    k, c, m = points.shape[0], points.shape[1], ends.shape[1]
    if (
        ends.shape[0] not in (1, k)
        or ends.shape[2:] != (2, 2)
        or free.shape[0] not in (1, k)
        or free.shape[1:] != (m, 2)
    ):
        raise ValueError(f"segments {ends.shape} and free normals {free.shape} do not fit {k} bodies")
    distance, n, h = np.empty((k, m)), np.empty((k, m, 2)), np.empty((k, m))
    kernel(
        k, c, points.ctypes.data, m, ends.ctypes.data, int(ends.shape[0] == k and k > 1),
        free.ctypes.data, int(free.shape[0] == k and k > 1), distance.ctypes.data, n.ctypes.data, h.ctypes.data,
    )  # fmt: skip
    return distance, n, h


def separating_lines_numpy(
    points: np.ndarray, ends: np.ndarray, free: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Distance, normal and offset of the line separating each convex body from each segment.

    ``points``: the bodies' corners ``(k, c, 2)`` (c = 2: a segment; c > 2: a convex polygon,
    counter-clockwise); ``ends``: segments ``(m, 2, 2)``, the same for every body, or ``(k, m, 2, 2)``, each
    body its own; ``free``: their normals to the free side ``(m, 2)`` or ``(k, m, 2)``.
    Returns ``distance (k, m)``, ``n (k, m, 2)`` (unit, from the segment towards the body) and
    ``h (k, m)`` = max over the segment's ends of ``n . q``; where a body overlaps a segment, distance 0
    and ``n`` the segment's free normal.
    """
    k, c = points.shape[:2]
    ends = ends if ends.ndim == 4 else ends[None]  # (k or 1, m, 2, 2)
    free = free if free.ndim == 3 else free[None]
    a, b = ends[:, None, :, 0], ends[:, None, :, 1]  # (k or 1, 1, m, 2)
    p = points[:, :, None, :]  # (k, c, 1, 2)
    # Corners to the segment.
    q = _nearest_on(p, a, b)  # (k, c, m, 2)
    gap = np.hypot(*np.moveaxis(p - q, -1, 0))
    # The segment's ends to the body's edges (a segment body: its one edge).
    starts = points if c > 2 else points[:, :1]
    stops = np.roll(points, -1, axis=1) if c > 2 else points[:, 1:]
    e0, e1 = starts[:, :, None, None, :], stops[:, :, None, None, :]  # (k, e, 1, 1, 2)
    tips = ends[:, None]  # (k or 1, 1, m, 2, 2)
    r = _nearest_on(tips, e0, e1)  # (k, e, m, 2, 2)
    tip_gap = np.hypot(*np.moveaxis(tips - r, -1, 0))  # (k, e, m, 2)
    # The nearest pair over both kinds.
    i_corner = np.argmin(gap, axis=1)  # (k, m)
    d_corner = np.take_along_axis(gap, i_corner[:, None], 1)[:, 0]
    flat = tip_gap.transpose(0, 2, 1, 3).reshape(k, -1, tip_gap.shape[1] * 2)  # (k, m, e*2)
    i_tip = np.argmin(flat, axis=2)
    d_tip = np.take_along_axis(flat, i_tip[..., None], 2)[..., 0]
    km = np.indices(i_corner.shape)
    body_pt = np.where(
        (d_corner <= d_tip)[..., None],
        points[km[0], i_corner],
        r.transpose(0, 2, 1, 3, 4).reshape(k, -1, tip_gap.shape[1] * 2, 2)[km[0], km[1], i_tip],
    )
    tip_pt = ends[km[0] if len(ends) > 1 else 0, km[1], i_tip % 2]
    scene_pt = np.where((d_corner <= d_tip)[..., None], q[km[0], i_corner, km[1]], tip_pt)
    distance = np.minimum(d_corner, d_tip)
    # Overlap: an edge of the body crosses the segment, or the segment lies inside the (polygon) body.
    s0, s1 = starts[:, :, None, :], stops[:, :, None, :]  # (k, e, 1, 2)
    o1 = _cross(b - a, s0 - a)  # (k, e, m)
    o2 = _cross(b - a, s1 - a)
    o3 = _cross(s1 - s0, a - s0)
    o4 = _cross(s1 - s0, b - s0)
    # Proper crossings only: where they touch (at an end, or collinear) some end lies on the other
    # segment, and the distance is 0 already.
    crossing = np.any((o1 * o2 < 0.0) & (o3 * o4 < 0.0), axis=1)  # (k, m)
    if c > 2:
        crossing |= np.all(o3 > 0.0, axis=1)  # the segment's first end inside: left of every edge
    overlap = crossing | (distance < 1e-9)
    with np.errstate(invalid="ignore", divide="ignore"):
        n = (body_pt - scene_pt) / distance[..., None]
    n = np.where(overlap[..., None], free, n)
    distance = np.where(overlap, 0.0, distance)
    h = np.maximum(np.sum(n * ends[:, :, 0], -1), np.sum(n * ends[:, :, 1], -1))
    return distance, n, h
