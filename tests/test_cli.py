"""Smoke tests of the ``hitchpark`` command (hitchpark.cli), run in-process and once as a subprocess."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

from hitchpark.cli import EXIT_BAD_INPUT, main, parse_start

SIM_DEFAULTS = {"--start": "0,0,0,0", "--speed": "-1", "--steer": "5", "--duration": "1"}


def run(argv: list[str]) -> int:
    """Call the CLI in-process; argparse's own exits come back as their status."""
    try:
        return main(argv)
    except SystemExit as exc:
        return exc.code if isinstance(exc.code, int) else 1


def simulate_argv(json_path: Path, **overrides: str) -> list[str]:
    options = {**SIM_DEFAULTS, **{"--" + k.replace("_", "-"): v for k, v in overrides.items()}}
    argv = ["simulate"]
    for flag, value in options.items():
        argv += [flag, value]
    return [*argv, "--json", str(json_path)]


def one_error_line(err: str) -> str:
    lines = err.splitlines()
    assert len(lines) == 1, err
    assert "Traceback" not in err
    return lines[0]


# --- good runs ---------------------------------------------------------------------------------


def test_simulate_writes_json(tmp_path, capsys):
    out = tmp_path / "sub" / "run.json"
    assert run(simulate_argv(out, start="1,2,10,-5", duration="2", dt="0.5")) == 0
    data = json.loads(out.read_text(encoding="utf-8"))
    assert {"vehicle", "start", "trajectory", "reason"} <= set(data)
    assert data["vehicle"]["wheelbase"] == 2.896
    assert data["start"] == pytest.approx({"x": 1.0, "y": 2.0, "yaw_deg": 10.0, "hitch_deg": -5.0})
    assert data["reason"] == "completed"
    tr = data["trajectory"]
    assert tr["t"] == pytest.approx([0.0, 0.5, 1.0, 1.5, 2.0])
    assert tr["front_steer"][0] == pytest.approx(math.radians(5.0))
    assert tr["rear_speed"][:-1] == [-1.0] * 4
    assert tr["yaw_trailer"][0] == pytest.approx(math.radians(10.0))
    assert tr["hitch"][0] == pytest.approx(math.radians(-5.0))
    captured = capsys.readouterr()
    assert str(out) in captured.out
    assert captured.err == ""


@pytest.mark.parametrize("form", ["separate", "equals"])
def test_negative_start_parses(tmp_path, form):
    out = tmp_path / "run.json"
    argv = simulate_argv(out)
    i = argv.index("--start")
    if form == "separate":
        argv[i + 1] = "-5,2,0,0"
    else:
        argv[i : i + 2] = ["--start=-5,2,0,0"]
    assert run([*argv, "--steer", "-5"]) == 0
    data = json.loads(out.read_text(encoding="utf-8"))
    assert data["start"]["x"] == -5.0
    assert data["trajectory"]["front_steer"][0] == pytest.approx(math.radians(-5.0))


def test_parse_start_units():
    state = parse_start("-1.5,2e0,90,-30")
    assert (state.x, state.y) == (-1.5, 2.0)
    assert state.yaw == pytest.approx(math.pi / 2)
    assert state.hitch == pytest.approx(-math.pi / 6)


def test_vehicle_file_with_command_line_override(tmp_path):
    car = tmp_path / "car.toml"
    car.write_text("wheelbase = 3.0\nhitch_offset = 0.5\n", encoding="utf-8")
    out = tmp_path / "run.json"
    assert run([*simulate_argv(out), "--vehicle", str(car), "--wheelbase", "3.5"]) == 0
    vehicle = json.loads(out.read_text(encoding="utf-8"))["vehicle"]
    assert vehicle["wheelbase"] == 3.5  # the command line wins over the file
    assert vehicle["hitch_offset"] == 0.5  # the file wins over the default
    assert vehicle["trailer_length"] == 2.693


def test_jackknife_run_is_reported(tmp_path, capsys):
    out = tmp_path / "run.json"
    assert run(simulate_argv(out, steer="30", duration="60")) == 0
    assert json.loads(out.read_text(encoding="utf-8"))["reason"] == "jackknife"
    assert "jackknife" in capsys.readouterr().out


@pytest.mark.parametrize("command", [[], ["simulate"], ["ik-study"]])
def test_help_exits_zero(command, capsys):
    with pytest.raises(SystemExit) as exc:
        main([*command, "--help"])
    assert exc.value.code == 0
    assert "usage:" in capsys.readouterr().out


def test_no_command_is_a_usage_error(capsys):
    assert run([]) == EXIT_BAD_INPUT
    assert "error" in one_error_line(capsys.readouterr().err)


def test_ik_study_writes_json(tmp_path, capsys):
    out = tmp_path / "ik"
    assert run(["ik-study", "--out", str(out), "--no-plots"]) == 0
    data = json.loads((out / "ik_study.json").read_text(encoding="utf-8"))
    assert data["max_virtual_steer_error_rad"] < 1e-9
    assert data["max_trailer_position_error_m"] < 1e-9
    assert data["vehicle"]["wheelbase"] == 3.0
    assert not (out / "ik_study.png").exists()
    assert "ik_study.json" in capsys.readouterr().out


# --- bad input: exit 2, one line on stderr naming the field, output untouched ------------------------


def _misspelt_toml(tmp_path: Path) -> list[str]:
    path = tmp_path / "misspelt.toml"
    path.write_text("wheelbse = 3.0\n", encoding="utf-8")
    return ["--vehicle", str(path)]


def _steep_steer_toml(tmp_path: Path) -> list[str]:
    path = tmp_path / "steep.toml"
    path.write_text("max_steer = 1.6\n", encoding="utf-8")
    return ["--vehicle", str(path)]


def _invalid_toml(tmp_path: Path) -> list[str]:
    path = tmp_path / "broken.toml"
    path.write_text("wheelbase = = 3\n", encoding="utf-8")
    return ["--vehicle", str(path)]


BAD_INPUTS = {
    "negative wheelbase": (lambda p: ["--wheelbase", "-1"], "wheelbase"),
    "zero wheelbase": (lambda p: ["--wheelbase", "0"], "wheelbase"),
    "NaN wheelbase": (lambda p: ["--wheelbase", "nan"], "wheelbase"),
    "text wheelbase": (lambda p: ["--wheelbase", "abc"], "wheelbase"),
    "negative hitch offset": (lambda p: ["--hitch-offset", "-1"], "hitch_offset"),
    "zero trailer length": (lambda p: ["--trailer-length", "0"], "trailer_length"),
    "length tolerance past a half": (lambda p: ["--length-tolerance", "0.8"], "length_tolerance"),
    "negative length tolerance": (lambda p: ["--length-tolerance", "-0.1"], "length_tolerance"),
    "NaN in start": (lambda p: ["--start", "0,nan,0,0"], "start"),
    "inf in start": (lambda p: ["--start", "inf,0,0,0"], "start"),
    "start with 3 numbers": (lambda p: ["--start", "1,2,3"], "start"),
    "start with 5 numbers": (lambda p: ["--start", "1,2,3,4,5"], "start"),
    "start with text": (lambda p: ["--start", "1,two,3,4"], "start"),
    "start hitch beyond 70 deg": (lambda p: ["--start", "0,0,0,75"], "hitch"),
    "negative start hitch beyond 70 deg": (lambda p: ["--start", "0,0,0,-71"], "hitch"),
    "steer past max_steer": (lambda p: ["--steer", "50"], "steer"),
    "negative steer past max_steer": (lambda p: ["--steer", "-43"], "steer"),
    "NaN speed": (lambda p: ["--speed", "nan"], "speed"),
    "zero duration": (lambda p: ["--duration", "0"], "duration"),
    "negative dt": (lambda p: ["--dt", "-0.1"], "dt"),
    "misspelt vehicle field": (_misspelt_toml, "wheelbse"),
    "max_steer of 1.6 rad in file": (_steep_steer_toml, "max_steer"),
    "invalid TOML": (_invalid_toml, "TOML"),
    "missing vehicle file": (lambda p: ["--vehicle", str(p / "absent.toml")], "vehicle file"),
    "vehicle file is a folder": (lambda p: ["--vehicle", str(p)], "vehicle file"),
}


@pytest.mark.parametrize("existing", [False, True], ids=["new-target", "existing-target"])
@pytest.mark.parametrize("case", list(BAD_INPUTS))
def test_bad_input_exits_2_with_one_line(tmp_path, capsys, case, existing):
    extra, field = BAD_INPUTS[case]
    out = tmp_path / "out" / "run.json"
    if existing:
        out.parent.mkdir()
        out.write_text("previous result\n", encoding="utf-8")
    argv = [*simulate_argv(out), *extra(tmp_path)]  # later options override the defaults
    assert run(argv) == EXIT_BAD_INPUT
    captured = capsys.readouterr()
    line = one_error_line(captured.err)
    assert field in line
    assert line.startswith("hitchpark")
    assert captured.out == ""
    if existing:
        assert out.read_text(encoding="utf-8") == "previous result\n"
        assert sorted(p.name for p in out.parent.iterdir()) == ["run.json"]  # no temporary left behind
    else:
        assert not out.exists()


def test_ik_study_bad_speed(tmp_path, capsys):
    assert run(["ik-study", "--out", str(tmp_path / "ik"), "--speed", "nan", "--no-plots"]) == EXIT_BAD_INPUT
    assert "speed" in one_error_line(capsys.readouterr().err)
    assert not (tmp_path / "ik").exists()


def test_unwritable_json_target_is_a_clean_error(tmp_path, capsys):
    target = tmp_path / "folder"
    target.mkdir()
    assert run(simulate_argv(target)) == EXIT_BAD_INPUT
    assert "is a folder; it must be a file" in one_error_line(capsys.readouterr().err)  # refused before it runs
    assert target.is_dir() and not any(target.iterdir())


def test_ik_study_out_is_a_file_is_a_clean_error(tmp_path, capsys):
    target = tmp_path / "f"
    target.write_text("keep")
    assert run(["ik-study", "--out", str(target), "--no-plots"]) == EXIT_BAD_INPUT
    assert "not a folder" in one_error_line(capsys.readouterr().err)
    assert target.read_text() == "keep"


def test_simulate_too_many_steps_is_a_clean_error(tmp_path, capsys):
    out = tmp_path / "run.json"
    argv = simulate_argv(out)
    argv[argv.index("--duration") + 1] = "1e15"
    assert run(argv) == EXIT_BAD_INPUT
    assert "steps" in one_error_line(capsys.readouterr().err)
    assert not out.exists()


# --- as a separate process -------------------------------------------------------------------


def test_module_entry_point_bad_input_without_traceback(tmp_path):
    out = tmp_path / "run.json"
    proc = subprocess.run(
        [sys.executable, "-m", "hitchpark.cli", *simulate_argv(out, wheelbase="-1")],
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == EXIT_BAD_INPUT
    assert "wheelbase" in one_error_line(proc.stderr)
    assert proc.stdout == ""
    assert not out.exists()


def test_module_entry_point_runs(tmp_path):
    out = tmp_path / "run.json"
    proc = subprocess.run(
        [sys.executable, "-m", "hitchpark.cli", *simulate_argv(out, start="-5,2,0,0")],
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == ""
    assert json.loads(out.read_text(encoding="utf-8"))["start"]["x"] == -5.0
