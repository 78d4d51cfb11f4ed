"""``hitchpark reproduce --suite obstacles``: the scenes of obstacles, their table and summary."""

from __future__ import annotations

import json

import pytest

from hitchpark import InputError
from hitchpark.app import report
from hitchpark.app.report import SUITES, suite_scenarios, suite_table, summary_entry
from hitchpark.control import NMPCSettings
from hitchpark.maneuver import ManeuverSettings, park
from hitchpark.maneuver.scenario import BUILTIN_ORDER, OBSTACLE_SUITE, PLACES_SUITE
from hitchpark.model import IDEAL, State, VehicleTrailer
from hitchpark.model.scene import Obstacle, Scene
from test_cli import run

PAPER = ManeuverSettings(nmpc=NMPCSettings(kind="paper", solver="sqp"))


def test_suites_name_the_builtin_scenarios():
    assert SUITES == {"paper": BUILTIN_ORDER, "obstacles": OBSTACLE_SUITE, "places": PLACES_SUITE}
    assert PLACES_SUITE[:5] == OBSTACLE_SUITE and len(set(PLACES_SUITE)) == 13
    assert all(sc.start_region is not None and not sc.scene.is_empty for sc in suite_scenarios("places"))
    assert OBSTACLE_SUITE == ("driveway", "campsite", "curb_parallel", "bay", "loading_dock")
    assert [sc.name for sc in suite_scenarios("obstacles")] == list(OBSTACLE_SUITE)
    assert all(sc.start_region is not None and not sc.scene.is_empty for sc in suite_scenarios("obstacles"))
    assert [sc.name for sc in suite_scenarios("paper")] == list(BUILTIN_ORDER)
    with pytest.raises(InputError, match="--suite must be one of 'paper', 'obstacles', 'places', got 'all'"):
        suite_scenarios("all", "--suite")


def test_suite_table_rows():
    start = State(6, 3, 0, 0)
    stone = Scene((Obstacle("kerb stone", [[-6.0, 8.0], [-5.0, 8.0], [-5.0, 9.0], [-6.0, 9.0]]),))
    among = park(VehicleTrailer(), start, settings=PAPER, plant=IDEAL, scene=stone, name="stone")
    open_space = park(VehicleTrailer(), start, settings=PAPER, plant=IDEAL, name="open")
    lines = suite_table([among, open_space]).splitlines()
    assert lines[0].split() == [
        "scene",
        "parked",
        "path",
        "[m]",
        "switches",
        "min",
        "clear",
        "[m]",
        "planning",
        "[s]",
        "maneuver",
        "[s]",
    ]
    entry = summary_entry(among, "stone/maneuver.json")
    row = lines[2].split()
    assert row[:2] == ["stone", "yes" if among.success else "no"]
    assert float(row[2]) == pytest.approx(entry["path_length_m"], abs=0.01)
    assert int(row[3]) == among.direction_switches == entry["direction_switches"]
    assert float(row[4]) == pytest.approx(among.min_clearance_m, abs=1e-3)
    assert float(row[5]) == 0.0 == entry["planning_s"]  # the paper's process plans nothing
    assert float(row[6]) == pytest.approx(among.duration, abs=0.1)
    assert lines[3].split()[4] == "-"  # no clearance in open space
    assert summary_entry(open_space, "x")["min_clearance_m"] is None


@pytest.mark.slow
def test_cli_reproduce_suite(tmp_path, capsys, monkeypatch):
    """The command on one scene of the suite (a planned maneuver on the realistic car), JSON only."""
    monkeypatch.setitem(report.SUITES, "obstacles", ("curb_parallel",))
    out = tmp_path / "suite"
    code = run(["reproduce", "--suite", "obstacles", "--out", str(out), "--no-plots"])
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    (entry,) = summary["scenarios"]
    assert code == (0 if entry["success"] else 1)
    assert entry["name"] == "curb_parallel" and entry["file"] == "curb_parallel/maneuver.json"
    saved = json.loads((out / entry["file"]).read_text(encoding="utf-8"))
    assert saved["obstacles"] and saved["min_clearance_m"] == entry["min_clearance_m"] is not None
    assert {"path_length_m", "direction_switches", "collision", "planning_s"} <= set(entry)
    assert entry["collision"] is False and entry["planning_s"] > 0
    printed = capsys.readouterr().out
    assert "Table 5" not in printed and "Suite obstacles" in printed
    header = next(line for line in printed.splitlines() if line.startswith("scene"))
    assert "min clear [m]" in header and "planning [s]" in header and "maneuver [s]" in header
    assert any(line.startswith("curb_parallel") for line in printed.splitlines())
    assert not list(out.rglob("*.png")) and not list(out.rglob("*.gif"))
