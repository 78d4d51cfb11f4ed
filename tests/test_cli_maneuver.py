"""The maneuver commands of ``hitchpark`` (reproduce, park, plot), run in-process."""

from __future__ import annotations

import contextlib
import io
import json
import math
from dataclasses import dataclass
from pathlib import Path

import pytest

from hitchpark.cli import EXIT_BAD_INPUT, main
from hitchpark.maneuver.scenario import BUILTIN_ORDER
from test_cli import one_error_line, run
from test_sim import EXPECTED_COLUMNS

# The columns the issue names: those of `simulate` (front_steer and rear_speed the actual values), the commands
# issued and the hitch angle the controller saw (and its doubt), plus the controller's.
TRAJECTORY_COLUMNS = {
    *EXPECTED_COLUMNS,
    "front_steer_cmd",
    "rear_speed_cmd",
    "hitch_measured",
    "hitch_doubt",
    "stage",
    "trailer_speed",
    "virtual_steer",
    "cost",
    "solve_ms",
}
STAGE_KEYS = {"kind", "steps", "distance_error_m", "orientation_error_deg", "final_hitch_deg"}

START = "[start]\nx = 10.0\ny = 3.5\nyaw_deg = 0.0\nhitch_deg = 0.0\n"


@dataclass
class Run:
    code: int
    out: str
    err: str
    folder: Path


def run_captured(argv: list[str], folder: Path) -> Run:
    """Run the CLI with its output captured, for module-scoped fixtures (capsys is per test)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = run(argv)
    return Run(code, out.getvalue(), err.getvalue(), folder)


def read(path: Path) -> dict:
    return json.loads(path.read_text(encoding="utf-8"))


def check_maneuver_file(data: dict) -> None:
    """The maneuver JSON schema that park and reproduce write and plot reads."""
    assert {"vehicle", "start", "goal", "success", "reason", "stages", "trajectory"} <= set(data)
    assert set(data["start"]) == {"x", "y", "yaw_deg", "hitch_deg"}
    assert set(data["goal"]) == {"x", "y", "yaw_deg"}
    assert isinstance(data["success"], bool) and isinstance(data["reason"], str)
    assert data["stages"] and all(STAGE_KEYS <= set(s) for s in data["stages"])
    tr = data["trajectory"]
    assert set(tr) == TRAJECTORY_COLUMNS
    n = len(tr["t"])
    assert n == data["stages"][-1]["last_row"] + 1
    assert all(len(col) == n for col in tr.values())
    # The paper's loop (its NMPC on the ideal plant) solves at every reverse row. On a real car a reverse stage
    # may also stand still: turning the wheels before it moves, braking after it stops; those rows command a
    # stop and have no solve, and the solves form one run between them.
    paper_loop = data["settings"]["nmpc"]["kind"] == "paper" and data["plant"]["kind"] == "ideal"
    solved: dict[int, list[int]] = {}
    for k in range(n - 1):
        index = int(tr["stage"][k])
        kind = data["stages"][index]["kind"]
        if data["stages"][index]["controller"] != "nmpc":  # pursuit or path tracking: no solves
            assert tr["solve_ms"][k] is None, f"row {k}"
        elif kind == "forward" or paper_loop:
            assert (tr["solve_ms"][k] is None) == (kind == "forward"), f"row {k}"
        elif tr["solve_ms"][k] is None:
            assert tr["rear_speed_cmd"][k] == 0.0, f"row {k}"
        if tr["solve_ms"][k] is not None:
            solved.setdefault(index, []).append(k)
    for rows in solved.values():
        assert rows == list(range(rows[0], rows[-1] + 1))
    assert tr["solve_ms"][-1] is None  # the final row is a stop, not a solve
    assert tr["rear_speed"][-1] == 0.0
    for name in TRAJECTORY_COLUMNS - {"solve_ms", "cost"}:
        assert all(isinstance(v, int | float) for v in tr[name]), name


def start_of(data: dict) -> tuple[float, float, float, float]:
    s = data["start"]
    return s["x"], s["y"], s["yaw_deg"], s["hitch_deg"]


@pytest.fixture(scope="module")
def reproduced(tmp_path_factory) -> Run:
    folder = tmp_path_factory.mktemp("reproduce") / "results"
    return run_captured(["reproduce", "--out", str(folder), "--no-plots"], folder)


@pytest.fixture(scope="module")
def parked(tmp_path_factory) -> Run:
    folder = tmp_path_factory.mktemp("park") / "parallel"
    return run_captured(["park", "--start", "10,3.5,0,0", "--out", str(folder), "--no-plots"], folder)


# --- reproduce ---------------------------------------------------------------------------------


def test_reproduce_writes_the_summary(reproduced):
    assert reproduced.code == 0, reproduced.err
    assert reproduced.err == ""
    summary = read(reproduced.folder / "summary.json")
    assert set(summary) == {"scenarios"}
    entries = summary["scenarios"]
    assert [e["name"] for e in entries] == list(BUILTIN_ORDER)
    for entry in entries:
        assert {"name", "file", "success", "stages", "max_abs_front_steer_deg", "max_abs_hitch_deg"} <= set(entry)
        assert entry["success"] is True
        assert [s["kind"] for s in entry["stages"]] == ["reverse", "forward", "reverse"]
        for stage in entry["stages"]:
            assert set(stage) == STAGE_KEYS
            assert isinstance(stage["steps"], int) and stage["steps"] > 0
        assert 0.0 < entry["max_abs_front_steer_deg"] <= math.degrees(0.75) + 1e-9
        assert 0.0 <= entry["max_abs_hitch_deg"] <= 70.0
        assert not Path(entry["file"]).is_absolute()
        path = reproduced.folder / entry["file"]
        assert path.is_file()
        data = read(path)
        check_maneuver_file(data)
        assert data["name"] == entry["name"]
        assert data["success"] is True and data["reason"] == "parked"
        assert [{k: s[k] for k in STAGE_KEYS} for s in data["stages"]] == entry["stages"]
        assert data["goal"] == {"x": 0.0, "y": 0.0, "yaw_deg": 0.0}
        assert data["plant"]["kind"] == "ideal" and data["settings"]["nmpc"]["kind"] == "paper"  # the paper's
    assert not list(reproduced.folder.rglob("*.png")) and not list(reproduced.folder.rglob("*.gif"))


def test_reproduce_prints_table5(reproduced):
    assert "Table 5" in reproduced.out
    table = reproduced.out[reproduced.out.index("Table 5") :]
    for name in BUILTIN_ORDER:
        assert name in table
    assert table.count("(paper)") == 4
    assert str(reproduced.folder / "summary.json") in reproduced.out


# --- park ------------------------------------------------------------------------------------


def test_park_from_a_start(parked):
    assert parked.code == 0, parked.err
    assert parked.err == ""
    data = read(parked.folder / "maneuver.json")
    check_maneuver_file(data)
    assert start_of(data) == (10.0, 3.5, 0.0, 0.0)
    assert data["goal"] == {"x": 0.0, "y": 0.0, "yaw_deg": 0.0}
    assert data["success"] is True and data["stages"][-1]["controller"] == "nmpc"
    # Without a scenario: the full-model NMPC on the realistic car.
    assert data["plant"]["kind"] == "realistic" and data["settings"]["nmpc"]["kind"] == "full"
    assert sorted(p.name for p in parked.folder.iterdir()) == ["maneuver.json", "trajectory.csv"]
    assert "parked" in parked.out and "maneuver.json" in parked.out


def test_park_scenario_with_a_goal(tmp_path, capsys):
    # The parallel start, moved with the goal so that it is the same task: (10, 3.5) in the goal's frame,
    # parked as the built-in scenario is, by the paper's process on the ideal plant.
    gx, gy, gyaw = 1.0, 2.0, math.radians(10.0)
    x = gx + 10.0 * math.cos(gyaw) - 3.5 * math.sin(gyaw)
    y = gy + 10.0 * math.sin(gyaw) + 3.5 * math.cos(gyaw)
    scenario = tmp_path / "moved.toml"
    scenario.write_text(
        f'name = "moved"\n[start]\nx = {x!r}\ny = {y!r}\nyaw_deg = 10.0\nhitch_deg = 0.0\n'
        '[plant]\nkind = "ideal"\n[nmpc]\nkind = "paper"\n',
        encoding="utf-8",
    )
    out = tmp_path / "out"
    code = run(["park", "--scenario", str(scenario), "--goal", "1,2,10", "--out", str(out), "--no-plots"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    data = read(out / "maneuver.json")
    check_maneuver_file(data)
    assert data["name"] == "moved"
    assert data["goal"] == pytest.approx({"x": 1.0, "y": 2.0, "yaw_deg": 10.0})
    assert data["start"] == pytest.approx({"x": x, "y": y, "yaw_deg": 10.0, "hitch_deg": 0.0})
    tr = data["trajectory"]
    assert math.hypot(tr["x_trailer"][-1] - 1.0, tr["y_trailer"][-1] - 2.0) <= 0.005  # parked at the goal
    assert math.degrees(tr["yaw_trailer"][-1]) == pytest.approx(10.0, abs=0.05)


# --- plot --------------------------------------------------------------------------------------


@pytest.mark.slow
def test_plot_a_saved_maneuver(parked, tmp_path, capsys):
    out = tmp_path / "figures"
    assert run(["plot", str(parked.folder / "maneuver.json"), "--out", str(out), "--no-animation"]) == 0
    captured = capsys.readouterr()
    pngs = sorted(out.glob("*.png"))
    assert pngs
    for png in pngs:
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert str(png) in captured.out
    assert not list(out.glob("*.gif"))
    # the source folder untouched
    assert sorted(p.name for p in parked.folder.iterdir()) == ["maneuver.json", "trajectory.csv"]


# --- help ------------------------------------------------------------------------------------


@pytest.mark.parametrize("command", ["reproduce", "park", "plot"])
def test_help_exits_zero(command, capsys):
    with pytest.raises(SystemExit) as exc:
        main([command, "--help"])
    assert exc.value.code == 0
    assert "usage:" in capsys.readouterr().out


# --- bad input: exit 2, one line on stderr naming the problem, no output folder -----------------


def scenario_file(text: str):
    def make(tmp_path: Path) -> list[str]:
        path = tmp_path / "bad.toml"
        path.write_text(text, encoding="utf-8")
        return ["--scenario", str(path)]

    return make


BAD_PARK = {
    "neither start nor scenario": (lambda p: [], "--start"),
    "start hitch of 80 deg": (lambda p: ["--start", "10,3.5,0,80"], "hitch"),
    "goal with 2 numbers": (lambda p: ["--start", "10,3.5,0,0", "--goal", "1,2"], "--goal"),
    "goal with NaN": (lambda p: ["--start", "10,3.5,0,0", "--goal", "1,nan,0"], "--goal"),
    "zero hitch offset": (lambda p: ["--start", "10,3.5,0,0", "--hitch-offset", "0"], "hitch_offset"),
    "missing scenario file": (lambda p: ["--scenario", str(p / "absent.toml")], "cannot read scenario file"),
    "scenario: unknown top-level key": (scenario_file("colour = 'red'\n" + START), "colour"),
    "scenario: unknown key in [nmpc]": (scenario_file(START + "[nmpc]\nhorizn = 3\n"), "nmpc.horizn"),
    "scenario: unknown key in [vehicle]": (scenario_file(START + "[vehicle]\nwheel_base = 3\n"), "wheel_base"),
    "scenario: missing [start]": (scenario_file("[goal]\nx = 1.0\n"), "[start]"),
    "scenario: missing start field": (scenario_file("[start]\nx = 1.0\ny = 0.0\nyaw_deg = 0.0\n"), "hitch_deg"),
    "scenario: string coordinate": (scenario_file(START.replace("x = 10.0", 'x = "ten"')), "start.x"),
    "scenario: nan coordinate": (scenario_file(START.replace("y = 3.5", "y = nan")), "start.y"),
    "scenario: start hitch beyond 70 deg": (scenario_file(START.replace("hitch_deg = 0.0", "hitch_deg = 71")), "hitch"),
    "scenario: zero hitch offset": (scenario_file(START + "[vehicle]\nhitch_offset = 0\n"), "hitch_offset"),
    "scenario: invalid TOML": (scenario_file("[start\n"), "TOML"),
    "scenario: negative nmpc.dt": (scenario_file(START + "[nmpc]\ndt = -0.1\n"), "nmpc.dt"),
}


@pytest.mark.parametrize("case", list(BAD_PARK))
def test_park_bad_input(tmp_path, capsys, case):
    extra, problem = BAD_PARK[case]
    out = tmp_path / "out"
    assert run(["park", *extra(tmp_path), "--out", str(out), "--no-plots"]) == EXIT_BAD_INPUT
    captured = capsys.readouterr()
    line = one_error_line(captured.err)
    assert line.startswith("hitchpark park: error:")
    assert problem in line
    assert captured.out == ""
    assert not out.exists()


def not_a_maneuver(tmp_path: Path) -> Path:
    path = tmp_path / "simulation.json"
    path.write_text(json.dumps({"vehicle": {}, "start": {}, "trajectory": {"t": [0.0]}}), encoding="utf-8")
    return path


def a_list(tmp_path: Path) -> Path:
    path = tmp_path / "list.json"
    path.write_text("[1, 2, 3]\n", encoding="utf-8")
    return path


def not_json(tmp_path: Path) -> Path:
    path = tmp_path / "notes.json"
    path.write_text("parked, more or less\n", encoding="utf-8")
    return path


BAD_PLOT = {
    "missing file": (lambda p: p / "absent.json", "cannot read"),
    "JSON that is not a maneuver": (not_a_maneuver, "not a hitchpark maneuver"),
    "JSON list": (a_list, "not a hitchpark maneuver"),
    "not JSON at all": (not_json, "not a hitchpark maneuver"),
}


@pytest.mark.parametrize("case", list(BAD_PLOT))
def test_plot_bad_input(tmp_path, capsys, case):
    make, problem = BAD_PLOT[case]
    path = make(tmp_path)
    out = tmp_path / "figures"
    assert run(["plot", str(path), "--out", str(out), "--no-animation"]) == EXIT_BAD_INPUT
    captured = capsys.readouterr()
    line = one_error_line(captured.err)
    assert line.startswith("hitchpark plot: error:")
    assert problem in line and path.name in line
    assert captured.out == ""
    assert not out.exists()


def test_plot_binary_file_names_the_file(tmp_path, capsys):
    path = tmp_path / "picture.json"
    path.write_bytes(b"\x89PNG\r\n\x1a\n\x00\x00")
    assert run(["plot", str(path), "--no-animation"]) == EXIT_BAD_INPUT
    assert "picture.json" in one_error_line(capsys.readouterr().err)


def test_reproduce_leaves_nothing_half_written(tmp_path, capsys):
    """A clash inside --out is found before anything is published: the folder stays as it was."""
    out = tmp_path / "rep"
    out.mkdir()
    (out / BUILTIN_ORDER[2]).write_text("a file where a scenario folder goes")
    assert run(["reproduce", "--out", str(out), "--no-plots"]) == EXIT_BAD_INPUT
    assert "in the way" in one_error_line(capsys.readouterr().err)
    assert [p.name for p in out.iterdir()] == [BUILTIN_ORDER[2]]


def test_park_out_is_a_file(tmp_path, capsys):
    target = tmp_path / "file"
    target.write_text("keep")
    assert run(["park", "--start", "10,3.5,0,0", "--out", str(target), "--no-plots"]) == EXIT_BAD_INPUT
    assert "not a folder" in one_error_line(capsys.readouterr().err)
    assert target.read_text() == "keep"


@pytest.mark.parametrize(
    ("argv", "problem"),
    [
        (["simulate", "--start", "0,0,0,0", "--speed", "-1", "--steer", "10", "--duration", "1e308"], "steps"),
        (
            ["simulate", "--start", "0,0,0,0", "--speed", "-1", "--steer", "10", "--duration", "1", "--dt", "1e-320"],
            "dt",
        ),
        (["simulate", "--start", "0,0,0,0", "--speed", "1e308", "--steer", "10", "--duration", "1"], "speed"),
        (["simulate", "--start", "1e300,0,0,0", "--speed", "-1", "--steer", "10", "--duration", "1"], "start x"),
        (["simulate", "--start", "0,0,1e300,0", "--speed", "-1", "--steer", "10", "--duration", "1"], "start yaw"),
    ],
)
def test_simulate_huge_inputs(tmp_path, capsys, argv, problem):
    out = tmp_path / "run.json"
    assert run([*argv, "--json", str(out)]) == EXIT_BAD_INPUT
    assert problem in one_error_line(capsys.readouterr().err)
    assert not out.exists()


@pytest.mark.parametrize(
    ("extra", "problem"), [(["--goal", "0,0,1e308"], "goal yaw"), (["--start", "1e300,0,0,0"], "x")]
)
def test_park_huge_inputs(tmp_path, capsys, extra, problem):
    argv = ["park", "--start", "10,3.5,0,0", *extra, "--out", str(tmp_path / "out"), "--no-plots"]
    assert run(argv) == EXIT_BAD_INPUT
    assert problem in one_error_line(capsys.readouterr().err)
    assert not (tmp_path / "out").exists()


def test_ik_study_zero_speed(tmp_path, capsys):
    assert run(["ik-study", "--out", str(tmp_path / "ik"), "--speed", "0", "--no-plots"]) == EXIT_BAD_INPUT
    assert "speed" in one_error_line(capsys.readouterr().err)
    assert not (tmp_path / "ik").exists()


def test_scenario_name_must_be_a_plain_folder_name(tmp_path, capsys):
    path = tmp_path / "evil.toml"
    path.write_text('name = "../escape"\n[start]\nx = 10.0\ny = 3.5\nyaw_deg = 0.0\nhitch_deg = 0.0\n')
    assert run(["park", "--scenario", str(path), "--out", str(tmp_path / "out"), "--no-plots"]) == EXIT_BAD_INPUT
    assert "name" in one_error_line(capsys.readouterr().err)


def test_park_csv_matches_the_json(parked):
    import numpy as np

    data = read(parked.folder / "maneuver.json")["trajectory"]
    with open(parked.folder / "trajectory.csv", encoding="utf-8") as fh:
        header = fh.readline().strip().split(",")
    table = np.loadtxt(parked.folder / "trajectory.csv", delimiter=",", skiprows=1)
    assert header == list(data)
    for i, name in enumerate(header):
        column = np.array([np.nan if v is None else v for v in data[name]], dtype=float)
        np.testing.assert_allclose(table[:, i], column, rtol=1e-15, equal_nan=True)


def test_a_bug_is_not_reported_as_bad_input(tmp_path, monkeypatch):
    """Only InputError means bad input (exit 2); any other exception is a bug and propagates."""
    import hitchpark.maneuver.process as process

    def broken(*args, **kwargs):
        raise ValueError("internal bug")

    monkeypatch.setattr(process, "park", broken)
    with pytest.raises(ValueError, match="internal bug"):
        main(["park", "--start", "10,3.5,0,0", "--out", str(tmp_path / "out"), "--no-plots"])
    assert not (tmp_path / "out").exists()
