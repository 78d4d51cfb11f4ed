"""Figures 8-15 of the paper for one parking maneuver, and an animated GIF of it.

The public entry points, gathered from the modules that hold them:

* ``plot_maneuver`` (:mod:`.figures`): ``motion.png``, ``inputs.png`` and ``nmpc.png``;
* ``animate_maneuver`` (:mod:`.animation`): the GIF;
* ``body_outlines``, ``wheel_outlines`` and ``parking_space`` (:mod:`hitchpark.model.geometry`):
  the outlines the figures draw, plain NumPy, so they can also serve collision checks;
* ``STAGE_COLORS`` (:mod:`.common`): the colour of each stage.

The layout of the package: :mod:`.common` (colours, stage shading, limit lines, texts,
extents), :mod:`.rig` (the car, trailer, goal and paths in the plane), :mod:`.figures`
(motion and NMPC figures, ``plot_maneuver``), :mod:`.inputs` (the inputs figure) and
:mod:`.animation`. Matplotlib is imported only inside the plotting functions.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from ..app.report import ANIMATION_FILE, ANIMATION_FRAMES
from ..model.geometry import body_outlines, parking_space, wheel_outlines
from .animation import animate_maneuver
from .common import STAGE_COLORS
from .figures import plot_maneuver
from .viewer import render_viewer

if TYPE_CHECKING:
    from ..maneuver.result import ManeuverResult

__all__ = [
    "STAGE_COLORS",
    "animate_maneuver",
    "body_outlines",
    "parking_space",
    "plot_maneuver",
    "render_maneuver",
    "render_viewer",
    "wheel_outlines",
]


def render_maneuver(
    result: ManeuverResult, folder: Path, plots: bool = True, animation: bool = True, viewer: bool = True
) -> dict[str, Path]:
    """Draw the figures and/or the GIF of ``result`` into ``folder``, and its viewer (``maneuver.html``,
    :mod:`.viewer`); return the paths by name (a renderer of :func:`~hitchpark.app.report.save_maneuver` and
    :func:`~hitchpark.app.report.reproduce`)."""
    files: dict[str, Path] = {}
    if viewer:
        files.update(render_viewer(result, folder))
    if plots:
        for p in plot_maneuver(result, folder):
            files[p.stem] = p
    if animation:
        files["animation"] = animate_maneuver(result, folder / ANIMATION_FILE, max_frames=ANIMATION_FRAMES)
    return files
