"""An animated GIF of a whole maneuver, and the fast fixed-palette GIF writer it uses."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..checks import InputError
from ..model.geometry import parking_space, to_goal_frame
from . import use_headless_backend
from .common import (
    TRAILER_EDGE,
    TRAILER_FACE,
    VEHICLE_EDGE,
    VEHICLE_FACE,
    WHEEL_COLOR,
    Extent,
    outcome,
    stage_color,
)
from .rig import draw_goal, draw_plans, draw_scene, near_scene, rig_outlines

if TYPE_CHECKING:
    from ..maneuver.result import ManeuverResult

__all__ = ["animate_maneuver"]


def _frame_rows(n_rows: int, max_frames: int) -> np.ndarray:
    """At most ``max_frames`` rows spread evenly over ``n_rows``, first and last included."""
    count = max(1, min(n_rows, max_frames))
    return np.unique(np.round(np.linspace(0, n_rows - 1, count)).astype(int))


def animate_maneuver(
    result: ManeuverResult,
    path: str | Path,
    fps: int = 10,
    max_frames: int = 300,
    *,
    dpi: int = 80,
    width: float = 6.0,
) -> Path:
    """Write an animated GIF of the whole maneuver.

    Each frame shows the parking space and goal heading, the scene's obstacles and area
    boundary (near the motion), the planned paths of the trailer axle, the bodies (with steered
    front wheels), the trailer-axle path so far coloured by stage, the rear-axle path
    so far, and a header with time, stage, rear-axle speed, front steer, hitch angle
    and the trailer's distance and orientation errors. The rows are subsampled evenly
    to at most ``max_frames`` frames (first and last row always included); the last
    frame is held for 1.5 s.

    Parameters
    ----------
    result : ManeuverResult
        A maneuver, fresh from ``park`` or loaded back from JSON.
    path : str or Path
        The GIF file to write (parent directories are created).
    fps : int
        Frames per second of the GIF (>= 1).
    max_frames : int
        Upper bound on the number of frames (>= 1).
    dpi : int
        Resolution; the GIF is ``width * dpi`` pixels wide.
    width : float
        Figure width in inches; the height follows the shape of the scene (3.2-6.5 in).

    Returns
    -------
    Path
        The written file.

    Raises
    ------
    ValueError
        If ``fps`` or ``max_frames`` is not an integer >= 1, or the maneuver has no rows or stages.
    """
    if isinstance(fps, bool) or not isinstance(fps, int) or fps < 1:
        raise InputError(f"fps must be an integer >= 1, got {fps!r}")
    if isinstance(max_frames, bool) or not isinstance(max_frames, int) or max_frames < 1:
        raise InputError(f"max_frames must be an integer >= 1, got {max_frames!r}")
    tr = result.trajectory
    if len(tr) == 0 or not result.stages:
        raise InputError("the maneuver has no trajectory rows or no stages: nothing to animate")
    use_headless_backend()
    import matplotlib.pyplot as plt
    from matplotlib.patches import Polygon

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    rows = _frame_rows(len(tr), max_frames)
    stage_of = np.clip(tr["stage"].astype(int), 0, len(result.stages) - 1)
    geometry = {int(r): rig_outlines(result, int(r)) for r in rows}
    ext = Extent()
    ext.add(parking_space(result.vehicle, result.goal))
    ext.add(np.column_stack([tr["x_trailer"], tr["y_trailer"]]))
    for bodies, _ in geometry.values():
        ext.add(bodies["vehicle"])
        ext.add(bodies["trailer"])
    near_scene(result.scene, ext)
    height = float(np.clip(0.85 * width * ext.aspect + 1.5, 3.2, 6.5))

    fig, ax = plt.subplots(figsize=(width, height), dpi=dpi, constrained_layout=True)
    draw_scene(ax, result.scene, ext, margin=0.6)
    draw_goal(ax, result)
    draw_plans(ax, result)
    ext.apply(ax, margin=0.6)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.grid(True, color="#dddddd", lw=0.6)
    fig.suptitle(f"{result.name or 'maneuver'}: {outcome(result)}", fontsize=10)

    def polygon(**style: Any) -> Any:
        return ax.add_patch(Polygon(np.zeros((5, 2)), closed=True, **style))

    rear_line = ax.plot([], [], color="#777777", lw=0.9, ls=(0, (4, 2)), zorder=4)[0]
    stage_lines = [ax.plot([], [], color=stage_color(i), lw=1.8, zorder=5)[0] for i in range(len(result.stages))]
    wheel_patches = [polygon(fc=WHEEL_COLOR, ec="none", zorder=6) for _ in range(6)]
    vehicle_patch = polygon(fc=VEHICLE_FACE, ec=VEHICLE_EDGE, lw=1.3, alpha=0.9, zorder=7)
    trailer_patch = polygon(fc=TRAILER_FACE, ec=TRAILER_EDGE, lw=1.3, alpha=0.9, zorder=7)
    bars = [ax.plot([], [], color="#303030", lw=1.8, zorder=8, solid_capstyle="round")[0] for _ in range(2)]
    hitch_dot = ax.plot([], [], "o", ms=3.5, color="k", zorder=9)[0]
    info = ax.set_title("", fontsize=8.5, family="monospace", loc="left")
    t = tr["t"]
    n_stages = len(result.stages)
    gx, gy, gyaw = to_goal_frame(result.goal, tr["x_trailer"], tr["y_trailer"], tr["yaw_trailer"])
    distance = np.hypot(gx, gy)

    def update(row: int) -> None:
        k = int(stage_of[row])
        for i, line in enumerate(stage_lines):
            lo, hi = result.stages[i].first_row, min(row, result.stages[i].last_row)
            if i <= k and hi >= lo:
                line.set_data(tr["x_trailer"][lo : hi + 1], tr["y_trailer"][lo : hi + 1])
            else:
                line.set_data([], [])
        rear_line.set_data(tr["x_rear"][: row + 1], tr["y_rear"][: row + 1])
        bodies, wheels = geometry[row]
        vehicle_patch.set_xy(bodies["vehicle"])
        trailer_patch.set_xy(bodies["trailer"])
        for patch, wheel in zip(wheel_patches, wheels, strict=True):
            patch.set_xy(wheel)
        for bar, key in zip(bars, ("drawbar", "tow_bar"), strict=True):
            bar.set_data(bodies[key][:, 0], bodies[key][:, 1])
        hitch_dot.set_data([bodies["hitch"][0]], [bodies["hitch"][1]])
        info.set_text(
            f"t {t[row]:5.1f} s   stage {k + 1}/{n_stages} {result.stages[k].kind:<7}  "
            f"V_R {tr['rear_speed'][row]:+5.2f} m/s\n"
            f"δf {math.degrees(tr['front_steer'][row]):+5.1f}°   "
            f"Δψ {math.degrees(tr['hitch'][row]):+5.1f}°   "
            f"trailer: d {distance[row]:5.2f} m, e_ψ {math.degrees(gyaw[row]):+6.2f}°"
        )
        info.set_color(stage_color(k))

    # Lay the figure out once, then freeze it: re-running the constrained layout on every
    # frame would more than double the render time.
    update(int(rows[-1]))
    fig.canvas.draw()
    fig.set_layout_engine(None)
    # The last frame holds every colour in use (all stage paths are drawn by then); its
    # palette serves every frame, which is fast and gives the GIF one global palette.
    palette = _canvas_image(fig).quantize(colors=255, dither=_no_dither())
    writer = _make_gif_writer(fps, palette, hold_last_s=1.5)
    with writer.saving(fig, str(path), dpi):
        for row in rows:
            update(int(row))
            writer.grab_frame()
    plt.close(fig)
    return path


def _canvas_image(fig: Any) -> Any:
    """The figure's Agg canvas as an RGB ``PIL.Image`` (the canvas must have been drawn)."""
    from PIL import Image

    width, height = fig.canvas.get_width_height(physical=True)
    return Image.frombuffer("RGBA", (width, height), fig.canvas.buffer_rgba(), "raw", "RGBA", 0, 1).convert("RGB")


def _no_dither() -> Any:
    from PIL import Image

    return Image.Dither.NONE


def _make_gif_writer(fps: int, palette: Any, hold_last_s: float) -> Any:
    """A ``PillowWriter`` that draws each frame once and maps it onto a fixed palette.

    The stock writer renders every frame through ``savefig`` and lets Pillow quantize
    every frame on its own when saving, which dominates the run time for a few hundred
    frames. The last frame is shown for ``hold_last_s`` seconds.
    """
    from matplotlib.animation import PillowWriter

    class _PaletteGifWriter(PillowWriter):
        def setup(self, fig: Any, outfile: Any, dpi: float | None = None) -> None:
            super().setup(fig, outfile, dpi=dpi)
            self._paletted: list[Any] = []

        def grab_frame(self, **savefig_kwargs: Any) -> None:
            self.fig.canvas.draw()
            self._paletted.append(_canvas_image(self.fig).quantize(palette=palette, dither=_no_dither()))

        def finish(self) -> None:
            frame_ms = round(1000 / self.fps)
            durations = [frame_ms] * len(self._paletted)
            durations[-1] = max(frame_ms, round(1000 * hold_last_s))
            self._paletted[0].save(
                self.outfile, save_all=True, append_images=self._paletted[1:], duration=durations, loop=0
            )

    return _PaletteGifWriter(fps=fps)
