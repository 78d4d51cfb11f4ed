"""Figures and animation of a maneuver among obstacles: they render, from a fresh result and from its JSON."""

from __future__ import annotations

import json

import matplotlib.pyplot as plt
import pytest
from PIL import Image

from hitchpark.control import NMPCSettings
from hitchpark.io import read_json, write_json
from hitchpark.maneuver import ManeuverResult, ManeuverSettings, park
from hitchpark.model import IDEAL, State, VehicleTrailer
from hitchpark.model.scene import Area, Obstacle, Scene
from hitchpark.viz.figures import motion_figure
from hitchpark.viz.maneuver import animate_maneuver, plot_maneuver


def box(x0: float, y0: float, x1: float, y1: float) -> list[list[float]]:
    return [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]


SCENE = Scene(
    (
        Obstacle("parked car", box(-7.0, -3.0, -2.3, -1.1)),
        Obstacle("pole", box(3.0, 0.9, 3.2, 1.1)),  # on the way: the maneuver runs into it
        Obstacle("", box(8.0, -4.0, 9.0, -3.0)),
    ),
    Area(box(-500.0, -500.0, 500.0, 500.0)),  # far larger than the motion: must not zoom the figure out
)


@pytest.fixture(scope="module")
def among() -> ManeuverResult:
    settings = ManeuverSettings(nmpc=NMPCSettings(kind="paper", solver="sqp"))
    return park(VehicleTrailer(), State(6, 3, 0, 0), settings=settings, name="among", plant=IDEAL, scene=SCENE)


@pytest.mark.slow
def test_plots_and_animation_of_a_result_with_a_scene(among: ManeuverResult, tmp_path) -> None:
    assert among.reason == "collision" and among.min_clearance_m == 0.0  # the pole is marked
    saved = write_json(tmp_path / "maneuver.json", among.to_dict())
    loaded = ManeuverResult.from_dict(read_json(saved))
    assert loaded.scene == SCENE
    files = plot_maneuver(loaded, tmp_path / "fig", dpi=60)
    files.append(animate_maneuver(loaded, tmp_path / "fig" / "maneuver.gif", max_frames=6))
    for path in files:
        assert path.exists() and path.stat().st_size > 0
        with Image.open(path) as image:
            assert image.width > 100 and image.height > 100


def test_a_large_area_does_not_zoom_the_figure_out(among: ManeuverResult) -> None:
    fig = motion_figure(among)
    try:
        fig.canvas.draw()
        for ax in fig.axes:
            if ax.get_visible():
                low, high = ax.get_xlim()
                assert high - low < 60.0  # the motion spans about 20 m; the area 1 km
    finally:
        plt.close(fig)


@pytest.mark.slow
def test_a_clear_scene_renders_with_its_clearance(tmp_path) -> None:
    settings = ManeuverSettings(nmpc=NMPCSettings(kind="paper", solver="sqp"))
    clear = Scene((Obstacle("kerb stone", box(-6.0, 8.0, -5.0, 9.0)),))
    result = park(VehicleTrailer(), State(6, 3, 0, 0), settings=settings, plant=IDEAL, scene=clear)
    assert result.success and result.min_clearance_m > 0.2
    data = json.loads(json.dumps(result.to_dict(), allow_nan=False))
    assert data["min_clearance_m"] == result.min_clearance_m and data["collision"] is False
    (motion, *_) = plot_maneuver(ManeuverResult.from_dict(data), tmp_path, dpi=50)
    assert motion.stat().st_size > 0
