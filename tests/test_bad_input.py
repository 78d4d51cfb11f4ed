"""Every class of bad input, one case each: refused on one line with exit status 2 (CLI) or ``InputError`` (API).

The documentation's list of bad-input classes (``docs/reference/bad-input.md``) is this file's ``CLI_CASES``,
``OUTPUT_CASES``, ``FILE_CASES``, ``JSON_CASES`` and ``API_CASES``. A command-line case also checks that nothing
was written. Generated inputs of the same kinds are in ``tests/fuzz`` (``python benchmarks/fuzz_inputs.py`` runs
them at scale).
"""

from __future__ import annotations

import copy
import json
import math
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

import hitchpark
from hitchpark.checks import InputError
from hitchpark.cli import EXIT_BAD_INPUT, main
from hitchpark.control import NMPCSettings, PurePursuitSettings, TrailerNMPC
from hitchpark.io import to_jsonable
from hitchpark.maneuver import ManeuverSettings, SuccessCriteria, park
from hitchpark.maneuver.result import ManeuverResult

V = hitchpark.VehicleTrailer()
START = hitchpark.State(10.0, 3.5, 0.0, 0.0)
PAPER = ManeuverSettings(nmpc=NMPCSettings(kind="paper"))


def sim(*extra: str, **values: str) -> list[str]:
    """A ``simulate`` command line writing {out}/s.json, with some values replaced."""
    options = {"start": "0,0,0,0", "speed": "-1", "steer": "5", "duration": "1", **values}
    argv = ["simulate"]
    for key, value in options.items():
        argv += [f"--{key}", value]
    return [*argv, *extra, "--json", "{out}/s.json"]


def run_cli(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    """Run the command in-process; its exit status and its standard error."""
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse's own refusals
        code = exc.code if isinstance(exc.code, int) else 1
    return code, capsys.readouterr().err


def files_under(folder: Path) -> set[Path]:
    return {p.relative_to(folder) for p in folder.rglob("*")}


def assert_refused(code: int, err: str, match: str) -> None:
    assert code == EXIT_BAD_INPUT, err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert match.lower() in lines[0].lower(), lines[0]


# --- command-line arguments: (class, argv with {out} for the output path, words of the message) -----------

CLI_CASES: list[tuple[str, list[str], str]] = [
    ("pose not numbers", ["park", "--start", "a,b,c,d", "--out", "{out}"], "comma-separated numbers"),
    ("pose of the wrong length", ["park", "--start", "1,2,3", "--out", "{out}"], "4 comma-separated"),
    ("NaN in a pose", ["park", "--start", "nan,0,0,0", "--out", "{out}"], "must be finite"),
    ("negative infinity as a value", sim(speed="-inf"), "must be finite"),
    ("coordinate out of range", ["park", "--start", "1e300,0,0,0", "--out", "{out}"], "start x"),
    ("yaw out of range", ["park", "--start", "10,3,0,0", "--goal", "0,0,1e308", "--out", "{out}"], "goal yaw"),
    ("hitch past the jackknife limit", ["park", "--start", "10,3.5,0,80", "--out", "{out}"], "jackknife"),
    ("steer past its limit", sim(steer="60"), "max_steer"),
    ("speed past 30 m/s", sim(speed="50"), "speed"),
    ("duration of zero", sim(duration="0"), "duration"),
    ("run of more than a day", sim(duration="1e9"), "steps"),
    ("non-positive length", sim("--wheelbase", "-1"), "wheelbase"),
    ("absurd length", sim("--trailer-length", "1e308"), "trailer_length"),
    (
        "L_H = 0 where the inverse kinematics need it",
        ["park", "--start", "10,3,0,0", "--hitch-offset", "0", "--out", "{out}"],
        "hitch_offset",
    ),
    ("case count out of range", ["sweep", "--n", "0", "--seed", "1", "--out", "{out}/s.jsonl"], "n must be"),
    ("negative seed", ["sweep", "--n", "2", "--seed", "-1", "--out", "{out}/s.jsonl"], "seed"),
    ("malformed region", ["sweep", "--n", "2", "--seed", "1", "--region", "x=5", "--out", "{out}/s.jsonl"], "region"),
    (
        "region past the jackknife limit",
        ["sweep", "--n", "2", "--seed", "1", "--region", "hitch=-80:80", "--out", "{out}/s.jsonl"],
        "hitch",
    ),
    (
        "worker count out of range",
        ["sweep", "--n", "2", "--seed", "1", "--workers", "0", "--out", "{out}/s.jsonl"],
        "workers",
    ),
    ("missing required option", ["park", "--start", "10,3,0,0"], "required"),
    ("unknown option", ["park", "--start", "10,3,0,0", "--out", "{out}", "--fast"], "unrecognized"),
    ("not an integer", ["sweep", "--n", "2.5", "--seed", "1", "--out", "{out}/s.jsonl"], "invalid int"),
    (
        "same file for two outputs",
        ["sweep", "--n", "2", "--seed", "1", "--out", "{out}/s.jsonl", "--json", "{out}/s.jsonl"],
        "different files",
    ),
    ("empty output path", ["park", "--start", "10,3,0,0", "--out", ""], "--out is empty"),
    (
        "map of an unknown image format",
        ["sweep", "--n", "2", "--seed", "1", "--out", "{out}/s.jsonl", "--map", "{out}/m.txt"],
        "must end in .png",
    ),
    ("unknown suite", ["reproduce", "--suite", "all", "--out", "{out}"], "--suite must be one of"),
    ("unknown built-in scenario", ["park", "--scenario", "garage", "--out", "{out}"], "nor a built-in scenario"),
    (
        "sweep over a scenario without a start region",
        ["sweep", "--scenario", "parallel", "--n", "2", "--seed", "1", "--out", "{out}/s.jsonl"],
        "has no [start_region]",
    ),
    (
        "region and scenario both",
        ["sweep", "--scenario", "bay", "--region", "x=1:2", "--n", "2", "--seed", "1", "--out", "{out}/s.jsonl"],
        "not both",
    ),
]


# --- output paths that are not a file or folder a command may write ----------------------------------------


def _fifo(path: Path) -> None:
    os.mkfifo(path)


def _link(path: Path) -> None:
    target = path.parent / "elsewhere.json"
    target.write_text("{}", encoding="utf-8")
    path.symlink_to(target)


def _file(path: Path) -> None:
    path.write_text("mine", encoding="utf-8")


OUTPUT_CASES: list[tuple[str, Callable[[Path], None], list[str], str]] = [
    ("FIFO as an output file", _fifo, [*sim()[:-2], "--json", "{path}"], "FIFO"),
    ("symbolic link as an output file", _link, [*sim()[:-2], "--json", "{path}"], "symbolic link"),
    ("file where an output folder belongs", _file, ["park", "--start", "10,3,0,0", "--out", "{path}"], "folder"),
    ("folder where an output file belongs", os.mkdir, [*sim()[:-2], "--json", "{path}"], "folder"),
]


@pytest.mark.parametrize(("make", "argv", "match"), [c[1:] for c in OUTPUT_CASES], ids=[c[0] for c in OUTPUT_CASES])
def test_bad_output_paths(tmp_path, capsys, make, argv, match):
    path = tmp_path / "target"
    make(path)
    before = {
        p: (p.lstat().st_mode, p.read_bytes() if p.is_file() and not p.is_symlink() else b"")
        for p in tmp_path.rglob("*")
    }
    code, err = run_cli([a.replace("{path}", str(path)) for a in argv], capsys)
    assert_refused(code, err, match)
    after = {
        p: (p.lstat().st_mode, p.read_bytes() if p.is_file() and not p.is_symlink() else b"")
        for p in tmp_path.rglob("*")
    }
    assert after == before  # nothing replaced, nothing written through a link


@pytest.mark.parametrize(("argv", "match"), [c[1:] for c in CLI_CASES], ids=[c[0] for c in CLI_CASES])
def test_bad_arguments(tmp_path, capsys, argv, match):
    out = tmp_path / "out"
    code, err = run_cli([a.replace("{out}", str(out)) for a in argv], capsys)
    assert_refused(code, err, match)
    assert files_under(tmp_path) == set()


# --- TOML files: (class, file text, the option that reads it, words of the message) ------------------------

START_TOML = "[start]\nx = 10.0\ny = 3.5\nyaw_deg = 0.0\nhitch_deg = 0.0\n"

FILE_CASES: list[tuple[str, str, str, str]] = [
    ("not TOML", "wheelbase = = 3\n", "--vehicle", "not valid TOML"),
    ("not UTF-8 text", "\udcff", "--vehicle", "not valid TOML"),
    ("unknown key in a file", "wheelbas = 3.0\n", "--vehicle", "unknown key vehicle.wheelbas"),
    ("number given as a string", 'wheelbase = "3.0"\n', "--vehicle", "wheelbase must be a number"),
    ("true/false given for a number", "wheelbase = true\n", "--vehicle", "wheelbase must be a number"),
    ("string given for true/false", START_TOML + '[nmpc]\njit = "false"\n', "--scenario", "nmpc.jit"),
    ("unknown choice", 'kind = "fast"\n', "--plant", "plant.kind must be one of"),
    ("fraction given for an integer", START_TOML + "[nmpc]\nhorizon = 10.5\n", "--scenario", "nmpc.horizon"),
    ("relation between fields", "trailer_front = 3.0\n", "--vehicle", "trailer_front must be < trailer_length"),
    ("value where a table belongs", "start = 5\n", "--scenario", "[start] must be a table"),
    ("list of the wrong length", START_TOML + "[nmpc]\nQ = [1.0, 2.0]\n", "--scenario", "nmpc.Q"),
    ("missing field", "[start]\nx = 1.0\ny = 1.0\nyaw_deg = 0.0\n", "--scenario", "start.hitch_deg is missing"),
    ("name that is not a folder name", 'name = "../up"\n' + START_TOML, "--scenario", "name must be"),
    ("setting past its upper bound", START_TOML + "[forward]\nspeed = 50.0\n", "--scenario", "forward.speed"),
    ("noise past its bound", "hitch_noise_std_deg = 90.0\n", "--plant", "plant.hitch_noise_std_deg"),
    (
        "solver option CasADi refuses, in a file",
        START_TOML + "[nmpc]\nkind = 'paper'\nsolver = 'sqp'\nsolver_options = {max_iter = 'x'}\n",
        "--scenario",
        "illegal type",
    ),
    (
        "self-intersecting obstacle",
        START_TOML + "[[obstacles]]\npolygon = [[0, 0], [1, 1], [1, 0], [0, 1]]\n",
        "--scenario",
        "polygon",
    ),
    (
        "start inside an obstacle",
        START_TOML + "[[obstacles]]\nname = 'shed'\npolygon = [[9, 3], [11, 3], [11, 4], [9, 4]]\n",
        "--scenario",
        "shed",
    ),
    ("missing file", None, "--vehicle", "cannot read"),  # type: ignore[list-item]
]


@pytest.mark.parametrize(("text", "option", "match"), [c[1:] for c in FILE_CASES], ids=[c[0] for c in FILE_CASES])
def test_bad_files(tmp_path, capsys, text, option, match):
    path = tmp_path / "in.toml"
    if text is not None:
        path.write_bytes(text.encode("utf-8", "surrogateescape"))
    before = files_under(tmp_path)
    start = [] if option == "--scenario" else ["--start", "10,3.5,0,0"]
    code, err = run_cli(["park", *start, option, str(path), "--out", str(tmp_path / "out")], capsys)
    assert_refused(code, err, match)
    assert files_under(tmp_path) == before


def test_a_sweep_whose_controller_refuses_its_settings_writes_nothing(tmp_path, capsys):
    """A solver option the controller refuses (riccati_c's, checked when it is built) is refused before the sweep's
    --out file is made: one line, exit status 2, no file."""
    settings = tmp_path / "s.toml"
    settings.write_text("[nmpc.solver_options]\nwhole_steps_only = true\n")
    before = files_under(tmp_path)
    argv = ["sweep", "--n", "2", "--seed", "1", "--settings", str(settings), "--out", str(tmp_path / "s.jsonl")]
    code, err = run_cli(argv, capsys)
    assert_refused(code, err, "option 'whole_steps_only' needs 'warm_iterations'")
    assert files_under(tmp_path) == before


# --- saved maneuvers read back (plot): (class, how the JSON is spoiled, words of the message) ---------------


@pytest.fixture(scope="module")
def saved() -> dict[str, Any]:
    result = park(V, START, settings=PAPER, plant=hitchpark.PlantSettings(kind="ideal"))
    return json.loads(json.dumps(to_jsonable(result.to_dict())))


def _set(path: str, value: Any) -> Callable[[dict[str, Any]], None]:
    def spoil(data: dict[str, Any]) -> None:
        *parents, last = path.split("/")
        node: Any = data
        for key in parents:
            node = node[int(key)] if isinstance(node, list) else node[key]
        if isinstance(node, list):
            node[int(last)] = value
        else:
            node[last] = value

    return spoil


JSON_CASES: list[tuple[str, Callable[[dict[str, Any]], None] | str, str]] = [
    ("not JSON", "{not json", "not JSON text"),
    ("JSON but not an object", "[1, 2, 3]", "not a JSON object"),
    ("required key missing", lambda d: d.pop("trajectory"), "lacks 'trajectory'"),
    ("unknown key in a saved maneuver", _set("extra", 1), "unknown top-level key 'extra'"),
    ("NaN in the start", _set("start/x", math.nan), "start.x must be finite"),
    ("start past the jackknife limit", _set("start/hitch_deg", 500.0), "hitch"),
    ("number as a string in a column", _set("trajectory/hitch/3", "0.5"), "'0.5' among them"),
    ("missing value in a state column", _set("trajectory/x_trailer/3", None), "None among them"),
    ("2-D column", lambda d: d["trajectory"].update(hitch=[[0.0, 0.0]] * len(d["trajectory"]["hitch"])), "1-D"),
    ("columns of different lengths", lambda d: d["trajectory"]["hitch"].pop(), "differ in length"),
    ("time running backwards", _set("trajectory/t/2", -1.0), "must not decrease"),
    ("'false' as a string for a flag", _set("success", "false"), "success must be true or false"),
    ("length of 1e308 in a saved maneuver", _set("vehicle/wheelbase", 1e308), "wheelbase must be"),
    ("unknown outcome", _set("reason", "teleported"), "reason must be one of"),
    ("stages that do not tile the rows", _set("stages/0/last_row", 10**9), "do not follow on"),
    ("stage of an unknown kind", _set("stages/0/kind", "sideways"), "stage.kind"),
    ("a maneuver of a later format", _set("format", "hitchpark-maneuver/2"), "reads 'hitchpark-maneuver/1'"),
    ("another kind of file", _set("format", "hitchpark-sweep-summary/1"), "is not one this version"),
]


def test_a_saved_maneuver_names_its_format_and_one_without_is_read_as_the_first(saved):
    assert saved["format"] == "hitchpark-maneuver/1"
    legacy = {k: v for k, v in saved.items() if k != "format"}  # written before formats had versions
    assert ManeuverResult.from_dict(legacy).to_dict()["format"] == "hitchpark-maneuver/1"


@pytest.mark.parametrize(("spoil", "match"), [c[1:] for c in JSON_CASES], ids=[c[0] for c in JSON_CASES])
def test_bad_saved_maneuvers(tmp_path, capsys, saved, spoil, match):
    path = tmp_path / "maneuver.json"
    if isinstance(spoil, str):
        path.write_text(spoil, encoding="utf-8")
    else:
        data = copy.deepcopy(saved)
        spoil(data)
        path.write_text(json.dumps(data), encoding="utf-8")  # NaN written as NaN, as a hand edit would
        with pytest.raises(InputError, match=None):
            ManeuverResult.from_dict(json.loads(path.read_text(encoding="utf-8")))
    before = files_under(tmp_path)
    code, err = run_cli(["plot", str(path), "--no-animation"], capsys)
    assert_refused(code, err, match)
    assert files_under(tmp_path) == before


# --- the library: (class, call, words of the message) ------------------------------------------------------

API_CASES: list[tuple[str, Callable[[], Any], str]] = [
    ("goal given as a tuple", lambda: park(V, START, goal=(0.0, 0.0, 0.0)), "goal must be a Pose"),
    ("start given as a tuple", lambda: park(V, (10.0, 3.5, 0.0, 0.0)), "start must be a State"),
    ("no vehicle", lambda: park(None, START), "vehicle must be a VehicleTrailer"),
    ("settings of the wrong type", lambda: park(V, START, settings={"nmpc": {}}), "settings must be"),
    ("NaN state", lambda: hitchpark.State(math.nan, 0.0, 0.0, 0.0), "x must be finite"),
    ("NaN yaw of a state", lambda: hitchpark.State(0.0, 0.0, math.nan, 0.0), "yaw must be finite"),
    ("state beyond the coordinate bound", lambda: hitchpark.State(0.0, 1e6, 0.0, 0.0), "y must be"),
    ("state yaw of ten turns and more", lambda: hitchpark.State(0.0, 0.0, 64.0, 0.0), "yaw must be"),
    (
        "NaN angle to the inverse kinematics",
        lambda: hitchpark.virtual_steer_bounds(V, math.nan, 0.5),
        "hitch_angle must be finite",
    ),
    (
        "infinite front steer to Eq. (56)",
        lambda: hitchpark.virtual_steer_from_front(V, 0.1, math.inf),
        "front_steer must be finite",
    ),
    (
        "string angle to the inverse kinematics",
        lambda: hitchpark.front_steer_from_virtual(V, "0.1", 0.0),
        "hitch_angle must be numbers",
    ),
    ("virtual limit past 90 deg", lambda: hitchpark.virtual_steer_bounds(V, 0.1, 2.0), "virtual_limit"),
    ("yaw of 1e300 to a controller step", lambda: TrailerNMPC(V).step(0.0, 0.0, 1e300, 0.0), "yaw"),
    ("controller of the other kind", lambda: TrailerNMPC(V, NMPCSettings()), "needs nmpc.kind 'paper'"),
    ("forward speed past 30 m/s", lambda: PurePursuitSettings(speed=50.0), "forward.speed"),
    ("maneuver time past a day", lambda: SuccessCriteria(max_time=1e300), "success.max_time"),
    ("length of 1e308", lambda: hitchpark.VehicleTrailer(wheelbase=1e308), "wheelbase must be"),
    ("solver options of the wrong shape", lambda: NMPCSettings(solver_options={"tol": object()}), "solver_options.tol"),
    (
        "solver option CasADi refuses",
        lambda: TrailerNMPC(V, NMPCSettings(kind="paper", solver="sqp", solver_options={"qpsol": "x"})),
        "not accepted by sqp: Plugin 'x' is not found",
    ),
    ("plant of the wrong type", lambda: park(V, START, plant="ideal"), "plant must be a PlantSettings"),
]


@pytest.mark.parametrize(("call", "match"), [c[1:] for c in API_CASES], ids=[c[0] for c in API_CASES])
def test_bad_api_calls(call, match):
    with pytest.raises(InputError) as info:
        call()
    message = str(info.value)
    assert "\n" not in message
    assert match.lower() in message.lower(), message


def test_there_are_at_least_forty_classes():
    names = [c[0] for c in (*CLI_CASES, *OUTPUT_CASES, *FILE_CASES, *JSON_CASES, *API_CASES)]
    assert len(names) == len(set(names)) >= 40
