"""Figures 8-15 of the paper for one parking maneuver.

``plot_maneuver`` writes three PNG files:

* ``motion.png`` (Figs. 8/10/12/14 a-d): one panel per stage with the trailer-axle
  and rear-axle paths and the bodies at several instants, plus the overall trajectory; the swept
  bodies of the real car (faint outlines every metre of travel) and the planned paths of the trailer
  axle (thin, dashed); with a scene, its obstacles and area boundary and, where the bodies came
  closest to it, a mark;
* ``inputs.png`` (Figs. 8e-f, drawn by :mod:`.inputs`): front steer and its rate, rear-axle
  speed and hitch angle against time, commanded, actual and measured where the trajectory has them;
* ``nmpc.png`` (Figs. 9/11/13/15), where an NMPC drove: per reverse stage, the NMPC cost, the virtual
  inputs, the trailer position in the parking frame and the trailer orientation error.

Matplotlib is imported only inside the plotting functions.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..checks import InputError
from ..model.collision import swept_contact
from ..model.geometry import parking_space
from . import use_headless_backend
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
    Extent,
    headline,
    stage_color,
    stage_name,
    stage_summary,
)
from .inputs import inputs_figure
from .nmpc_figure import nmpc_figure
from .rig import (
    PLAN_STYLE,
    SWEPT_EVERY_M,
    draw_contact,
    draw_goal,
    draw_paths,
    draw_plans,
    draw_rig,
    draw_scene,
    draw_swept,
    near_scene,
    rig_outlines,
    swept_outlines,
)

if TYPE_CHECKING:
    from matplotlib.artist import Artist
    from matplotlib.figure import Figure

    from ..maneuver.result import ManeuverResult

__all__ = ["motion_figure", "nmpc_figure", "plot_maneuver"]


def _snapshot_rows(t: np.ndarray, first: int, last: int, every: float, max_count: int = 8) -> list[int]:
    """Rows strictly between ``first`` and ``last`` about ``every`` seconds apart (at most ``max_count``)."""
    duration = float(t[last] - t[first])
    if last - first < 2 or duration <= 0:
        return []
    step = max(every, duration / (max_count + 1))
    targets = t[first] + np.arange(step, duration - 0.5 * step + 1e-9, step)
    rows = np.searchsorted(t[first : last + 1], targets) + first
    return sorted({int(r) for r in rows if first < r < last})


def _panel_rows(result: ManeuverResult, snapshot_every: float) -> list[tuple[slice, list[int], list[int]]]:
    """For each panel (stages, then the overall one): path rows, light-body rows, bold-body rows."""
    t = result.trajectory["t"]
    panels = []
    for i, st in enumerate(result.stages):
        bold = [st.first_row] if st.last_row == st.first_row else [st.first_row, st.last_row]
        panels.append((result.stage_rows(i), _snapshot_rows(t, st.first_row, st.last_row, snapshot_every), bold))
    light = [st.first_row for st in result.stages[1:]]
    panels.append((slice(0, len(t)), light, [0, len(t) - 1]))
    return panels


def motion_figure(result: ManeuverResult, snapshot_every: float = 2.0) -> Figure:
    """The motion figure: a panel per stage and one for the whole maneuver (the caller saves and closes it)."""
    use_headless_backend()
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    tr = result.trajectory
    n_stages = len(result.stages)
    panels = _panel_rows(result, snapshot_every)
    scene = result.scene
    # Where the real car came closest to the scene (the sub-sample of the swept check), marked in the panels
    # whose rows hold it.
    closest_row, contact = -1, None
    if not scene.is_empty:
        _, closest_row, contact = swept_contact(result.plant_vehicle, scene, tr.states())
    n_panels = len(panels)
    ncols = 2 if n_panels <= 4 else 3
    nrows = math.ceil(n_panels / ncols)

    # Extents first, to give the panels a height that suits the data.
    extents, swept = [], []
    for rows, light, bold in panels:
        ext = Extent()
        swept.append(swept_outlines(result, rows))
        for outline in (*swept[-1]["vehicle"], *swept[-1]["trailer"]):
            ext.add(outline)
        ext.add(parking_space(result.vehicle, result.goal))
        ext.add(np.column_stack([tr["x_trailer"][rows], tr["y_trailer"][rows]]))
        ext.add(np.column_stack([tr["x_rear"][rows], tr["y_rear"][rows]]))
        for row in (*light, *bold):
            bodies, _ = rig_outlines(result, row)
            ext.add(bodies["vehicle"])
            ext.add(bodies["trailer"])
        if contact is not None and _holds(rows, closest_row):
            ext.add(contact.points)
        near_scene(scene, ext)
        extents.append(ext)
    width = 6.0
    aspect = float(np.median([e.aspect for e in extents]))
    height = float(np.clip(width * aspect * 0.92, 2.0, 5.5)) + 1.15
    fig, axes = plt.subplots(
        nrows, ncols, figsize=(width * ncols, height * nrows + 1.3), constrained_layout=True, squeeze=False
    )
    flat = axes.ravel()
    letters = "abcdefghij"
    n_plans = 0
    for p, ((rows, light, bold), ext) in enumerate(zip(panels, extents, strict=True)):
        ax = flat[p]
        draw_scene(ax, scene, ext)
        draw_goal(ax, result)
        draw_swept(ax, swept[p])
        n_plans = draw_plans(ax, result)
        for i in range(n_stages) if p == n_stages else [p]:
            draw_paths(ax, result, result.stage_rows(i), stage_color(i))
        for row in light:
            draw_rig(ax, result, row, bold=False)
        for j, row in enumerate(bold):
            draw_rig(ax, result, row, bold=True, zorder=3 + 0.5 * j)
        if contact is not None and result.min_clearance_m is not None and _holds(rows, closest_row):
            draw_rig(ax, result, closest_row, bold=False)
            draw_contact(ax, contact, result.min_clearance_m)
        first, last = bold[0], bold[-1]
        start_color = stage_color(p if p < n_stages else 0)
        end_color = stage_color(p if p < n_stages else n_stages - 1)
        ax.plot(
            tr["x_trailer"][first],
            tr["y_trailer"][first],
            "o",
            ms=6.5,
            mfc="white",
            mec=start_color,
            mew=1.8,
            zorder=6,
        )
        ax.plot(tr["x_trailer"][last], tr["y_trailer"][last], "s", ms=6, color=end_color, zorder=6)
        ext.apply(ax)
        if p < n_stages:
            title = f"({letters[p]}) {stage_name(result, p)}\n{stage_summary(result, p)}"
        else:
            title = f"({letters[p]}) Overall trajectory\nbodies at the start, at each stage change and at the end"
        ax.set_title(title, fontsize=10)
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.grid(True, lw=0.4, alpha=0.5)
    for ax in flat[n_panels:]:
        ax.set_visible(False)
    handles: list[Artist] = [
        Line2D([], [], color=stage_color(i), lw=2.0, label=f"stage {i + 1} ({st.kind})")
        for i, st in enumerate(result.stages)
    ]
    handles += [
        Line2D([], [], color="#555555", lw=2.0, label="trailer-axle path"),
        Line2D([], [], color="#555555", lw=1.2, ls=(0, (4, 2)), label="vehicle rear-axle path"),
        Line2D([], [], marker="o", mfc="white", mec="#555555", mew=1.6, ls="none", label="start (trailer axle)"),
        Line2D([], [], marker="s", color="#555555", ls="none", label="end (trailer axle)"),
        Patch(fc=VEHICLE_FACE, ec=VEHICLE_EDGE, label="vehicle"),
        Patch(fc=TRAILER_FACE, ec=TRAILER_EDGE, label="trailer (drawbar to the hitch •)"),
        Line2D(
            [],
            [],
            lw=0.8,
            color=VEHICLE_EDGE,
            alpha=0.45,
            label=f"bodies every {snapshot_every:g} s (at most 8 per stage)",
        ),
        Patch(fc=SPACE_FACE, ec=SPACE_EDGE, ls="--", label="parking space, goal heading →"),
        Patch(
            fill=False,
            ec=TRAILER_EDGE,
            lw=0.5,
            alpha=0.4,
            label=f"swept bodies of the real car, every {SWEPT_EVERY_M:g} m of travel",
        ),
    ]
    if n_plans:
        label = "planned path (trailer axle)" + (f", {n_plans} plans with replans" if n_plans > 1 else "")
        handles.append(Line2D([], [], **PLAN_STYLE, label=label))
    if any(plan.closest is not None for plan in result.plans):
        handles.append(Patch(fill=False, ec=LIMIT_COLOR, ls=":", label="where a search that found nothing got stuck"))
    if scene.obstacles:
        handles.append(Patch(fc=OBSTACLE_FACE, ec=OBSTACLE_EDGE, label="obstacle"))
    if scene.area is not None:
        handles.append(Line2D([], [], color=AREA_EDGE, lw=1.2, ls="--", label="area boundary"))
    if contact is not None:
        handles.append(
            Line2D([], [], color=LIMIT_COLOR, lw=1.6, marker="x", mew=1.6, label="least clearance (real car)")
        )
    fig.legend(
        handles=handles,
        loc="outside lower center",
        ncol=min(6, math.ceil(len(handles) / (2 if len(handles) <= 12 else 3))),
        fontsize=8.5,
        frameon=False,
    )
    fig.suptitle(headline(result), fontsize=11)
    return fig


def _holds(rows: slice, row: int) -> bool:
    """``row`` lies within the panel's ``rows``."""
    return (rows.start or 0) <= row < (rows.stop if rows.stop is not None else row + 1)


def _save(fig: Figure, path: Path, dpi: int) -> Path:
    """Write ``fig`` to ``path`` and close it, even if writing fails."""
    import matplotlib.pyplot as plt

    try:
        fig.savefig(path, dpi=dpi)
    finally:
        plt.close(fig)
    return path


def plot_maneuver(
    result: ManeuverResult,
    out_dir: str | Path,
    prefix: str = "",
    *,
    dpi: int = 150,
    snapshot_every: float = 2.0,
) -> list[Path]:
    """Write the paper's Figs. 8-15 for one maneuver as PNG files.

    Parameters
    ----------
    result : ManeuverResult
        A maneuver, fresh from ``park`` or loaded back from JSON.
    out_dir : str or Path
        Directory for the files (created if missing).
    prefix : str
        Prepended to each file name, e.g. ``"scenario1_"``.
    dpi : int
        Resolution of the PNG files.
    snapshot_every : float
        Time between the light body outlines drawn in each stage panel [s]; fewer are
        drawn in long stages (at most 8 per stage).

    Returns
    -------
    list of Path
        ``motion.png``, ``inputs.png`` and ``nmpc.png`` (with the prefix), in that order; no ``nmpc.png`` for a
        maneuver no NMPC drove (a knob-assisted drive: it would show nothing).

    Raises
    ------
    ValueError
        If ``snapshot_every`` is not a positive time, or the maneuver has no rows or stages.
    """
    if not math.isfinite(snapshot_every) or snapshot_every <= 0:
        raise InputError(f"snapshot_every must be a finite time > 0 s, got {snapshot_every!r}")
    if len(result.trajectory) == 0 or not result.stages:
        raise InputError("the maneuver has no trajectory rows or no stages: nothing to plot")
    use_headless_backend()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    files = [
        _save(motion_figure(result, snapshot_every), out / f"{prefix}motion.png", dpi),
        _save(inputs_figure(result), out / f"{prefix}inputs.png", dpi),
    ]
    if any(st.controller in ("nmpc", "") for st in result.stages):  # "": a file that did not record it
        files.append(_save(nmpc_figure(result), out / f"{prefix}nmpc.png", dpi))
    return files
