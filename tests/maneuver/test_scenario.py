"""Scenario files (hitchpark.maneuver.scenario): the four built-ins, a user file, and bad files."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from hitchpark.control import NMPCSettings
from hitchpark.control.pure_pursuit import PurePursuitSettings
from hitchpark.maneuver import ManeuverSettings, SuccessCriteria, builtin_scenarios, load_scenario
from hitchpark.maneuver.scenario import BUILTIN_ORDER
from hitchpark.model import IDEAL, PlantSettings, Pose, VehicleTrailer

# The starts each shipped file documents in its comments and description: (x, y, yaw_deg, hitch_deg).
DOCUMENTED_STARTS = {
    "parallel": (10.0, 3.5, 0.0, 0.0),
    "parallel_hitch": (6.0, -3.5, 0.0, -20.0),
    "perpendicular": (6.0, 6.0, 90.0, 0.0),
    "random": (11.96, -1.42, 39.26, 16.86),
}

START = "[start]\nx = 10.0\ny = 3.5\nyaw_deg = 0.0\nhitch_deg = 0.0\n"

USER_FILE = """\
name = "kerbside"
description = "a user scenario"

[start]
x = 8.5
y = -2.0
yaw_deg = 15.0
hitch_deg = -5.0

[goal]
x = 1.0
y = 2.0
yaw_deg = 10.0

[vehicle]
wheelbase = 3.0
hitch_offset = 1.0
trailer_length = 2.5
max_steer = 0.6

[plant]
delay_steps = 1
hitch_noise_std_deg = 0.5

[plant.vehicle]
hitch_offset = 1.1

[nmpc]
kind = "paper"
dt = 0.05
horizon = 20
Q = [1.0, 5.0, 5.0]
R = [0.0, 0.2]
P = [2.0, 20.0, 20.0]
speed_min = -0.5
virtual_limit = 0.4
stop_speed = 0.002
max_steps = 900
solver = "ipopt"
fallback_solver = "sqp"
transcription = "single_shooting"

[forward]
lookahead = 4.0
speed = 0.5
distance_threshold = 7.0

[success]
distance = 0.02
max_stages = 5
"""


def write(tmp_path: Path, text: str, name: str = "scenario.toml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def test_builtins_load_with_the_documented_starts():
    scenarios = builtin_scenarios()
    assert [sc.name for sc in scenarios] == list(BUILTIN_ORDER)
    for sc in scenarios:
        x, y, yaw_deg, hitch_deg = DOCUMENTED_STARTS[sc.name]
        assert (sc.start.x, sc.start.y) == (x, y)
        assert sc.start.yaw == pytest.approx(math.radians(yaw_deg), abs=1e-15)
        assert sc.start.hitch == pytest.approx(math.radians(hitch_deg), abs=1e-15)
        assert sc.goal == Pose()
        assert sc.vehicle == VehicleTrailer()  # Table 4
        # The paper's process: Table 4's NMPC and the forward-stage defaults, on the ideal plant.
        assert sc.settings == ManeuverSettings(nmpc=NMPCSettings(kind="paper"))
        assert sc.plant == IDEAL
        assert sc.description
        assert sc.path is not None and sc.path.name == f"{sc.name}.toml"


def test_user_file_round_trip(tmp_path):
    path = write(tmp_path, USER_FILE)
    sc = load_scenario(path)
    assert sc.name == "kerbside" and sc.description == "a user scenario" and sc.path == path
    assert (sc.start.x, sc.start.y) == (8.5, -2.0)
    assert sc.start.yaw == pytest.approx(math.radians(15.0))
    assert sc.start.hitch == pytest.approx(math.radians(-5.0))
    assert sc.goal == Pose(1.0, 2.0, math.radians(10.0))
    assert sc.vehicle == VehicleTrailer(wheelbase=3.0, hitch_offset=1.0, trailer_length=2.5, max_steer=0.6)
    assert sc.plant == PlantSettings(vehicle={"hitch_offset": 1.1}, delay_steps=1, hitch_noise_std_deg=0.5)
    assert sc.settings.nmpc == NMPCSettings(
        kind="paper",
        dt=0.05,
        horizon=20,
        Q=(1.0, 5.0, 5.0),
        R=(0.0, 0.2),
        P=(2.0, 20.0, 20.0),
        speed_min=-0.5,
        virtual_limit=0.4,
        stop_speed=0.002,
        max_steps=900,
        solver="ipopt",
        fallback_solver="sqp",
        transcription="single_shooting",
    )
    assert sc.settings.forward == PurePursuitSettings(lookahead=4.0, speed=0.5, distance_threshold=7.0)
    assert sc.settings.success == SuccessCriteria(distance=0.02, max_stages=5)


def test_minimal_file_takes_the_defaults(tmp_path):
    sc = load_scenario(write(tmp_path, START + "[goal]\ny = -1.5\n", name="my_space.toml"))
    assert sc.name == "my_space"  # from the file name
    assert sc.goal == Pose(0.0, -1.5, 0.0)
    assert sc.vehicle == VehicleTrailer()
    assert sc.settings == ManeuverSettings()  # the full-model NMPC
    assert sc.plant == PlantSettings()  # the realistic car


BAD_FILES = {
    "unknown top-level key": ("colour = 'red'\n" + START, "colour"),
    "unknown key in [start]": (START + "z = 1.0\n", "start.z"),
    "unknown key in [nmpc]": (START + "[nmpc]\nhorizn = 12\n", "nmpc.horizn"),
    "unknown key in [vehicle]": (START + "[vehicle]\nwheel_base = 3.0\n", "wheel_base"),
    "unknown key in [goal]": (START + "[goal]\nhitch_deg = 3.0\n", "goal.hitch_deg"),
    "missing [start]": ("[goal]\nx = 1.0\n", r"\[start\] is missing"),
    "missing start field": ("[start]\nx = 10.0\ny = 3.5\nyaw_deg = 0.0\n", "start.hitch_deg is missing"),
    "string coordinate": (START.replace("x = 10.0", 'x = "10"'), "start.x"),
    "boolean coordinate": (START.replace("y = 3.5", "y = true"), "start.y"),
    "nan coordinate": (START.replace("yaw_deg = 0.0", "yaw_deg = nan"), "start.yaw_deg"),
    "inf goal": (START + "[goal]\nx = inf\n", "goal.x"),
    "start hitch beyond 70 deg": (START.replace("hitch_deg = 0.0", "hitch_deg = 72.0"), "hitch"),
    "zero hitch offset": (START + "[vehicle]\nhitch_offset = 0.0\n", "hitch_offset"),
    "negative wheelbase": (START + "[vehicle]\nwheelbase = -3.0\n", "wheelbase"),
    "invalid TOML": ("[start\nx = 1\n", "not valid TOML"),
    "negative nmpc.dt": (START + "[nmpc]\ndt = -0.1\n", "nmpc.dt"),
    "nmpc horizon not an integer": (START + "[nmpc]\nhorizon = 10.5\n", "nmpc.horizon"),
    "Q of wrong length": (START + "[nmpc]\nQ = [1.0, 10.0]\n", "nmpc.Q"),
    "unknown solver": (START + "[nmpc]\nsolver = 'fmincon'\n", "nmpc.solver"),
    "solver options not a table": (START + "[nmpc]\nsolver_options = 'fast'\n", "nmpc.solver_options"),
    "solver option of a table type": (START + "[nmpc]\nsolver_options = {tol = [{a = 1}]}\n", "solver_options.tol"),
    "non-positive forward speed": (START + "[forward]\nspeed = 0.0\n", "forward.speed"),
    "zero max_stages": (START + "[success]\nmax_stages = 0\n", "success.max_stages"),
    "start not a table": ("start = 5\n", r"\[start\] must be a table"),
    "empty name": ("name = ''\n" + START, "name"),
}


@pytest.mark.parametrize("case", list(BAD_FILES))
def test_bad_file_raises_a_value_error_naming_the_problem(tmp_path, case):
    text, message = BAD_FILES[case]
    path = write(tmp_path, text)
    with pytest.raises(ValueError, match=message) as exc:
        load_scenario(path)
    assert str(path) in str(exc.value)  # and the file


def test_missing_file(tmp_path):
    path = tmp_path / "absent.toml"
    with pytest.raises(ValueError, match="cannot read scenario file") as exc:
        load_scenario(path)
    assert str(path) in str(exc.value)


def test_folder_instead_of_file(tmp_path):
    with pytest.raises(ValueError, match="cannot read scenario file"):
        load_scenario(tmp_path)


@pytest.mark.parametrize("value", ['["a", 10.0, 10.0]', "5", "[true, 10.0, 10.0]"])
def test_bad_weight_entries_name_the_weight(tmp_path, value):
    with pytest.raises(ValueError, match=r"nmpc\.Q"):
        load_scenario(write(tmp_path, START + f"[nmpc]\nQ = {value}\n"))


def test_a_settings_file_turns_the_fallback_and_relaxed_solvers_off_with_none(tmp_path):
    """TOML has no null: ``"none"`` is None (no second solver), as the error for a wrong name says it may be."""
    text = START + '[nmpc]\nfallback_solver = "none"\nrelaxed_solver = "none"\n'
    nmpc = load_scenario(write(tmp_path, text, name="off.toml")).settings.nmpc
    assert nmpc.fallback_solver is None and nmpc.relaxed_solver is None
    assert nmpc == NMPCSettings(fallback_solver=None, relaxed_solver=None)
