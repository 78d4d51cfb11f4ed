"""Generated bad input: malformed command lines, TOML files, saved maneuvers and API calls.

Each example must meet the contract of ``fuzz_contract``: accepted (the work is reached), or refused
with exit status 2 / ``InputError`` on one line, no traceback, nothing written. Most examples are
one mutation away from a valid input, where checks are most likely to slip.
"""

from __future__ import annotations

import copy
import json
import math
from pathlib import Path
from typing import Any

import pytest
from fuzz_contract import FUZZ, check_call, check_command
from hypothesis import given
from hypothesis import strategies as st

import hitchpark
from hitchpark.control import NMPCSettings, PurePursuitSettings
from hitchpark.io import to_jsonable
from hitchpark.maneuver import ManeuverSettings, SuccessCriteria, park
from hitchpark.maneuver.result import ManeuverResult

# --- values a user might type or a file might hold ---------------------------------------------------------

NASTY_TEXT = st.sampled_from(
    [
        "",
        " ",
        "nan",
        "NaN",
        "-nan",
        "inf",
        "-inf",
        "+inf",
        "infinity",
        "-Infinity",
        "1e308",
        "-1e308",
        "1e-320",
        "0",
        "-0",
        "1e9",
        "-1e9",
        "abc",
        "1,2",
        "1,,2",
        "0x10",
        "1_000",
        "\uff19",
        "--",
        "-",
        "1e",
        ".",
        "1..2",
        "3,4,5,6,7",
        "0,0,0",
        "10,3.5,0,0",
        "10,3.5,0,89",
        "-5,2,0,0",
        "x=5",
        "x=1:2:3",
        "hitch=-80:80",
        "yaw=a:b",
        "x=16:4",
        "/dev/null",
        "\x00",
        "é",
        "1 2",
    ]
)
TEXT = st.one_of(NASTY_TEXT, st.text(max_size=12), st.floats().map(repr), st.integers().map(str))

JSON_SCALAR = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(min_value=-(10**20), max_value=10**20),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=8),
    st.sampled_from([1e308, -1e308, 5e-324, 0.0, -0.0, "0.5", "false", "true", "nan"]),
)
JSON_VALUE = st.recursive(
    JSON_SCALAR,
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=6), inner, max_size=4),
    max_leaves=10,
)


# --- command lines ----------------------------------------------------------------------------------------


def _commands(out: str) -> dict[str, list[str]]:
    """A valid command line of each command, writing under ``out``."""
    return {
        "simulate": [
            "simulate",
            "--start",
            "0,0,0,0",
            "--speed",
            "-1",
            "--steer",
            "5",
            "--duration",
            "1",
            "--dt",
            "0.1",
            "--wheelbase",
            "3",
            "--hitch-offset",
            "1",
            "--trailer-length",
            "2.5",
            "--json",
            f"{out}/s.json",
        ],
        "park": ["park", "--start", "10,3.5,0,0", "--goal", "0,0,0", "--out", f"{out}/park", "--no-plots"],
        "sweep": [
            "sweep",
            "--n",
            "3",
            "--seed",
            "1",
            "--region",
            "x=4:16,y=-8:8,yaw=-90:90,hitch=-30:30",
            "--workers",
            "1",
            "--out",
            f"{out}/s.jsonl",
            "--json",
            f"{out}/sum.json",
        ],
        "reproduce": ["reproduce", "--out", f"{out}/rep", "--no-plots"],
        "ik-study": ["ik-study", "--out", f"{out}/ik", "--speed", "-1", "--no-plots"],
    }


EXTRA_OPTIONS = [
    "--start",
    "--goal",
    "--speed",
    "--steer",
    "--duration",
    "--dt",
    "--n",
    "--seed",
    "--region",
    "--workers",
    "--wheelbase",
    "--hitch-offset",
    "--trailer-length",
    "--fast",
    "-x",
    "--dask",
]


@st.composite
def mutated_command(draw: st.DrawFn, out: str) -> list[str]:
    argv = list(_commands(out)[draw(st.sampled_from(sorted(_commands(out))))])
    for _ in range(draw(st.integers(1, 3))):
        kind = draw(st.sampled_from(["replace", "replace", "replace", "drop", "insert", "duplicate"]))
        i = draw(st.integers(1, len(argv) - 1))
        if kind == "replace" and not argv[i].startswith(("--json", "--out")) and argv[i - 1] not in ("--json", "--out"):
            argv[i] = draw(TEXT)
        elif kind == "drop":
            del argv[i]
        elif kind == "insert":
            argv[i:i] = [draw(st.sampled_from(EXTRA_OPTIONS)), draw(TEXT)]
        elif kind == "duplicate" and argv[i].startswith("--") and i + 1 < len(argv):
            argv += [argv[i], draw(TEXT)]
        if len(argv) < 2:
            break
    return argv


@FUZZ
@given(data=st.data())
def test_generated_command_lines(tmp_path_factory, capsys, data):
    folder: Path = tmp_path_factory.mktemp("cli")
    argv = data.draw(mutated_command(str(folder)))
    check_command("command lines", [a for a in argv if "\x00" not in a], folder, capsys)


# --- TOML files -------------------------------------------------------------------------------------------

TABLE_KEYS = {
    "vehicle": [
        "wheelbase",
        "hitch_offset",
        "trailer_length",
        "max_steer",
        "max_hitch",
        "trailer_front",
        "trailer_width",
        "max_steer_rate",
        "max_accel",
        "wheel",
    ],
    "plant": [
        "kind",
        "steer_rate_max",
        "steer_time_constant",
        "accel_max",
        "delay_steps",
        "hitch_noise_std_deg",
        "hitch_bias_deg",
        "seed",
        "vehicle",
        "noise",
    ],
    "nmpc": [
        "kind",
        "dt",
        "prediction_dt",
        "horizon",
        "Q",
        "R",
        "P",
        "speed_min",
        "speed_max",
        "virtual_limit",
        "stop_speed",
        "max_steps",
        "solver",
        "fallback_solver",
        "relaxed_solver",
        "transcription",
        "solver_options",
        "jit",
    ],
    "forward": ["lookahead", "speed", "hitch_threshold", "distance_threshold", "max_distance", "length_tolerance"],
    "success": ["distance", "orientation", "hitch", "max_stages", "max_time"],
    "start": ["x", "y", "yaw_deg", "hitch_deg", "z"],
    "goal": ["x", "y", "yaw_deg"],
}

TOML_SCALAR = st.one_of(
    st.booleans(),
    st.integers(min_value=-(2**63), max_value=2**63 - 1),
    st.floats(),
    st.text(max_size=8),
    st.sampled_from(
        [
            0,
            1,
            -1,
            0.5,
            1e308,
            -1e308,
            "fatrop",
            "ipopt",
            "paper",
            "full",
            "ideal",
            "realistic",
            "multiple_shooting",
            10,
            10.5,
            3.0,
            70.0,
            90.0,
        ]
    ),
)
TOML_VALUE = st.one_of(
    TOML_SCALAR,
    st.lists(TOML_SCALAR, max_size=7),
    st.dictionaries(st.sampled_from(["max_iter", "tol", "x"]), TOML_SCALAR, max_size=2),
)


def toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf") if math.isinf(value) else repr(value)
    if isinstance(value, int):
        return str(value)
    if isinstance(value, str):
        return json.dumps(value)  # a TOML basic string for the printable text generated here
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    return "{" + ", ".join(f"{k} = {toml_value(v)}" for k, v in value.items()) + "}"


def _table_body(draw: st.DrawFn, table: str) -> str:
    keys = draw(st.lists(st.sampled_from(TABLE_KEYS[table]), min_size=1, max_size=4, unique=True))
    return "\n".join(f"{k} = {toml_value(draw(TOML_VALUE))}" for k in keys)


@st.composite
def toml_file(draw: st.DrawFn) -> tuple[str, str]:
    """``(option, text)``: a scenario, vehicle, plant or settings file, mostly well-formed, with odd values."""
    option = draw(st.sampled_from(["--scenario", "--vehicle", "--plant", "--settings"]))
    if option in ("--vehicle", "--plant"):  # the fields at the top level
        text = _table_body(draw, option[2:])
    else:
        tables = (
            ["goal", "vehicle", "plant", "nmpc", "forward", "success"]
            if option == "--scenario"
            else ["nmpc", "forward", "success"]
        )
        blocks = [
            f"[{t}]\n{_table_body(draw, t)}" for t in draw(st.lists(st.sampled_from(tables), max_size=3, unique=True))
        ]
        if option == "--scenario":
            good_start = "[start]\nx = 10.0\ny = 3.5\nyaw_deg = 0.0\nhitch_deg = 0.0"
            blocks.insert(0, draw(st.sampled_from([good_start, good_start, f"[start]\n{_table_body(draw, 'start')}"])))
        text = "\n".join(blocks)
    text += "\n"
    if draw(st.integers(0, 9)) == 0:  # now and then, break the syntax or the encoding
        text = draw(st.sampled_from([text[: len(text) // 2], text.replace("=", "==", 1), text + "\udcff", "= 1\n"]))
    return option, text


@FUZZ
@given(file=toml_file())
def test_generated_files(tmp_path_factory, capsys, file):
    folder: Path = tmp_path_factory.mktemp("toml")
    option, text = file
    path = folder / "in.toml"
    path.write_bytes(text.encode("utf-8", "surrogateescape"))
    if option == "--settings":
        argv = ["sweep", "--n", "2", "--seed", "1", "--workers", "1", option, str(path), "--out", f"{folder}/s.jsonl"]
    elif option == "--scenario":
        argv = ["park", option, str(path), "--out", f"{folder}/park", "--no-plots"]
    else:
        argv = ["park", "--start", "10,3.5,0,0", option, str(path), "--out", f"{folder}/park", "--no-plots"]
    check_command("TOML files", argv, folder, capsys)


# --- saved maneuvers (plot) -------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def saved() -> dict[str, Any]:
    result = park(
        hitchpark.VehicleTrailer(),
        hitchpark.State(10.0, 3.5, 0.0, 0.0),
        settings=ManeuverSettings(nmpc=NMPCSettings(kind="paper")),
        plant=hitchpark.PlantSettings(kind="ideal"),
    )
    data = json.loads(json.dumps(to_jsonable(result.to_dict())))
    for name, column in data["trajectory"].items():  # short columns keep each example fast
        data["trajectory"][name] = column[:40]
    data["stages"] = [dict(data["stages"][0], last_row=39)]
    return data


def _paths(node: Any, prefix: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    """Every path into a JSON tree (long lists: their first few items)."""
    out = [prefix] if prefix else []
    if isinstance(node, dict):
        for k, v in node.items():
            out += _paths(v, (*prefix, k))
    elif isinstance(node, list):
        for i, v in enumerate(node[:3]):
            out += _paths(v, (*prefix, i))
    return out


@st.composite
def spoiled(draw: st.DrawFn, data: dict[str, Any]) -> dict[str, Any]:
    data = copy.deepcopy(data)
    paths = _paths(data)
    for _ in range(draw(st.integers(1, 3))):
        path = draw(st.sampled_from(paths))
        node: Any = data
        try:
            for key in path[:-1]:
                node = node[key]
            kind = draw(st.sampled_from(["set", "set", "delete", "add"]))
            if kind == "set":
                node[path[-1]] = draw(JSON_VALUE)
            elif kind == "delete":
                del node[path[-1]]
            elif isinstance(node, dict):
                node[draw(st.text(max_size=6))] = draw(JSON_VALUE)
            else:
                node.append(draw(JSON_VALUE))
        except (KeyError, IndexError, TypeError):  # an earlier change moved the path
            pass
    return data


@FUZZ
@given(data=st.data())
def test_generated_saved_maneuvers(tmp_path_factory, capsys, saved, data):
    folder: Path = tmp_path_factory.mktemp("json")
    spoilt = data.draw(spoiled(saved))
    path = folder / "maneuver.json"
    path.write_text(json.dumps(spoilt), encoding="utf-8")  # NaN and Infinity as JSON readers accept them
    check_call("saved maneuvers (API)", lambda: ManeuverResult.from_dict(json.loads(path.read_text())))
    check_command(
        "saved maneuvers (plot)", ["plot", str(path), "--no-animation", "--out", f"{folder}/fig"], folder, capsys
    )


# --- library calls ----------------------------------------------------------------------------------------

ANY = st.one_of(
    JSON_SCALAR,
    st.tuples(JSON_SCALAR, JSON_SCALAR),
    st.just(object()),
    st.just(hitchpark.Pose()),
    st.just(hitchpark.State(0.0, 0.0, 0.0, 0.0)),
)
NUMBER = st.one_of(st.floats(), st.integers(-(10**6), 10**6), st.sampled_from([0.1, -0.1, 0.5, 1.0, 2.0]), ANY)


def _settings_call(cls: Any, names: list[str]) -> st.SearchStrategy[Any]:
    return st.dictionaries(st.sampled_from(names), NUMBER | TOML_VALUE, max_size=3).map(lambda kw: lambda: cls(**kw))


API_CALLS = st.one_of(
    _settings_call(hitchpark.VehicleTrailer, TABLE_KEYS["vehicle"][:-1]),
    _settings_call(hitchpark.PlantSettings, TABLE_KEYS["plant"][:-1]),
    _settings_call(NMPCSettings, TABLE_KEYS["nmpc"]),
    _settings_call(PurePursuitSettings, TABLE_KEYS["forward"]),
    _settings_call(SuccessCriteria, TABLE_KEYS["success"]),
    st.tuples(NUMBER, NUMBER, NUMBER, NUMBER).map(lambda a: lambda: hitchpark.State(*a)),
    st.tuples(NUMBER, NUMBER, NUMBER).map(lambda a: lambda: hitchpark.Pose(*a)),
    st.tuples(NUMBER, NUMBER).map(lambda a: lambda: hitchpark.front_steer_from_virtual(hitchpark.VehicleTrailer(), *a)),
    st.tuples(NUMBER, NUMBER).map(lambda a: lambda: hitchpark.virtual_steer_from_front(hitchpark.VehicleTrailer(), *a)),
    st.tuples(NUMBER, NUMBER).map(lambda a: lambda: hitchpark.virtual_steer_bounds(hitchpark.VehicleTrailer(), *a)),
    st.tuples(NUMBER, NUMBER, NUMBER).map(
        lambda a: lambda: hitchpark.rear_speed_from_trailer_speed(hitchpark.VehicleTrailer(), *a)
    ),
    st.tuples(ANY, ANY, ANY).map(lambda a: lambda: park(a[0], a[1], a[2])),
    st.tuples(NUMBER, NUMBER, NUMBER, NUMBER).map(
        lambda a: (
            lambda: hitchpark.simulate(
                hitchpark.VehicleTrailer(),
                hitchpark.State(0.0, 0.0, 0.0, 0.0),
                a[0],
                a[1],
                _short(a[2], min),
                _short(a[3], max),
            )
        )
    ),
)


def _short(value: Any, bound: Any) -> Any:
    """A duration of at most 2 s (``min``) or a step of at least 0.01 s (``max``), so a run stays short."""
    if isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value) and value > 0:
        return bound(value, 2.0 if bound is min else 0.01)
    return value


@FUZZ
@given(call=API_CALLS)
def test_generated_api_calls(call):
    check_call("API calls", call)
