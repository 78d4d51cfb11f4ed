"""A knob-assisted drive as a maneuver (hitchpark.maneuver.assisted) and ``hitchpark assist``: the profile, the
record and its round trip, the wall, the command's output and its refusals."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from hitchpark.assist import OVERRIDES
from hitchpark.checks import InputError
from hitchpark.cli import main
from hitchpark.control.estimator import EstimatorSettings
from hitchpark.maneuver.assisted import KnobProfile, drive_assisted, load_knob_profile
from hitchpark.maneuver.result import ASSIST_COLUMNS, ManeuverResult
from hitchpark.maneuver.scenario import builtin_scenario
from hitchpark.model import PlantSettings, State, VehicleTrailer
from hitchpark.model.scene import Obstacle, Scene

V = VehicleTrailer()
STRAIGHT = State(0.0, 0.0, 0.0, 0.0)


def test_the_profile_holds_each_row_until_the_next_and_stops_after_the_last():
    p = KnobProfile(np.array([0.0, 2.0, 5.0]), np.array([0.0, 1.0, -0.5]), np.array([1.0, 0.5, 0.0]))
    assert p.at(0.0) == (0.0, 1.0) and p.at(1.99) == (0.0, 1.0)
    assert p.at(2.0) == (1.0, 0.5) and p.at(4.9) == (1.0, 0.5)
    assert p.at(5.0) == (-0.5, 0.0) and p.at(9.0) == (-0.5, 0.0)


@pytest.mark.parametrize(
    "text, message",
    [
        ("t,knob,speed\n0,0,1\n", "header must be t,knob,speed_request"),
        ("t,knob,speed_request\n0,1.5,1\n", "knob must be in"),
        ("t,knob,speed_request\n0,0,1\n1,nan,1\n", "knob must be a finite number"),
        ("t,knob,speed_request\n0,0,1\n2,0,1\n2,0,1\n", "t must increase"),
        ("t,knob,speed_request\n1,0,1\n", "t must start at 0"),
        ("t,knob,speed_request\n0,0,-1\n", "speed_request must be in"),
        ("t,knob,speed_request\n0,0\n", "3 values expected"),
        ("t,knob,speed_request\n0,left,1\n", "not numbers"),
        ("t,knob,speed_request\n", "no rows"),
    ],
)
def test_a_bad_profile_is_refused_on_one_line(tmp_path, text, message):
    path = tmp_path / "knob.csv"
    path.write_text(text)
    with pytest.raises(InputError, match=message) as err:
        load_knob_profile(path)
    assert "\n" not in str(err.value)


def test_a_drive_records_the_knob_and_the_overrides_and_reads_back():
    profile = KnobProfile(np.array([0.0, 2.0, 8.0]), np.array([0.0, 1.0, 1.0]), np.array([0.8, 0.8, 0.0]))
    result = drive_assisted(V, STRAIGHT, profile)
    assert result.success and result.reason == "driven"
    assert result.stages[0].controller == "assist"
    tr = result.trajectory
    assert set(ASSIST_COLUMNS) <= set(tr.names)
    assert math.isnan(tr["knob"][-1])  # the last row: no assist step
    codes = tr["override"][:-1]
    assert np.all(np.isin(codes, np.arange(len(OVERRIDES))))
    assert OVERRIDES.index("curvature_limited") in codes  # the knob flicked to full lock is followed at a rate
    assert tr["knob"][0] == 0.0 and tr["knob"][30] == 1.0
    back = ManeuverResult.from_dict(json.loads(json.dumps(result.to_dict())))
    assert back.to_dict() == result.to_dict()
    assert np.max(np.abs(tr["hitch"])) < V.max_hitch


def test_the_figures_of_a_drive_leave_out_the_nmpc_that_did_not_drive(tmp_path):
    from hitchpark.viz.figures import plot_maneuver

    profile = KnobProfile(np.array([0.0, 3.0]), np.array([0.5, 0.5]), np.array([0.8, 0.0]))
    files = plot_maneuver(drive_assisted(V, STRAIGHT, profile), tmp_path)
    assert [f.name for f in files] == ["motion.png", "inputs.png"] and not (tmp_path / "nmpc.png").exists()


def test_a_drive_at_a_wall_ends_stopped_for_the_obstacle_with_no_collision():
    wall = Scene((Obstacle("wall", ((-9.0, -6.0), (-8.0, -6.0), (-8.0, 6.0), (-9.0, 6.0))),))
    # Backing towards it at 1 m/s for 25 s, weaving a little: 7 m of room behind the trailer's rear.
    t = np.array([0.0, 4.0, 8.0, 25.0])
    profile = KnobProfile(t, np.array([0.0, 0.3, -0.3, 0.0]), np.ones(4))
    faults = PlantSettings(delay_steps=1, hitch_noise_std_deg=0.5)
    result = drive_assisted(V, STRAIGHT, profile, scene=wall, plant=faults)
    assert result.reason == "stopped_for_obstacle" and result.success
    assert not result.collision and result.min_clearance_m >= result.settings.success.min_clearance_m


@pytest.mark.slow
@pytest.mark.parametrize("name", ["driveway", "campsite", "curb_parallel", "bay", "loading_dock"])
def test_full_lock_at_the_scene_ends_stopped_for_the_obstacle_on_both_plants(name):
    """From each obstacle scene's start, backing at full lock until something is in the way: on its own plant to
    the left, and to the right on a car with a delay and 0.5 deg of hitch noise, the controller told the noise
    (its estimator). The guard stops the car each time, no nearer than success.min_clearance_m."""
    sc = builtin_scenario(name)
    t = np.array([0.0, 60.0])
    faults = replace(sc.plant, delay_steps=1, hitch_noise_std_deg=0.5)
    told = replace(sc.settings, estimator=EstimatorSettings(hitch_noise_std_deg=0.5))
    for knob, plant, settings in ((1.0, sc.plant, sc.settings), (-1.0, faults, told)):
        profile = KnobProfile(t, np.full(2, knob), np.ones(2))
        result = drive_assisted(
            sc.vehicle, sc.start, profile, goal=sc.goal, settings=settings, plant=plant, scene=sc.scene, name=name
        )
        assert result.reason == "stopped_for_obstacle", (knob, result.reason, result.min_clearance_m)
        assert not result.collision and result.min_clearance_m >= sc.settings.success.min_clearance_m


def test_the_command_writes_the_maneuver_and_refuses_bad_input(tmp_path, capsys):
    knob = tmp_path / "knob.csv"
    knob.write_text("t,knob,speed_request\n0,0,1\n2,-1,1\n6,0,0\n")
    out = tmp_path / "out"
    assert main(["assist", "--scenario", "parallel", "--knob", str(knob), "--out", str(out), "--no-plots"]) == 0
    printed = capsys.readouterr().out
    assert printed.startswith("driven after") and "overrides:" in printed
    data = json.loads((out / "maneuver.json").read_text())
    assert data["reason"] == "driven" and "override" in data["trajectory"]
    assert "knob" in (out / "trajectory.csv").read_text().splitlines()[0].split(",")
    knob.write_text("t,knob,speed_request\n0,0,1\n1,2,1\n")
    assert main(["assist", "--scenario", "parallel", "--knob", str(knob), "--out", str(tmp_path / "o2")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "knob must be in [-1, 1]" in err
    assert not (tmp_path / "o2").exists()
