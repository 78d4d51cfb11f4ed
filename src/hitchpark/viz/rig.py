"""Drawing the scene in the plane: the car and trailer at a row, the parking space and goal, the paths.

The outlines themselves come from :mod:`hitchpark.model.geometry` (plain NumPy); this module
only turns them into matplotlib artists. Matplotlib is imported inside the functions.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..model.geometry import along, body_outlines, parking_space, wheel_outlines
from .common import (
    SPACE_EDGE,
    SPACE_FACE,
    TRAILER_EDGE,
    TRAILER_FACE,
    VEHICLE_EDGE,
    VEHICLE_FACE,
    WHEEL_COLOR,
)

if TYPE_CHECKING:
    from matplotlib.axes import Axes

    from ..maneuver.result import ManeuverResult

__all__ = ["draw_goal", "draw_paths", "draw_rig", "rig_outlines"]


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
