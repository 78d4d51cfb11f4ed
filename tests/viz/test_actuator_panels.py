"""The inputs figure with a steering actuator: commanded vs. actual steer and speed, steer rate, measured hitch.

The tests take the paper's maneuver (the ideal plant: the actual steer and speed are the commands,
the measured hitch the true one) and fabricate an actuator the figure must show: the actual
steer follows the command at a limited rate, the actual speed lags the command, and the measured
hitch is the true one plus a bias and seeded noise.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING

import numpy as np
import pytest
from PIL import Image

from hitchpark.app.report import run_scenario
from hitchpark.io import read_json, write_json
from hitchpark.maneuver import ManeuverResult, builtin_scenarios
from hitchpark.model import IDEAL, PlantSettings
from hitchpark.model.simulate import Trajectory
from hitchpark.viz.inputs import inputs_figure, steer_rate_limit
from hitchpark.viz.maneuver import plot_maneuver

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.lines import Line2D

Panels = dict[str, "Axes"]

STEER_RATE_MAX = math.radians(60.0)
NEW_COLUMNS = ("front_steer_cmd", "rear_speed_cmd", "hitch_measured")


@dataclasses.dataclass(frozen=True)
class Plant:
    """Stands in for other plant settings a result may carry: only the steer-rate limit matters here."""

    steer_rate_max: float | None


def with_actuator(result: ManeuverResult, steer_rate_max: float = STEER_RATE_MAX, seed: int = 0) -> ManeuverResult:
    """``result`` with the commands it applied as ``*_cmd`` columns and fabricated actual and measured ones."""
    tr = result.trajectory
    t, steer_cmd, speed_cmd = tr["t"], tr["front_steer"], tr["rear_speed"]
    steer, speed = np.zeros(len(t)), np.zeros(len(t))
    for k in range(len(t) - 1):
        step = steer_rate_max * (t[k + 1] - t[k])
        steer[k + 1] = steer[k] + np.clip(steer_cmd[k] - steer[k], -step, step)
        speed[k + 1] = speed[k] + 0.5 * (speed_cmd[k] - speed[k])
    noise = np.random.default_rng(seed).normal(0.0, math.radians(0.8), len(t))
    columns = {
        **tr.columns,
        "front_steer": steer,
        "front_steer_cmd": steer_cmd,
        "rear_speed": speed,
        "rear_speed_cmd": speed_cmd,
        "hitch_measured": tr["hitch"] + math.radians(0.5) + noise,
    }
    return dataclasses.replace(result, trajectory=Trajectory(columns))


def without_new_columns(result: ManeuverResult) -> ManeuverResult:
    """``result`` with a trajectory that lacks the actuator columns, as other tools may build one."""
    columns = {k: v for k, v in result.trajectory.columns.items() if k not in NEW_COLUMNS}
    return dataclasses.replace(result, trajectory=Trajectory(columns))


@pytest.fixture(scope="module")
def parallel() -> ManeuverResult:
    """The built-in parallel scenario as ``park`` returns it: the paper's process on the ideal plant (~0.2 s)."""
    scenario = next(s for s in builtin_scenarios() if s.name == "parallel")
    result = run_scenario(scenario)
    assert result.plant == IDEAL
    return result


@pytest.fixture(scope="module")
def actuated(parallel: ManeuverResult) -> ManeuverResult:
    return dataclasses.replace(with_actuator(parallel), plant=PlantSettings(steer_rate_max=STEER_RATE_MAX))


@pytest.fixture
def figure_of() -> Iterator[Callable[[ManeuverResult], Panels]]:
    """Build the inputs figure of a result and return its panels by label; close the figures afterwards."""
    figures = []

    def build(result: ManeuverResult) -> Panels:
        fig = inputs_figure(result)
        figures.append(fig)
        return {ax.get_label(): ax for ax in fig.axes}

    yield build
    import matplotlib.pyplot as plt

    for fig in figures:
        plt.close(fig)


def lines(ax: Axes, prefix: str) -> list[Line2D]:
    """The lines of ``ax`` whose legend label starts with ``prefix``."""
    return [line for line in ax.get_lines() if line.get_label().startswith(prefix)]


def only(ax: Axes, prefix: str) -> np.ndarray:
    """The y data of the one line of ``ax`` labelled ``prefix...``."""
    found = lines(ax, prefix)
    assert len(found) == 1, [line.get_label() for line in ax.get_lines()]
    return np.asarray(found[0].get_ydata(), dtype=float)


def test_panels_show_commanded_actual_rate_and_measured(actuated: ManeuverResult, figure_of) -> None:
    panels = figure_of(actuated)
    assert list(panels) == ["front_steer", "steer_rate", "rear_speed", "hitch"]
    tr = actuated.trajectory
    t = tr["t"]
    np.testing.assert_allclose(only(panels["front_steer"], "commanded"), np.degrees(tr["front_steer_cmd"]))
    np.testing.assert_allclose(only(panels["front_steer"], "actual"), np.degrees(tr["front_steer"]))
    np.testing.assert_allclose(only(panels["rear_speed"], "commanded"), tr["rear_speed_cmd"])
    np.testing.assert_allclose(only(panels["rear_speed"], "actual"), tr["rear_speed"])
    # Steer rate [deg/s]: the actual one over each sample, the commanded one from each jump of the command.
    rate = panels["steer_rate"]
    actual = only(rate, "actual")
    np.testing.assert_allclose(actual[:-1], np.degrees(np.diff(tr["front_steer"]) / np.diff(t)))
    assert np.isnan(actual[-1])
    commanded = only(rate, "commanded")
    np.testing.assert_allclose(commanded[1:], np.degrees(np.diff(tr["front_steer_cmd"]) / np.diff(t)))
    assert np.isnan(commanded[0])
    limit = math.degrees(STEER_RATE_MAX)
    assert np.nanmax(np.abs(actual)) == pytest.approx(limit)  # the fabricated actuator does saturate
    assert np.nanmax(np.abs(commanded)) > 2 * limit  # while the command jumps faster
    limit_lines = [line for line in rate.get_lines() if np.allclose(np.abs(line.get_ydata()), limit)]
    assert len(limit_lines) == 2
    assert "rate limit" in rate.get_legend_handles_labels()[1][-1]
    assert rate.get_ylabel().endswith("[deg/s]")
    # Hitch: the true angle as the line, the measured one as points beside it.
    hitch = panels["hitch"]
    np.testing.assert_allclose(only(hitch, "true"), np.degrees(tr["hitch"]))
    (measured,) = lines(hitch, "measured")
    np.testing.assert_allclose(measured.get_ydata(), np.degrees(tr["hitch_measured"]))
    assert measured.get_linestyle() == "None" and measured.get_alpha() < 1
    assert "measured - true" in hitch.get_title()


def test_a_maneuver_without_the_new_columns_still_plots(parallel: ManeuverResult, figure_of) -> None:
    legacy = without_new_columns(parallel)
    assert not any(name in legacy.trajectory for name in NEW_COLUMNS)
    panels = figure_of(legacy)
    assert list(panels) == ["front_steer", "steer_rate", "rear_speed", "hitch"]
    for ax in panels.values():
        assert not lines(ax, "commanded") and not lines(ax, "actual")
    assert not lines(panels["hitch"], "measured") and not lines(panels["hitch"], "true")
    # The steer here is the command itself, so its rate is that of a command; the ideal plant, no rate limit.
    tr = legacy.trajectory
    rate = only(panels["steer_rate"], "change per step")
    np.testing.assert_allclose(rate[1:], np.degrees(np.diff(tr["front_steer"]) / np.diff(tr["t"])))
    assert not any("limit" in label for label in panels["steer_rate"].get_legend_handles_labels()[1])


@pytest.mark.parametrize(
    "plant", [None, Plant(None), Plant(math.inf), IDEAL], ids=["no plant", "no limit", "inf", "ideal plant"]
)
def test_no_rate_limit_line_without_a_finite_limit(actuated: ManeuverResult, plant: object, figure_of) -> None:
    result = dataclasses.replace(actuated, plant=plant)
    assert steer_rate_limit(result) is None
    labels = figure_of(result)["steer_rate"].get_legend_handles_labels()[1]
    assert labels and not any("limit" in label for label in labels)
    assert steer_rate_limit(dataclasses.replace(actuated, plant=Plant(0.5))) == 0.5
    assert steer_rate_limit(dataclasses.replace(actuated, plant=PlantSettings(steer_rate_max=0.5))) == 0.5


def test_an_old_file_reads_as_the_ideal_plant(parallel: ManeuverResult, figure_of) -> None:
    """A maneuver.json written before the plant existed: the commands acted at once, the hitch was measured exactly."""
    data = parallel.to_dict()
    del data["plant"], data["detail"]
    for name in NEW_COLUMNS:
        del data["trajectory"][name]
    old = ManeuverResult.from_dict(data)
    assert old.plant == IDEAL and steer_rate_limit(old) is None
    tr = old.trajectory
    np.testing.assert_array_equal(tr["front_steer_cmd"], tr["front_steer"])
    np.testing.assert_array_equal(tr["rear_speed_cmd"], tr["rear_speed"])
    np.testing.assert_array_equal(tr["hitch_measured"], tr["hitch"])
    panels = figure_of(old)
    np.testing.assert_allclose(only(panels["front_steer"], "commanded"), only(panels["front_steer"], "actual"))


def test_a_file_saved_before_the_estimates_doubt_reads_with_none(actuated: ManeuverResult) -> None:
    """A maneuver.json without ``hitch_doubt`` (written before the estimator had a doubt): the hitch the controllers
    saw as saved, and a doubt of 0 on every row (the readings were taken as they came)."""
    data = actuated.to_dict()
    del data["trajectory"]["hitch_doubt"]
    old = ManeuverResult.from_dict(data)
    np.testing.assert_array_equal(old.trajectory["hitch_measured"], actuated.trajectory["hitch_measured"])
    assert len(old.trajectory["hitch_doubt"]) == len(old.trajectory) and not np.any(old.trajectory["hitch_doubt"])


def test_each_new_curve_needs_its_own_column(actuated: ManeuverResult, figure_of) -> None:
    columns = {k: v for k, v in actuated.trajectory.columns.items() if k != "hitch_measured"}
    panels = figure_of(dataclasses.replace(actuated, trajectory=Trajectory(columns)))
    assert not lines(panels["hitch"], "measured")
    assert lines(panels["front_steer"], "commanded") and lines(panels["rear_speed"], "commanded")


@pytest.mark.slow
def test_plot_maneuver_writes_the_figures_from_a_saved_file(actuated: ManeuverResult, tmp_path) -> None:
    saved = write_json(tmp_path / "maneuver.json", actuated.to_dict())
    loaded = ManeuverResult.from_dict(read_json(saved))
    assert all(name in loaded.trajectory for name in NEW_COLUMNS)
    for result, folder in ((actuated, "fresh"), (loaded, "loaded")):
        files = plot_maneuver(result, tmp_path / folder)
        assert [f.name for f in files] == ["motion.png", "inputs.png", "nmpc.png"]
        for f in files:
            with Image.open(f) as im:
                assert im.format == "PNG" and im.width > 800 and im.height > 400
    import matplotlib.pyplot as plt

    assert not plt.get_fignums()  # plot_maneuver leaves no figure open
