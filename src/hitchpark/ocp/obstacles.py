"""Obstacles inside the full NMPC: separating lines that keep every body clear of the scene over the horizon.

The bodies are convex: the vehicle and trailer rectangles, the drawbar and the tow bar segments
(:func:`~hitchpark.model.geometry.body_corners`). The scene is cut into convex pieces
(:func:`convex_pieces`): each convex obstacle, the triangles of a non-convex one, and the triangles of
the ground outside the area (near it). A body keeps ``c`` from a convex piece when a line separates
them with ``c`` to spare: a unit normal ``n`` and a number ``h`` with ``n . q <= h`` at every vertex
``q`` of the piece and ``n . p >= h + c`` at every corner ``p`` of the body.

Each NMPC step fixes the lines from its warm start (the previous plan moved on by a sample): per
prediction step k = 1..N and body, one line for each of the ``planes`` pieces nearest to the body there
(within :data:`REACH_M`). Its normal is, of the outward normals of the piece's edges and the direction
of the nearest points, the one with the widest gap to the body both there and where the car is now (the
lesser of the two): the nearest points give the widest gap at step k, but a line through a corner,
turned towards where the warm start passes it, or an edge's line across the way the car came, would hold
the plan back from where it could safely be (behind the warm start along an obstacle), and a plan that
must go slower than its warm start would find no room. Where the warm start overlaps the piece, the edge
whose line it crosses least. Where no line leaves the gap both there and now (the body rounds the piece)
and the chosen one would cut a warm start that keeps the clearance there, that step takes its own line
(``keep_warm``: the warm start is the last plan, which kept its lines). ``h`` is the piece's
largest ``n . q``. The OCP then asks ``n . p_i(X_k) >= h + c`` of every corner ``p_i``: linear in the
corners, which are smooth in the state. A prediction that meets the lines keeps ``c`` from every piece
that has one, never less. These numbers are parameters of the NLP, so one compiled solver serves every
scene.

The parameters of a step are compiled C where it can be (``clearance_lines.c``, a body and a step at a time,
the same operations in the same order as the NumPy here, to the last bit: ``hitchpark export``'s package
carries that file), NumPy otherwise: over all steps, bodies and pieces at once, but for the distance and line
between each body and each edge of a piece, which is :mod:`.separating`'s. The constraint rows are CasADi.
"""

from __future__ import annotations

import ctypes
import functools
import math
import os
from pathlib import Path
from typing import Any

import numpy as np
import shapely

from ..model.geometry import body_corners, has_tow_bar
from ..model.scene import Scene
from ..model.state import Pose, to_goal_frame
from ..model.vehicle import VehicleTrailer
from ..native import jit_available, source_function
from .separating import SEPARATING_LINES_SOURCE, prepare_lines, separating_lines

__all__ = [
    "CLEARANCE_LINES_SOURCE",
    "CLEARANCE_PIECES_SOURCE",
    "REACH_M",
    "ClearanceConstraints",
    "convex_pieces",
    "prepare_clearance",
    "vehicle_shape",
]

#: Pieces of the scene farther than this from a body in the warm start get no line at that step [m]; a
#: plan moves far less from one step to the next.
REACH_M = 2.5

#: An unused slot: 0 . p - (-1) >= 0 always holds.
_UNUSED = (0.0, 0.0, -1.0)

#: The compiled :meth:`ClearanceConstraints.parameters` (it includes :data:`CLEARANCE_PIECES_SOURCE` and
#: :data:`.separating.SEPARATING_LINES_SOURCE`).
CLEARANCE_LINES_SOURCE = Path(__file__).with_name("clearance_lines.c")
#: Its measurements of one body and one piece (included by it).
CLEARANCE_PIECES_SOURCE = Path(__file__).with_name("clearance_pieces.c")

_INT, _PTR = ctypes.c_longlong, ctypes.c_void_p


@functools.lru_cache(maxsize=8)
def _kernel(compiling: bool, cache: str | None) -> Any:
    """The compiled parameters, or None where nothing compiles (per compilation switch and cache folder)."""
    if not compiling:
        return None
    argtypes = [_INT, _PTR, _INT, _PTR, _INT, _INT, _PTR, _PTR, _PTR, _PTR, _INT, ctypes.c_double, ctypes.c_int,
                ctypes.c_int, _PTR, _PTR]  # fmt: skip
    return source_function(
        "clearance_lines",
        CLEARANCE_LINES_SOURCE,
        "hp_clearance_lines",
        argtypes,
        (SEPARATING_LINES_SOURCE, CLEARANCE_PIECES_SOURCE),
    )


def prepare_clearance() -> bool:
    """Compile (or load) the compiled parameters now, not inside a tick or a planner's clock (and the lines they
    draw on); False where they do not compile (:meth:`ClearanceConstraints.parameters` then runs NumPy's)."""
    prepare_lines()
    return _kernel(jit_available(), os.environ.get("HITCHPARK_CACHE")) is not None


def vehicle_shape(vehicle: VehicleTrailer) -> np.ndarray:
    """The lengths ``clearance_lines.c`` draws the bodies with (:func:`~hitchpark.model.geometry.body_corners`'s):
    L_T, L_H, rear overhang, wheelbase + front overhang, vehicle width / 2, trailer rear, trailer front, trailer
    width / 2, and 1 where the tow bar sticks out behind the body."""
    v = vehicle
    return np.array(
        [v.trailer_length, v.hitch_offset, v.rear_overhang, v.wheelbase + v.front_overhang, v.vehicle_width / 2,
         v.trailer_rear, v.trailer_front, v.trailer_width / 2, float(has_tow_bar(v))]
    )  # fmt: skip


def _ccw(polygon: np.ndarray) -> np.ndarray:
    ring = np.asarray(polygon, dtype=float)
    b = np.roll(ring, -1, axis=0)
    twice_area = float(np.sum(ring[:, 0] * b[:, 1] - b[:, 0] * ring[:, 1]))
    return ring if twice_area > 0 else ring[::-1].copy()


def _triangles(geometry: shapely.Geometry) -> list[np.ndarray]:
    parts = shapely.get_parts(shapely.constrained_delaunay_triangles(geometry))
    return [np.asarray(t.exterior.coords, dtype=float)[:-1] for t in parts]


def convex_pieces(scene: Scene) -> list[np.ndarray]:
    """The scene as convex polygons, each ``(v, 2)`` counter-clockwise, world frame.

    Each convex obstacle is one piece, a non-convex one its constrained Delaunay triangles; outside the
    area, the ground within :data:`REACH_M` and more of its bounds is cut into triangles.
    """
    pieces = []
    for obstacle in scene.obstacles:
        polygon = shapely.Polygon(obstacle.polygon)
        if shapely.equals(polygon, shapely.convex_hull(polygon)):
            pieces.append(obstacle.polygon)
        else:
            pieces += _triangles(polygon)
    if scene.area is not None:
        area = shapely.Polygon(scene.area.boundary)
        ground = shapely.difference(shapely.box(*shapely.bounds(area.buffer(2.0 * REACH_M))), area)
        pieces += _triangles(ground)
    return [_ccw(p) for p in pieces]


def _padded(pieces: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Pieces as one ``(j, v, 2)`` array (each one's last vertex repeated) and the mask of their real edges.

    Edge i runs from vertex i to vertex i + 1 (the last to the first): the repeats add edges of zero length.
    """
    size = max(len(p) for p in pieces)
    out = np.stack([np.vstack([p, np.repeat(p[-1:], size - len(p), axis=0)]) for p in pieces])
    counts = np.array([len(p) for p in pieces])[:, None]
    edge = np.arange(size)[None, :]
    return out, (edge < counts - 1) | (edge == size - 1)


class ClearanceConstraints:
    """The scene's separating lines as NLP parameters and constraint rows (see the module text).

    ``planes``: lines per body and prediction step. The parameters of step k are, per body and line,
    ``(n_x, n_y, h + c)``, in the parking frame of the goal.
    """

    def __init__(self, vehicle: VehicleTrailer, planes: int):
        self.vehicle, self.planes = vehicle, int(planes)
        self.bodies = tuple(body_corners(vehicle, 0.0, 0.0, 0.0, 0.0))
        self.n_params = 3 * len(self.bodies) * self.planes  # per prediction step
        self._scene: Scene | None = None
        self._clearance = 0.0
        self._pieces: tuple[np.ndarray, np.ndarray] | None = None
        self._framed: tuple[Pose, np.ndarray, np.ndarray, np.ndarray] | None = None
        self._kernel_framed: tuple[Any, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] | None = None
        self._shape = vehicle_shape(vehicle)

    # -- CasADi: the rows of one prediction step --------------------------------------------------------

    def rows(self, x: Any, params: Any) -> tuple[list[Any], list[float], list[float]]:
        """``n . p_i(x) - (h + c) >= 0`` for every body corner and line; ``x`` the OCP state, ``params`` its step's."""
        corners = body_corners(self.vehicle, x[0], x[1], x[2], x[3])
        g: list[Any] = []
        i = 0
        for name in self.bodies:
            for _ in range(self.planes):
                nx, ny, offset = params[i], params[i + 1], params[i + 2]
                i += 3
                g += [nx * px + ny * py - offset for px, py in corners[name]]
        return g, [0.0] * len(g), [math.inf] * len(g)

    def least_slack(self, states: np.ndarray, params: np.ndarray) -> float:
        """The least row value ``n . p_i - (h + c)`` (NumPy) of X_1..X_N, ``states`` X_0..X_N, at ``params``."""
        states = np.asarray(states, dtype=float)[1:]
        lines = np.asarray(params, dtype=float).reshape(len(states), len(self.bodies), self.planes, 3)
        corners = body_corners(self.vehicle, *states[:, :4].T)
        least = math.inf
        for j, name in enumerate(self.bodies):
            for px, py in corners[name]:
                rows = lines[:, j, :, 0] * px[:, None] + lines[:, j, :, 1] * py[:, None] - lines[:, j, :, 2]
                least = min(least, float(rows.min()))
        return least

    # -- NumPy: the parameters of a step ----------------------------------------------------------------

    def use(self, scene: Scene, clearance_m: float) -> None:
        """Keep ``clearance_m`` from ``scene`` (world frame) from now on."""
        if scene != self._scene:
            pieces = convex_pieces(scene)
            self._scene, self._pieces, self._framed = scene, (_padded(pieces) if pieces else None), None
            prepare_clearance()  # compiled now, not inside a tick
        self._clearance = float(clearance_m)

    def _in_goal_frame(self, goal: Pose) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The pieces' vertices ``(j, v, 2)``, their edges' outward normals ``(j, v, 2)`` and real-edge mask."""
        assert self._pieces is not None
        if self._framed is None or self._framed[0] != goal:
            world, real = self._pieces
            x, y, _ = to_goal_frame(goal, world[..., 0], world[..., 1], np.zeros(world.shape[:2]))
            vertices = np.stack([x, y], -1)
            d = np.roll(vertices, -1, axis=1) - vertices
            length = np.hypot(d[..., 0], d[..., 1])
            with np.errstate(invalid="ignore", divide="ignore"):
                outward = np.stack([d[..., 1], -d[..., 0]], -1) / length[..., None]  # right of a CCW edge
            self._framed = (goal, vertices, np.where(real[..., None], outward, 0.0), real)
        return self._framed[1], self._framed[2], self._framed[3]

    def lines(
        self,
        points: np.ndarray,
        goal: Pose,
        anchor: np.ndarray | None = None,
        pieces: np.ndarray | None = None,
        reach: float | None = None,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Distance ``(k, j)`` from bodies ``(k, c, 2)`` (parking frame) to each piece, and the line each gets:
        normal ``(k, j, 2)`` and offset ``h`` ``(k, j)`` (see the module text). ``anchor``: each body where
        the car is now ``(k, c, 2)``; an edge's normal must leave the gap to it as well. ``pieces``: the
        indices of the pieces to look at (default: all). A segment body may come as ``(a, b, b, a)``.
        ``reach``: a body and a piece whose bounding boxes are farther apart get distance ``inf`` and no
        line worth having (none is measured: the lines of a step come from the pieces within reach)."""
        vertices, outward, real = self._in_goal_frame(goal)
        if pieces is not None:
            vertices, outward, real = vertices[pieces], outward[pieces], real[pieces]
        n_pieces, size = real.shape
        k = len(points)
        # Nearest points, over the real edges of every piece (or of the pieces within reach of each body).
        edges = np.stack([vertices, np.roll(vertices, -1, axis=1)], 2)  # (j, v, 2, 2)
        gaps = np.full((k, n_pieces, size), np.inf)
        normals = np.zeros((k, n_pieces, size, 2))
        if reach is None:
            gap, normal, _ = separating_lines(points, edges[real], outward[real])
            gaps[:, real] = gap
            normals[:, real] = normal
        else:
            low, high = points.min(axis=1), points.max(axis=1)  # (k, 2)
            apart = np.maximum(vertices.min(axis=1)[None] - high[:, None], low[:, None] - vertices.max(axis=1)[None])
            apart = np.maximum(apart, 0.0)  # (k, j, 2): the gap between the boxes along x and y
            body, piece = np.nonzero(np.hypot(apart[..., 0], apart[..., 1]) <= reach)
            if len(body):
                gap, normal, _ = separating_lines(points[body], edges[piece], outward[piece])  # (pairs, v)
                gaps[body, piece] = np.where(real[piece], gap, np.inf)
                normals[body, piece] = normal
        best = np.argmin(gaps, axis=2)  # the nearest edge of each piece
        distance = np.take_along_axis(gaps, best[..., None], 2)[..., 0]
        nearest = np.take_along_axis(normals, best[..., None, None], 2)[:, :, 0]
        # A body wholly inside a piece: its first corner left of every real edge.
        first = points[:, 0][:, None, None, :]  # (k, 1, 1, 2)
        side = np.sum((first - vertices[None]) * outward[None], -1)  # > 0: right of (outside) the edge
        inside = np.all((side < 0.0) | ~real[None], axis=2)
        overlap = inside | (distance <= 1e-9)
        distance = np.where(overlap, 0.0, distance)
        # Edge normals: the gap between body and piece along each, here and (the lesser) where the car is.
        reach = np.einsum("kcx,jvx->kcjv", points, outward).min(axis=1)  # (k, j, v)
        extent = np.einsum("jvx,jwx->jvw", outward, vertices).max(axis=2)  # (j, v)
        h_near = np.einsum("kjx,jvx->kjv", nearest, vertices).max(axis=2)  # (k, j)
        near_score = distance
        if anchor is not None:
            reach = np.minimum(reach, np.einsum("kcx,jvx->kcjv", anchor, outward).min(axis=1))
            near_score = np.minimum(near_score, np.einsum("kcx,kjx->kcj", anchor, nearest).min(axis=1) - h_near)
        margin = np.where(real[None], reach - extent[None], -np.inf)
        edge = np.argmax(margin, axis=2)  # (k, j)
        edge_score = np.take_along_axis(margin, edge[..., None], 2)[..., 0]
        take_edge = overlap | (edge_score >= near_score)
        n = np.where(take_edge[..., None], outward[np.arange(n_pieces)[None, :], edge], nearest)
        h = np.einsum("kjx,jvx->kjv", n, vertices).max(axis=2)
        return distance, n, h

    def parameters(self, goal: Pose, states: np.ndarray, anchored: bool = True, keep_warm: bool = False) -> np.ndarray:
        """The lines of each prediction step, flat (see :meth:`parameters_numpy`): compiled where it can be, the
        same to the last bit."""
        kernel = _kernel(jit_available(), os.environ.get("HITCHPARK_CACHE"))
        states = np.asarray(states, dtype=float)
        if kernel is None or self._pieces is None or states.ndim != 2 or states.shape[1] < 4 or len(states) < 2:
            return self.parameters_numpy(goal, states, anchored, keep_warm)
        states = np.ascontiguousarray(states)
        vertices, edges, outward, real = self._kernel_pieces(goal)
        n_steps = len(states) - 1
        out = np.empty(n_steps * self.n_params)
        scratch = np.empty((11 + vertices.shape[1]) * len(vertices))
        kernel(
            n_steps, states.ctypes.data, states.shape[1], self._shape.ctypes.data, len(vertices), vertices.shape[1],
            vertices.ctypes.data, edges.ctypes.data, outward.ctypes.data, real.ctypes.data, self.planes,
            self._clearance, int(anchored), int(keep_warm), scratch.ctypes.data, out.ctypes.data,
        )  # fmt: skip
        return out

    def _kernel_pieces(self, goal: Pose) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The pieces in the goal's frame as ``clearance_lines.c`` takes them: vertices, edges, outward normals and
        the real-edge mask as numbers, contiguous (cached with the frame)."""
        vertices, outward, real = self._in_goal_frame(goal)
        if self._kernel_framed is None or self._kernel_framed[0] is not self._framed:
            edges = np.stack([vertices, np.roll(vertices, -1, axis=1)], 2)
            v, e, o, r = (np.ascontiguousarray(a, dtype=float) for a in (vertices, edges, outward, real))
            self._kernel_framed = (self._framed, (v, e, o, r))
        return self._kernel_framed[1]

    def parameters_numpy(
        self, goal: Pose, states: np.ndarray, anchored: bool = True, keep_warm: bool = False
    ) -> np.ndarray:
        """The lines of each prediction step, flat: ``states`` are X_0..X_N of the warm start, parking frame.
        ``anchored``: an edge's line leaves the gap at X_0 too (see the module text); a planned path, far
        longer than a horizon, takes each line from its own step alone. ``keep_warm`` (anchored): the warm
        start is the last plan moved on, which kept its lines; where an anchored line would cut its body at
        a step that keeps the clearance from that piece, the body takes its own step's line there instead
        (measured on the driveway: anchored lines cut such a plan by up to 0.78 m and the solvers found the
        problem infeasible: four ticks of 250-470 ms). A cold guess, which may pass through a piece, keeps
        the anchored lines: the first steps must stay reachable from where the car is."""
        states = np.asarray(states, dtype=float)
        n_steps = len(states) - 1
        out = np.tile(np.array(_UNUSED), (n_steps, len(self.bodies), self.planes, 1))
        if self._pieces is None or not n_steps:
            return out.reshape(n_steps * self.n_params)
        corners = body_corners(self.vehicle, *states[:, :4].T)
        # Every body as four corners (a segment a-b as a, b, b, a), all bodies and steps at once.
        quads = []
        for name in self.bodies:
            points = [np.stack(p, -1) for p in corners[name]]
            quads.append(np.stack(points if len(points) == 4 else [*points, *points[::-1]], 1))  # (k + 1, 4, 2)
        bodies = np.stack(quads)  # (b, k + 1, 4, 2)
        # Only the pieces whose bounding boxes come within reach of the box around every body at every step.
        every = bodies.reshape(-1, 2)
        low, high = every.min(axis=0) - REACH_M, every.max(axis=0) + REACH_M
        vertices = self._in_goal_frame(goal)[0]
        pieces = np.flatnonzero(np.all((vertices.max(axis=1) >= low) & (vertices.min(axis=1) <= high), axis=1))
        if not len(pieces):
            return out.reshape(n_steps * self.n_params)
        n_bodies = len(self.bodies)
        anchors = np.repeat(bodies[:, :1], n_steps, axis=1).reshape(-1, 4, 2) if anchored else None
        placed = bodies[:, 1:].reshape(-1, 4, 2)  # every body at every step
        distance, n, h = self.lines(placed, goal, anchors, pieces, REACH_M)
        if anchors is not None and keep_warm:
            # An anchored line that cuts the warm start's body at a step where that body keeps the clearance
            # from the piece would shut out the warm start itself (rounding a piece, no line leaves the gap
            # both there and where the car is now): that body and step take the line of its own step.
            slack = np.einsum("kcx,kjx->kcj", placed, n).min(axis=1) - h - self._clearance  # (b k, j)
            cut = (slack < 0.0) & (distance >= self._clearance) & np.isfinite(distance)
            redo = np.flatnonzero(cut.any(axis=1))
            if len(redo):
                _, own_n, own_h = self.lines(placed[redo], goal, None, pieces, REACH_M)
                n[redo] = np.where(cut[redo][..., None], own_n, n[redo])
                h[redo] = np.where(cut[redo], own_h, h[redo])
        take = min(self.planes, len(pieces))
        nearest = np.argsort(distance, axis=1, kind="stable")[:, :take]  # (b k, take); ties in order, on any machine
        rows = np.arange(len(distance))[:, None]
        within = distance[rows, nearest] <= REACH_M
        chosen = np.concatenate([n[rows, nearest], (h[rows, nearest] + self._clearance)[..., None]], -1)
        chosen = np.where(within[..., None], chosen, np.array(_UNUSED)).reshape(n_bodies, n_steps, take, 3)
        out[:, :, :take] = chosen.transpose(1, 0, 2, 3)
        return out.reshape(n_steps * self.n_params)
