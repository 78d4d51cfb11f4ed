"""The motion figure draws the planned paths (thin, dashed) and the swept bodies (faint outlines every metre)."""

from __future__ import annotations

from dataclasses import replace

import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.collections import PolyCollection
from matplotlib.lines import Line2D

from hitchpark.control import NMPCSettings
from hitchpark.io import read_json, write_json
from hitchpark.maneuver import ManeuverResult, ManeuverSettings, park
from hitchpark.maneuver.result import PlanRecord
from hitchpark.model import IDEAL, State, VehicleTrailer
from hitchpark.model.scene import Obstacle, Scene
from hitchpark.viz.figures import motion_figure
from hitchpark.viz.maneuver import animate_maneuver
from hitchpark.viz.rig import PLAN_COLOR, swept_outlines, swept_rows


def plan_along(result: ManeuverResult, every: int, shift: float) -> PlanRecord:
    """A plan that follows the motion, shifted sideways: the paper's process plans nothing, so one is made up."""
    tr = result.trajectory
    rows = np.arange(0, len(tr), every)
    path = {
        "x_trailer": tr["x_trailer"][rows],
        "y_trailer": tr["y_trailer"][rows] + shift,
        "yaw_trailer": tr["yaw_trailer"][rows],
        "hitch": tr["hitch"][rows],
        "direction": np.where(tr["rear_speed"][rows] < 0, -1.0, 1.0),
    }
    return PlanRecord("found", 0.25, "", path)


@pytest.fixture(scope="module")
def planned() -> ManeuverResult:
    settings = ManeuverSettings(nmpc=NMPCSettings(kind="paper", solver="sqp"))
    scene = Scene((Obstacle("kerb stone", [[-6.0, 8.0], [-5.0, 8.0], [-5.0, 9.0], [-6.0, 9.0]]),))
    result = park(VehicleTrailer(), State(6, 3, 0, 0), settings=settings, plant=IDEAL, scene=scene, name="planned")
    return replace(result, plans=(plan_along(result, 7, 0.3), plan_along(result, 11, -0.3)))


def test_swept_rows_are_a_metre_of_travel_apart(planned: ManeuverResult) -> None:
    tr = planned.trajectory
    rows = swept_rows(planned, slice(0, len(tr)))
    assert rows[0] == 0 and rows[-1] == len(tr) - 1 and rows == sorted(set(rows))
    trailer = np.concatenate([[0], np.cumsum(np.hypot(np.diff(tr["x_trailer"]), np.diff(tr["y_trailer"])))])
    rear = np.concatenate([[0], np.cumsum(np.hypot(np.diff(tr["x_rear"]), np.diff(tr["y_rear"])))])
    travel = max(trailer[-1], rear[-1])
    assert travel > 5.0
    assert travel - 2 <= len(rows) <= 2 * travel + 2  # about one a metre (of the axle that moved more)
    middle = rows[1:-1]
    assert np.all(np.diff(np.maximum(trailer[middle], rear[middle])) > 0.5)
    outlines = swept_outlines(planned, slice(0, len(tr)))
    assert len(outlines["vehicle"]) == len(outlines["trailer"]) == len(rows)
    assert all(o.shape == (5, 2) for o in outlines["trailer"])
    assert swept_rows(planned, slice(3, 3)) == []


def _plan_lines(ax) -> list[Line2D]:
    return [a for a in ax.get_children() if isinstance(a, Line2D) and a.get_color() == PLAN_COLOR]


def test_motion_figure_draws_plans_and_swept_bodies(planned: ManeuverResult, tmp_path) -> None:
    loaded = ManeuverResult.from_dict(read_json(write_json(tmp_path / "m.json", planned.to_dict())))
    assert len(loaded.plans) == 2  # the plans travel through maneuver.json
    fig = motion_figure(loaded)
    try:
        panels = [ax for ax in fig.axes if ax.get_visible()]
        assert len(panels) == len(loaded.stages) + 1
        for ax in panels:
            lines = _plan_lines(ax)
            assert len(lines) == 2 and lines[0].get_linestyle() == "--"
            assert np.array_equal(lines[0].get_xdata(), loaded.plans[0].path["x_trailer"])
            swept = [c for c in ax.collections if isinstance(c, PolyCollection) and c.get_alpha() == 0.2]
            assert len(swept) == 2  # the car's outlines and the trailer's
        overall = panels[-1]
        n_rows = len(swept_rows(loaded, slice(0, len(loaded.trajectory))))
        assert [len(c.get_paths()) for c in overall.collections if c.get_alpha() == 0.2] == [n_rows, n_rows]
        labels = [t.get_text() for t in fig.legends[0].get_texts()]
        assert "planned path (trailer axle), 2 plans with replans" in labels
        assert any(label.startswith("swept bodies of the real car, every 1 m") for label in labels)
    finally:
        plt.close(fig)


def test_no_plan_no_plan_line_and_the_animation_draws_them(planned: ManeuverResult, tmp_path) -> None:
    fig = motion_figure(replace(planned, plans=(PlanRecord("no_path", 0.1, "none in time"),)))
    try:
        assert all(not _plan_lines(ax) for ax in fig.axes)
        assert not any("planned path" in t.get_text() for t in fig.legends[0].get_texts())
    finally:
        plt.close(fig)
    gif = animate_maneuver(planned, tmp_path / "m.gif", max_frames=4)
    assert gif.stat().st_size > 0
