"""The map of a sweep: where the maneuver parks and where it fails, and why, among the scene's obstacles if any.

Matplotlib is imported only inside :func:`plot_sweep_map`.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..model.geometry import parking_space
from ..model.scene import Scene
from ..model.state import Pose
from ..model.vehicle import VehicleTrailer
from ..outputs import check_figure_name, replacing
from . import use_headless_backend

if TYPE_CHECKING:
    from ..app.records import CaseRecord
    from ..app.starts import Region

__all__ = ["plot_sweep_map"]

_PARKED_COLOR = "#009E73"
#: Colour and marker of the i-th failure reason (most frequent first): Okabe-Ito, then wine and black.
_FAILURE_STYLES = (
    ("#D55E00", "X"),
    ("#CC79A7", "s"),
    ("#E69F00", "^"),
    ("#0072B2", "D"),
    ("#56B4E9", "v"),
    ("#882255", "P"),
    ("#000000", "*"),
)
_SPACE_FACE, _SPACE_EDGE = "#ececec", "#7a7a7a"


def plot_sweep_map(
    records: Sequence[CaseRecord],
    path: str | Path,
    vehicle: VehicleTrailer | None = None,
    region: Region | None = None,
    title: str = "",
    tick_m: float = 0.6,
    goal: Pose | None = None,
    scene: Scene | None = None,
) -> Path:
    """Draw every start of a sweep at its trailer-axle position and write an image (PNG, PDF, SVG) to ``path``.

    Parked starts are green dots, each failure reason has its own colour and marker (the legend
    counts them); a short tick of ``tick_m`` metres from each start points along its trailer heading.
    The parking space of ``vehicle`` (default Table 4) is drawn at ``goal`` (default the origin, heading +x),
    ``region`` (where the starts were drawn), if given, as a dashed box, and the obstacles and area of
    ``scene`` near the starts and the goal.
    """
    path = check_figure_name(path, "map")
    use_headless_backend()
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection

    vehicle = vehicle or VehicleTrailer()
    goal = goal or Pose()
    fig, ax = plt.subplots(figsize=(9.5, 8.0), layout="constrained")
    try:
        space = parking_space(vehicle, goal)
        if scene is not None and not scene.is_empty:
            from .common import AREA_EDGE, OBSTACLE_EDGE, OBSTACLE_FACE, Extent
            from .rig import draw_scene, near_scene

            ext = Extent()
            ext.add(space)
            ext.add(np.array([[r.start.x, r.start.y] for r in records]))
            if region is not None:
                ext.add(np.array([[region.x[0], region.y[0]], [region.x[1], region.y[1]]]))
            near_scene(scene, ext)
            draw_scene(ax, scene, ext)
            ext.apply(ax)
            if scene.obstacles:  # legend entries: draw_scene's artists carry no label
                ax.fill([], [], fc=OBSTACLE_FACE, ec=OBSTACLE_EDGE, label="obstacle")
            if scene.area is not None:
                ax.plot([], [], color=AREA_EDGE, lw=1.2, ls="--", label="area boundary")
        ax.fill(
            space[:, 0],
            space[:, 1],
            facecolor=_SPACE_FACE,
            edgecolor=_SPACE_EDGE,
            lw=1.2,
            zorder=1,
            label="parking space",
        )
        ax.annotate(
            "",
            xy=(goal.x + 1.5 * np.cos(goal.yaw), goal.y + 1.5 * np.sin(goal.yaw)),
            xytext=(goal.x, goal.y),
            arrowprops={"arrowstyle": "-|>", "color": "black", "lw": 1.5},
            zorder=4,
        )
        ax.plot([goal.x], [goal.y], marker="*", ms=14, color="black", ls="none", zorder=5, label="goal (trailer axle)")
        if region is not None:
            (x0, x1), (y0, y1) = region.x, region.y
            ax.plot(
                [x0, x1, x1, x0, x0],
                [y0, y0, y1, y1, y0],
                ls="--",
                lw=1.0,
                color="#7a7a7a",
                zorder=1,
                label="start region",
            )

        reasons: dict[str, list[CaseRecord]] = {}
        for r in records:
            reasons.setdefault("parked" if r.success else r.reason, []).append(r)
        failures = sorted((k for k in reasons if k != "parked"), key=lambda k: (-len(reasons[k]), k))
        groups = [("parked", _PARKED_COLOR, "o", 22.0)] if "parked" in reasons else []
        for i, reason in enumerate(failures):
            color, marker = _FAILURE_STYLES[i % len(_FAILURE_STYLES)]
            groups.append((reason, color, marker, 60.0))
        for order, (reason, color, marker, size) in enumerate(groups):
            group = reasons[reason]
            x = np.array([r.start.x for r in group])
            y = np.array([r.start.y for r in group])
            yaw = np.radians([r.start.yaw_deg for r in group])
            tips = np.column_stack([x + tick_m * np.cos(yaw), y + tick_m * np.sin(yaw)])
            ticks = np.stack([np.column_stack([x, y]), tips], axis=1)
            ax.add_collection(LineCollection(list(ticks), colors=color, linewidths=1.0, zorder=2 + order))
            ax.scatter(
                x,
                y,
                s=size,
                c=color,
                marker=marker,
                edgecolors="white" if reason == "parked" else "black",
                linewidths=0.4,
                zorder=3 + order,
                label=f"{reason} ({len(group)})",
            )
        n = len(records)
        parked = len(reasons.get("parked", []))
        head = title or "Sweep"
        rate = f"{100 * parked / n:.1f}%" if n else "-"
        ax.set_title(f"{head}: parked {parked} of {n} starts ({rate})\nticks point along the trailer heading")
        if goal == Pose():
            ax.set_xlabel("x of the trailer axle [m] (parking frame, goal at the origin heading +x)")
        else:
            ax.set_xlabel("x of the trailer axle [m] (world frame)")
        ax.set_ylabel("y of the trailer axle [m]")
        ax.set_aspect("equal", adjustable="datalim")
        ax.autoscale_view()
        ax.grid(True, lw=0.4, alpha=0.5)
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False, title="outcome (starts)")
        with replacing(path) as tmp:  # whole or not at all; the format from the name asked for
            fig.savefig(tmp, dpi=120, format=path.suffix[1:] or "png")
    finally:
        plt.close(fig)
    return path
