"""Drawing the plane: the car and trailer at a row, the parking space and goal, the paths, the obstacles.

The outlines themselves come from :mod:`hitchpark.model.geometry` (plain NumPy); this module
only turns them into matplotlib artists. Matplotlib is imported inside the functions.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import shapely

from ..model.collision import Contact
from ..model.geometry import along, body_outlines, parking_space, wheel_outlines
from ..model.scene import Scene
from ..model.vehicle import VehicleTrailer
from .common import (
    AREA_EDGE,
    LIMIT_COLOR,
    OBSTACLE_EDGE,
    OBSTACLE_FACE,
    SPACE_EDGE,
    SPACE_FACE,
    TRAILER_EDGE,
    TRAILER_FACE,
    VEHICLE_EDGE,
    VEHICLE_FACE,
    WHEEL_COLOR,
    Extent,
    clearance_text,
)

if TYPE_CHECKING:
    from matplotlib.axes import Axes

    from ..maneuver.result import ManeuverResult

__all__ = [
    "draw_contact",
    "draw_goal",
    "draw_paths",
    "draw_plans",
    "draw_rig",
    "draw_scene",
    "draw_swept",
    "near_scene",
    "rig_outlines",
    "swept_outlines",
    "swept_rows",
]

#: How far past the drawn motion the parts of obstacles and of the area boundary widen a panel [m].
SCENE_REACH = 3.0

#: Travel between two outlines of the swept bodies [m] (of whichever axle, the car's rear or the trailer's, moved more).
SWEPT_EVERY_M = 1.0

#: Style of the planned paths: thin, dashed, dark.
PLAN_COLOR = "#303030"
PLAN_STYLE: dict[str, Any] = {"color": PLAN_COLOR, "lw": 0.9, "ls": (0, (5, 3)), "alpha": 0.8}


def rig_outlines(result: ManeuverResult, row: int) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Body outlines and wheel outlines (front wheels at the row's front steer) of the rig at ``row``."""
    tr = result.trajectory
    args = (tr["x_trailer"][row], tr["y_trailer"][row], tr["yaw_trailer"][row], tr["hitch"][row])
    return body_outlines(result.vehicle, *args), wheel_outlines(result.vehicle, *args, tr["front_steer"][row])


def draw_rig(ax: Axes, result: ManeuverResult, row: int, bold: bool, zorder: float = 3) -> None:
    """Draw vehicle, trailer, drawbar and (bold only) wheels at ``row``."""
    from matplotlib.patches import Polygon

    bodies, wheels = rig_outlines(result, row)
    if bold:
        for w in wheels:
            ax.add_patch(Polygon(w, closed=True, fc=WHEEL_COLOR, ec="none", zorder=zorder))
        for key, face, edge in (
            ("vehicle", VEHICLE_FACE, VEHICLE_EDGE),
            ("trailer", TRAILER_FACE, TRAILER_EDGE),
        ):
            ax.add_patch(Polygon(bodies[key], closed=True, fc=face, ec=edge, lw=1.4, alpha=0.85, zorder=zorder + 0.1))
        lw, alpha = 1.8, 1.0
    else:
        for key, edge in (("vehicle", VEHICLE_EDGE), ("trailer", TRAILER_EDGE)):
            ax.add_patch(Polygon(bodies[key], closed=True, fill=False, ec=edge, lw=0.7, alpha=0.35, zorder=zorder))
        lw, alpha = 0.8, 0.35
    for key in ("drawbar", "tow_bar"):
        seg = bodies[key]
        ax.plot(
            seg[:, 0],
            seg[:, 1],
            color="#404040",
            lw=lw,
            alpha=alpha,
            zorder=zorder + 0.2,
            solid_capstyle="round",
        )
    ax.plot(*bodies["hitch"], "o", ms=3.0 if bold else 2.0, color="k", alpha=alpha, zorder=zorder + 0.3)


def draw_goal(ax: Axes, result: ManeuverResult) -> None:
    """The parking space, a cross at the goal trailer-axle centre and an arrow along the goal heading."""
    from matplotlib.patches import Polygon

    goal, v = result.goal, result.vehicle
    space = parking_space(v, goal)
    ax.add_patch(
        Polygon(
            space,
            closed=True,
            fc=SPACE_FACE,
            ec=SPACE_EDGE,
            lw=1.2,
            ls="--",
            zorder=1,
        )
    )
    arrow = 0.5 * (v.trailer_front + v.trailer_rear)
    tip = along(goal.x, goal.y, goal.yaw, arrow)
    ax.annotate(
        "",
        xy=tuple(tip),
        xytext=(goal.x, goal.y),
        zorder=4.8,
        arrowprops={"arrowstyle": "-|>", "color": "#222222", "lw": 1.4, "mutation_scale": 12},
    )
    ax.plot(
        goal.x,
        goal.y,
        marker="+",
        ms=9,
        mew=1.6,
        color="#222222",
        ls="none",
        zorder=4.8,
    )


def draw_paths(ax: Axes, result: ManeuverResult, rows: slice, color: str) -> None:
    """Trailer-axle path (solid) and vehicle rear-axle path (dashed) over ``rows``."""
    tr = result.trajectory
    xt, yt = tr["x_trailer"][rows], tr["y_trailer"][rows]
    xr, yr = tr["x_rear"][rows], tr["y_rear"][rows]
    ax.plot(xt, yt, color=color, lw=2.0, zorder=5)
    ax.plot(
        xr,
        yr,
        color=color,
        lw=1.2,
        ls=(0, (4, 2)),
        alpha=0.9,
        zorder=5,
    )


def _box(ext: Extent, grow: float) -> shapely.Geometry | None:
    """The extent's box grown by ``grow`` [m]; None while the extent is empty."""
    if not np.all(np.isfinite(ext.low)):
        return None
    return shapely.box(*(ext.low - grow), *(ext.high + grow))


def near_scene(scene: Scene, ext: Extent, reach: float = SCENE_REACH) -> None:
    """Widen ``ext`` to the parts of the obstacles and of the area boundary within ``reach`` [m] of it.

    A scene may be far larger than the motion (a whole street): only what lies near the motion is framed.
    """
    box = _box(ext, reach)
    if box is None:
        return
    shapes = [shapely.Polygon(o.polygon) for o in scene.obstacles]
    if scene.area is not None:
        shapes.append(shapely.LinearRing(scene.area.boundary))
    for part in shapely.intersection(shapes, box):
        ext.add(shapely.get_coordinates(part))


def draw_scene(ax: Axes, scene: Scene, ext: Extent, margin: float = 0.8) -> None:
    """The obstacles (filled grey, named in small type) and the area boundary (dashed), under everything else.

    Drawn without widening the axes' data limits (a scene may reach far past the motion): frame them
    with :func:`near_scene`. A name sits inside the part of its obstacle within ``ext`` grown by ``margin``.
    """
    from matplotlib.patches import Polygon

    if scene.area is not None:
        ax.add_artist(Polygon(scene.area.boundary, closed=True, fill=False, ec=AREA_EDGE, lw=1.2, ls="--", zorder=1.2))
    view = _box(ext, margin)
    for obstacle in scene.obstacles:
        ax.add_artist(
            Polygon(obstacle.polygon, closed=True, fc=OBSTACLE_FACE, ec=OBSTACLE_EDGE, lw=1.0, alpha=0.9, zorder=1.5)
        )
        if not obstacle.name or view is None:
            continue
        seen = shapely.intersection(shapely.Polygon(obstacle.polygon), view)
        if seen.is_empty:
            continue
        spot = shapely.point_on_surface(seen)
        ax.text(
            spot.x,
            spot.y,
            obstacle.name,
            fontsize=7,
            color="#1a1a1a",
            ha="center",
            va="center",
            zorder=1.6,
            clip_on=True,
        )


def draw_contact(ax: Axes, contact: Contact, clearance: float) -> None:
    """Mark where the bodies came closest to the scene: a red segment between the nearest points, labelled."""
    (bx, by), (ox, oy) = contact.points
    ax.plot([bx, ox], [by, oy], color=LIMIT_COLOR, lw=1.6, marker="x", ms=6, mew=1.6, zorder=7, clip_on=True)
    ax.annotate(
        f"least clearance {clearance_text(clearance)}",
        xy=(bx, by),
        xytext=(6, 6),
        textcoords="offset points",
        fontsize=7.5,
        color=LIMIT_COLOR,
        zorder=7.1,
        annotation_clip=True,
    )


def swept_rows(result: ManeuverResult, rows: slice, every_m: float = SWEPT_EVERY_M) -> list[int]:
    """Rows of ``rows`` about ``every_m`` [m] of travel apart, the first and last included.

    Travel is, step by step, the larger of the moves of the car's rear axle and of the trailer axle, so a
    car turning while the trailer stands still is drawn too.
    """
    tr = result.trajectory
    index = np.arange(len(tr))[rows]
    if index.size == 0:
        return []
    steps = np.maximum(
        np.hypot(np.diff(tr["x_trailer"][index]), np.diff(tr["y_trailer"][index])),
        np.hypot(np.diff(tr["x_rear"][index]), np.diff(tr["y_rear"][index])),
    )
    travel = np.concatenate([[0.0], np.cumsum(steps)])
    marks = np.floor(travel / every_m)
    chosen = [0, *np.flatnonzero(np.diff(marks) > 0) + 1, index.size - 1]
    return sorted({int(index[i]) for i in chosen})


def swept_outlines(result: ManeuverResult, rows: slice, every_m: float = SWEPT_EVERY_M) -> dict[str, list[np.ndarray]]:
    """Outlines of the real car's bodies (``"vehicle"``, ``"trailer"``) at :func:`swept_rows`: what the
    clearance is judged on (the plant's lengths)."""
    tr, vehicle = result.trajectory, result.plant_vehicle
    out: dict[str, list[np.ndarray]] = {"vehicle": [], "trailer": []}
    for row in swept_rows(result, rows, every_m):
        bodies = body_outlines(
            vehicle, tr["x_trailer"][row], tr["y_trailer"][row], tr["yaw_trailer"][row], tr["hitch"][row]
        )
        out["vehicle"].append(bodies["vehicle"])
        out["trailer"].append(bodies["trailer"])
    return out


def draw_swept(ax: Axes, outlines: dict[str, list[np.ndarray]], zorder: float = 2.0) -> None:
    """The swept bodies: each outline of :func:`swept_outlines` thin and faint, in its body's colour."""
    from matplotlib.collections import PolyCollection

    for key, edge in (("vehicle", VEHICLE_EDGE), ("trailer", TRAILER_EDGE)):
        if outlines[key]:
            lines = PolyCollection(outlines[key], closed=True, facecolors="none", edgecolors=edge, linewidths=0.5)
            lines.set_alpha(0.2)
            lines.set_zorder(zorder)
            ax.add_collection(lines, autolim=False)


def draw_plans(ax: Axes, result: ManeuverResult, zorder: float = 4.5) -> int:
    """The planned paths of the trailer axle (each plan and replan with a path), thin and dashed; how many.

    Added without widening the axes' data limits: a plan runs where the motion runs, or it was left. A search
    that found nothing is drawn where it got stuck (:func:`draw_stuck`).
    """
    from matplotlib.lines import Line2D

    drawn = 0
    for plan in result.plans:
        if plan.closest is not None:
            draw_stuck(ax, result.vehicle, plan.closest, zorder)
        if len(plan.path.get("x_trailer", ())) < 2:
            continue
        ax.add_artist(Line2D(plan.path["x_trailer"], plan.path["y_trailer"], zorder=zorder, **PLAN_STYLE))
        drawn += 1
    return drawn


def draw_stuck(ax: Axes, vehicle: VehicleTrailer, config: tuple[float, ...], zorder: float = 4.5) -> None:
    """The bodies, dotted in the limit colour, where a search that found nothing came nearest the goal, labelled."""
    from matplotlib.patches import Polygon

    bodies = body_outlines(vehicle, *config)
    for key in ("vehicle", "trailer"):
        ax.add_patch(Polygon(bodies[key], closed=True, fill=False, ec=LIMIT_COLOR, lw=1.0, ls=":", zorder=zorder))
    ax.annotate(
        "search stuck here",
        xy=(config[0], config[1]),
        xytext=(6, -10),
        textcoords="offset points",
        fontsize=7.5,
        color=LIMIT_COLOR,
        zorder=zorder + 0.1,
        annotation_clip=True,
    )
