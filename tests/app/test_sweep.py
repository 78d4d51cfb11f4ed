"""``hitchpark sweep`` and the library under it (hitchpark.app): starts, records, resume, backends, summary."""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import hitchpark
from hitchpark import InputError, VehicleTrailer
from hitchpark.app import (
    DEFAULT_REGION,
    CaseRecord,
    Region,
    Start,
    SweepConfig,
    case_record,
    draw_starts,
    make_executor,
    parse_region,
    register_executor,
    run_sweep,
    scan_records,
    summarize,
)
from hitchpark.app.executors import SerialExecutor
from hitchpark.app.records import RECORD_FIELDS
from hitchpark.app.sweep import GOAL, controller_for, settings_from_dict
from hitchpark.cli import EXIT_BAD_INPUT, main
from hitchpark.control import NMPCSettings
from hitchpark.maneuver import ManeuverSettings, SuccessCriteria, park
from hitchpark.model import IDEAL

SRC = str(Path(hitchpark.__file__).resolve().parents[1])

#: The paper's process: its NMPC; with the ideal plant about 0.15 s a case, where the default (the full-model
#: NMPC on the realistic car) takes about 1 s. The sweep machinery is tested on it; the default runs end to end
#: in ``test_cli_sweep_writes_records_summary_and_map`` and ``test_case_record_fields_on_a_real_run``.
PAPER = ManeuverSettings(nmpc=NMPCSettings(kind="paper"))

#: A small sweep shared by several tests (module-scoped runs below).
SMALL = SweepConfig(seed=3, n=4, settings=PAPER, plant=IDEAL)

#: The same as files for the command: ``--settings`` and ``--plant``.
PAPER_TOML, IDEAL_TOML = '[nmpc]\nkind = "paper"\n', '[plant]\nkind = "ideal"\n'

#: A start the first reverse stage does not park from: with max_stages = 1 it fails as max_stages.
HARD = "x=5.6:5.6,y=-1.6:-1.6,yaw=-53:-53,hitch=-14:-14"


def run(argv: list[str]) -> int:
    try:
        return main(argv)
    except SystemExit as exc:
        return exc.code if isinstance(exc.code, int) else 1


def one_error_line(err: str) -> str:
    lines = err.splitlines()
    assert len(lines) == 1, err
    assert "Traceback" not in err
    return lines[0]


def without_wall(records: list[CaseRecord] | tuple[CaseRecord, ...]) -> list[dict]:
    """The records less their wall-clock times (``wall_s``, ``planning_s``)."""
    clocks = ("wall_s", "planning_s")
    return [{k: v for k, v in r.to_dict().items() if k not in clocks} for r in sorted(records, key=lambda r: r.case)]


def read_lines(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text(encoding="utf-8").splitlines()]


@pytest.fixture(scope="module")
def serial_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("serial") / "sweep.jsonl"
    return out, run_sweep(SMALL, out)


@pytest.fixture(scope="module")
def pool_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("pool") / "sweep.jsonl"
    return out, run_sweep(SMALL, out, make_executor("pool", 2))


# --- region and starts -------------------------------------------------------------------------


def test_region_defaults_and_partial_text():
    assert parse_region("") == DEFAULT_REGION == Region()
    assert str(DEFAULT_REGION) == "x=4:16,y=-8:8,yaw=-90:90,hitch=-30:30"
    r = parse_region(" hitch = -10:10 , x=0:2.5")
    assert r == Region(x=(0.0, 2.5), hitch_deg=(-10.0, 10.0))
    assert (r.y, r.yaw_deg) == (DEFAULT_REGION.y, DEFAULT_REGION.yaw_deg)
    assert parse_region(str(r)) == r
    assert parse_region("x=3:3").x == (3.0, 3.0)  # a fixed coordinate
    assert parse_region("hitch=-70:70", VehicleTrailer()).hitch_deg == (-70.0, 70.0)  # the jackknife limit itself


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("x=4", ["x", "LO:HI", "'4'"]),
        ("x=4:16:20", ["x", "LO:HI"]),
        ("z=1:2", ["KEY", "'z=1:2'", "x, y, yaw, hitch"]),
        ("x=16:4", ["region x", "lo <= hi", "16:4"]),
        ("y=nan:4", ["region y", "finite", "nan:4"]),
        ("yaw=-1:inf", ["region yaw", "finite"]),
        ("x=0:2e5", ["region x", "100000", "0:200000"]),
        ("yaw=-4000:0", ["region yaw", "3600", "-4000:0"]),
        ("hitch=-80:30", ["region hitch", "-70:70", "max_hitch", "-80:30"]),
        ("x=1:2,x=3:4", ["x twice"]),
        ("x=a:b", ["region", "x", "'a:b'"]),
        ("x=1:2,", ["KEY=LO:HI", "''"]),
    ],
)
def test_bad_region_is_input_error(text, words):
    with pytest.raises(InputError) as info:
        parse_region(text, VehicleTrailer())
    message = str(info.value)
    assert "\n" not in message
    for word in words:
        assert word in message, message


def test_hitch_beyond_the_vehicle_limit():
    small = VehicleTrailer(max_hitch=math.radians(20))
    with pytest.raises(InputError, match="region hitch must lie within -20:20 deg"):
        SweepConfig(vehicle=small, seed=0, n=1)  # the default +-30 deg does not fit this vehicle
    SweepConfig(vehicle=small, region=parse_region("hitch=-20:20"), seed=0, n=1)


@pytest.mark.parametrize(("n", "seed", "what"), [(0, 1, "n must be"), (1, -1, "seed must be"), (2.5, 1, "n must be")])
def test_bad_n_or_seed(n, seed, what):
    with pytest.raises(InputError, match=what):
        SweepConfig(seed=seed, n=n)


def test_starts_are_a_pure_function_of_seed_n_region():
    region = parse_region("x=-3:3,y=1:2,yaw=-180:180,hitch=-5:5")
    starts = draw_starts(7, 50, region)
    assert starts == draw_starts(7, 50, region)
    assert starts[:10] == draw_starts(7, 10, region)  # a longer sweep extends a shorter one
    assert starts != draw_starts(8, 50, region)
    table = np.array([[s.x, s.y, s.yaw_deg, s.hitch_deg] for s in starts])
    lo, hi = region.bounds()
    assert np.all(table >= lo) and np.all(table <= hi)
    assert len({s.x for s in starts}) == 50


@pytest.mark.slow
def test_starts_and_records_do_not_depend_on_workers(serial_run, pool_run):
    (_, serial), (_, pool) = serial_run, pool_run
    assert [r.start for r in serial.records] == SMALL.starts()
    assert without_wall(serial.records) == without_wall(pool.records)


# --- one case ----------------------------------------------------------------------------------


def test_case_record_fields_on_a_real_run():
    vehicle, settings = VehicleTrailer(), ManeuverSettings()
    start = Start(9.0, -2.5, 20.0, 10.0)
    result = park(vehicle, start.state(), GOAL, settings)
    rec = case_record(result, 0.25)
    assert set(rec) == set(RECORD_FIELDS) - {"case", "start"}
    tr = result.trajectory
    assert rec["success"] is True and rec["reason"] == "parked"
    assert rec["stages"] == len(result.stages) >= 1
    last = result.stages[-1]
    assert rec["distance_error_m"] == last.distance_error_m < 0.05
    assert rec["orientation_error_deg"] == last.orientation_error_deg
    assert rec["final_hitch_deg"] == last.final_hitch_deg == pytest.approx(math.degrees(tr["hitch"][-1]))
    assert rec["max_abs_steer_deg"] == pytest.approx(result.max_abs_front_steer_deg)
    assert rec["max_abs_steer_deg"] <= math.degrees(vehicle.max_steer) + 1e-9
    assert rec["max_abs_hitch_deg"] == pytest.approx(result.max_abs_hitch_deg)
    rates = [
        abs(tr["front_steer"][k + 1] - tr["front_steer"][k]) / (tr["t"][k + 1] - tr["t"][k]) for k in range(len(tr) - 1)
    ]
    assert rec["max_abs_steer_rate_deg_s"] == pytest.approx(math.degrees(max(rates)))
    path = sum(
        math.hypot(tr["x_trailer"][k + 1] - tr["x_trailer"][k], tr["y_trailer"][k + 1] - tr["y_trailer"][k])
        for k in range(len(tr) - 1)
    )
    assert rec["path_length_m"] == pytest.approx(path)
    assert rec["path_length_m"] > math.hypot(start.x, start.y)  # at least the straight line to the goal
    assert rec["maneuver_time_s"] == result.duration
    assert rec["wall_s"] == 0.25
    assert case_record(result, math.nan)["wall_s"] is None  # non-finite -> null


def test_each_worker_builds_one_controller():
    first = controller_for(SMALL)
    assert controller_for(replace(SMALL, seed=99, n=7)) is first  # same vehicle and NMPC settings
    other = replace(SMALL, settings=ManeuverSettings(nmpc=NMPCSettings(kind="paper", horizon=8)))
    assert controller_for(other) is not first


# --- records and the JSONL file ----------------------------------------------------------------


def make_record(case: int, reason: str = "parked", **values) -> CaseRecord:
    fixed = ("case", "start", "success", "reason", "stages", "collision", "direction_switches")
    fields: dict = {name: None for name in RECORD_FIELDS if name not in fixed}
    fields.update(collision=False, direction_switches=0)
    fields.update(values)
    return CaseRecord(
        case=case, start=Start(1.0, 2.0, 3.0, 4.0), success=reason == "parked", reason=reason, stages=3, **fields
    )


def test_record_json_round_trip(serial_run):
    out, outcome = serial_run
    for line in out.read_text(encoding="utf-8").splitlines(keepends=True):
        assert CaseRecord.from_dict(json.loads(line)).to_line() == line
    for record in outcome.records:
        assert CaseRecord.from_dict(json.loads(record.to_line())) == record
    sparse = make_record(5, "solver: Infeasible_Problem_Detected", wall_s=0.5)
    line = sparse.to_line()
    assert line.startswith('{"case": 5, ') and line.endswith("}\n") and line.count("\n") == 1
    assert json.loads(line)["distance_error_m"] is None
    assert CaseRecord.from_dict(json.loads(line)) == sparse


@pytest.mark.parametrize(
    ("change", "words"),
    [
        ({"case": -1}, "case must be"),
        ({"case": True}, "case must be"),
        ({"success": 1}, "success must be"),
        ({"path_length_m": "3"}, "path_length_m must be"),
        ({"start": {"x": 1, "y": 2, "yaw_deg": 3}}, "start must be"),
        ({"extra": 1}, "unknown key 'extra'"),
    ],
)
def test_record_from_dict_rejects(change, words):
    data = {**make_record(0).to_dict(), **change}
    with pytest.raises(InputError, match=words):
        CaseRecord.from_dict(data)
    data = make_record(0).to_dict()
    del data["reason"]
    with pytest.raises(InputError, match="lacks 'reason'"):
        CaseRecord.from_dict(data)


# --- resume ------------------------------------------------------------------------------------


def test_resume_keeps_finished_lines_and_reruns_a_cut_one(serial_run, tmp_path):
    full_path, full = serial_run
    lines = full_path.read_bytes().splitlines(keepends=True)
    out = tmp_path / "resume.jsonl"
    kept = lines[0] + lines[1]
    out.write_bytes(kept + lines[2][: len(lines[2]) // 2])  # a third line cut off mid-write
    outcome = run_sweep(SMALL, out)
    after = out.read_bytes()
    assert after.startswith(kept)  # the two finished lines, byte for byte
    assert (outcome.kept, outcome.ran, outcome.dropped_cut_line) == (2, 2, True)
    assert sorted(r["case"] for r in read_lines(out)) == [0, 1, 2, 3]
    assert without_wall(outcome.records) == without_wall(full.records)
    assert outcome.summary["n"] == 4

    again = run_sweep(SMALL, out)  # nothing left to run: the file is not touched
    assert out.read_bytes() == after
    assert (again.kept, again.ran, again.dropped_cut_line) == (4, 0, False)
    assert again.records == outcome.records


def test_resume_extends_to_a_larger_n(serial_run, tmp_path):
    full_path, _ = serial_run
    out = tmp_path / "grow.jsonl"
    out.write_bytes(full_path.read_bytes())
    outcome = run_sweep(replace(SMALL, n=6), out)
    assert (outcome.kept, outcome.ran) == (4, 2)
    assert out.read_bytes().startswith(full_path.read_bytes())
    assert [r.case for r in outcome.records] == list(range(6))


def test_a_cut_first_line_is_dropped(tmp_path):
    out = tmp_path / "cut.jsonl"
    out.write_text('{"case": 0, "sta', encoding="utf-8")
    existing = scan_records(out, SMALL.starts())
    assert (existing.records, existing.keep_bytes, existing.cut_bytes) == ({}, 0, 16)
    out.write_text('{"ca', encoding="utf-8")
    assert scan_records(out, SMALL.starts()).cut_bytes == 4


def refuses(out: Path, config: SweepConfig, words: str) -> None:
    before = out.read_bytes()
    with pytest.raises(InputError, match=words):
        run_sweep(config, out)
    assert out.read_bytes() == before


def test_resume_refuses_another_sweep(serial_run, tmp_path):
    full_path, _ = serial_run
    out = tmp_path / "other.jsonl"
    out.write_bytes(full_path.read_bytes())
    refuses(out, replace(SMALL, seed=4), r"line 1 holds case 0 with start .*\(another seed or region\)")
    refuses(out, replace(SMALL, region=parse_region("x=5:16")), "another seed or region")
    refuses(out, replace(SMALL, n=3), r"holds case 3, beyond this sweep's n = 3")
    lines = full_path.read_bytes().splitlines(keepends=True)
    out.write_bytes(lines[0] + lines[0])
    refuses(out, SMALL, "line 2 repeats case 0")


@pytest.mark.parametrize(
    "content",
    [
        b"hello\n",
        b"hello",  # no newline: not a cut record either
        b"x,y\n1,2\n",
        b'{"case": 0}\n',
        b"\n",
        b"\xff\xfe\n",
        b'[1, 2]\n{"case": 0, "st',
    ],
)
def test_never_touches_a_file_that_is_not_a_sweep(tmp_path, content):
    out = tmp_path / "mine.txt"
    out.write_bytes(content)
    refuses(out, SMALL, "refusing to add to it")


# --- backends ----------------------------------------------------------------------------------


@pytest.mark.slow
def test_pool_and_dask_local_give_the_same_records(pool_run, tmp_path):
    _, pool = pool_run
    dask = run_sweep(SMALL, tmp_path / "dask.jsonl", make_executor("dask", 2, "local"))
    assert "Dask LocalCluster of 2" in dask.where and "pool of 2" in pool.where
    assert without_wall(dask.records) == without_wall(pool.records)
    assert sorted(r["case"] for r in read_lines(tmp_path / "dask.jsonl")) == [0, 1, 2, 3]


def test_executors_are_an_open_set(tmp_path):
    seen = []

    @register_executor("test-recording")
    class Recording(SerialExecutor):
        def imap_unordered(self, fn, items):
            for item in reversed(list(items)):  # completion order differs from case order
                seen.append(item.case)
                yield fn(item)

    config = replace(SMALL, n=2, settings=ManeuverSettings(nmpc=NMPCSettings(kind="paper", max_steps=5)))
    outcome = run_sweep(config, tmp_path / "custom.jsonl", make_executor("test-recording"))
    assert seen == [1, 0]
    assert [r["case"] for r in read_lines(tmp_path / "custom.jsonl")] == [1, 0]
    assert [r.case for r in outcome.records] == [0, 1]
    with pytest.raises(InputError, match="unknown executor 'nope'"):
        make_executor("nope")
    with pytest.raises(InputError, match="workers must be an integer >= 1"):
        make_executor("pool", 0)


# --- summary -----------------------------------------------------------------------------------


def test_summary_numbers():
    reasons = ["parked"] * 6 + ["jackknife", "max_stages", "jackknife", "stalled"]
    records = [
        make_record(
            i,
            reason,
            path_length_m=float(i + 1),  # 1..10
            maneuver_time_s=10.0 * (i + 1),
            wall_s=0.5,
            max_abs_steer_deg=float(i),
            max_abs_steer_rate_deg_s=100.0 - i,
            max_abs_hitch_deg=None if i == 3 else 2.0 * i,
        )
        for i, reason in enumerate(reasons)
    ]
    s = summarize(records)
    assert s["n"] == 10 and s["parked"] == 6
    assert s["success_rate"] == pytest.approx(0.6)
    assert s["by_reason"] == {"parked": 6, "jackknife": 2, "max_stages": 1, "stalled": 1}
    assert list(s["by_reason"]) == ["parked", "jackknife", "max_stages", "stalled"]
    assert s["path_length_m"] == pytest.approx({"median": 5.5, "p90": 9.1})
    assert s["maneuver_time_s"] == pytest.approx({"median": 55.0, "p90": 91.0})
    assert s["wall_s"] == pytest.approx(5.0)
    assert (s["max_abs_steer_deg"], s["max_abs_steer_rate_deg_s"], s["max_abs_hitch_deg"]) == (9.0, 100.0, 18.0)
    none_parked = summarize([make_record(0, "jackknife")])
    assert none_parked["by_reason"] == {"parked": 0, "jackknife": 1}
    assert none_parked["path_length_m"] == {"median": None, "p90": None}
    assert none_parked["max_abs_hitch_deg"] is None


def test_settings_file_tables():
    s = settings_from_dict({"success": {"max_stages": 1}, "nmpc": {"kind": "paper", "horizon": 8, "Q": [1, 2, 3]}})
    assert s.success == SuccessCriteria(max_stages=1)
    assert s.nmpc.kind == "paper" and s.nmpc.horizon == 8 and s.nmpc.Q == (1.0, 2.0, 3.0)
    assert settings_from_dict({}) == ManeuverSettings()  # the full-model NMPC
    with pytest.raises(InputError, match=r"nmpc\.Q must be a list of 6 numbers"):  # Q of the paper's OCP
        settings_from_dict({"nmpc": {"Q": [1, 2, 3]}})
    with pytest.raises(InputError, match=r"unknown table \[start\]"):
        settings_from_dict({"start": {}})
    with pytest.raises(InputError, match=r"unknown key success\.foo"):
        settings_from_dict({"success": {"foo": 1}})


# --- the command -------------------------------------------------------------------------------


@pytest.mark.slow
def test_cli_sweep_writes_records_summary_and_map(tmp_path, capsys):
    """The default sweep end to end: the full-model NMPC on the realistic car."""
    out, summary, figure = tmp_path / "s.jsonl", tmp_path / "s.json", tmp_path / "maps" / "s.png"
    argv = ["sweep", "--n", "2", "--seed", "1", "--workers", "1", "--region", "hitch=-5:5"]
    assert run([*argv, "--out", str(out), "--json", str(summary), "--map", str(figure)]) == 0
    records = read_lines(out)
    assert [r["case"] for r in records] == [0, 1]
    assert all(list(r) == list(RECORD_FIELDS) for r in records)
    assert all(-5 <= r["start"]["hitch_deg"] <= 5 for r in records)
    for record in records:  # each case as park gives it with the defaults
        start = Start(**record["start"])
        result = park(VehicleTrailer(), start.state(), GOAL, ManeuverSettings(), name=f"case {record['case']}")
        assert result.settings.nmpc.kind == "full" and result.plant.kind == "realistic"
        clocks = ("wall_s", "planning_s")  # wall-clock times
        assert {k: v for k, v in record.items() if k not in ("case", "start", *clocks)} == {
            k: v for k, v in case_record(result, math.nan).items() if k not in clocks
        }
    data = json.loads(summary.read_text(encoding="utf-8"))
    assert data["n"] == 2 and data["seed"] == 1 and data["region"]["hitch_deg"] == [-5.0, 5.0]
    assert {"success_rate", "by_reason", "path_length_m", "maneuver_time_s", "wall_s"} <= set(data)
    assert figure.read_bytes().startswith(b"\x89PNG")
    captured = capsys.readouterr()
    assert f"parked {data['parked']}/2" in captured.out
    assert str(out) in captured.out and str(summary) in captured.out and str(figure) in captured.out
    assert "2/2" in captured.err  # the progress bar


def test_cli_exit_0_when_a_case_does_not_park(tmp_path, capsys):
    settings = tmp_path / "settings.toml"
    settings.write_text("[success]\nmax_stages = 1\n", encoding="utf-8")
    out, summary, figure = tmp_path / "f.jsonl", tmp_path / "f.json", tmp_path / "f.png"
    argv = ["sweep", "--n", "2", "--seed", "0", "--workers", "1", "--region", HARD, "--settings", str(settings)]
    assert run([*argv, "--out", str(out), "--json", str(summary), "--map", str(figure)]) == 0
    assert [(r["success"], r["reason"], r["stages"]) for r in read_lines(out)] == [(False, "max_stages", 1)] * 2
    data = json.loads(summary.read_text(encoding="utf-8"))
    assert data["success_rate"] == 0.0 and data["by_reason"] == {"parked": 0, "max_stages": 2}
    assert figure.exists()
    assert "not parked: max_stages 2" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--n", "0"], "n must be an integer >= 1"),
        (["--seed", "-1"], "seed must be an integer >= 0"),
        (["--workers", "0"], "workers must be an integer >= 1"),
        (["--region", "hitch=-75:0"], "region hitch must lie within -70:70 deg"),
        (["--region", "x=9:1"], "region x must be lo:hi with finite lo <= hi, got 9:1"),
        (["--region", "speed=1:2"], "--region must be"),
        (["--dask", " "], "--dask must be 'local' or a scheduler address"),
        (["--n", "many"], "invalid int value"),
        (["--plant", "PLANT"], "plant.steer_rate_max"),
        (["--settings", "SETTINGS"], "unknown key success.nope"),
        (["--json", "DIR"], "--json"),
        (["--map", "OUT"], "--out, --map must name different files"),
    ],
)
def test_cli_bad_input_exit_2_one_line_nothing_written(tmp_path, capsys, args, words):
    (tmp_path / "PLANT").write_text("[plant]\nsteer_rate_max = -1.0\n", encoding="utf-8")
    (tmp_path / "SETTINGS").write_text("[success]\nnope = 1\n", encoding="utf-8")
    (tmp_path / "DIR").mkdir()
    args = [str(tmp_path / a) if a in ("PLANT", "SETTINGS", "DIR") else a for a in args]
    args = [str(tmp_path / "o.jsonl") if a == "OUT" else a for a in args]
    options = {"--n": "2", "--seed": "1", "--workers": "1"}
    for flag, value in zip(args[::2], args[1::2], strict=True):
        options[flag] = value
    argv = ["sweep", *[item for pair in options.items() for item in pair], "--out", str(tmp_path / "o.jsonl")]
    before = sorted(p.name for p in tmp_path.iterdir())
    assert run(argv) == EXIT_BAD_INPUT
    line = one_error_line(capsys.readouterr().err)
    assert line.startswith("hitchpark sweep: error: ") and words in line, line
    assert sorted(p.name for p in tmp_path.iterdir()) == before


def test_cli_refuses_a_foreign_out_file(tmp_path, capsys):
    out = tmp_path / "notes.txt"
    out.write_text("my notes\n", encoding="utf-8")
    assert run(["sweep", "--n", "2", "--seed", "1", "--workers", "1", "--out", str(out)]) == EXIT_BAD_INPUT
    assert "line 1 is not JSON; refusing to add to it" in one_error_line(capsys.readouterr().err)
    assert out.read_text(encoding="utf-8") == "my notes\n"


@pytest.mark.slow
def test_killed_sweep_resumes_without_changing_finished_lines(tmp_path):
    out = tmp_path / "killed.jsonl"
    (tmp_path / "paper.toml").write_text(PAPER_TOML, encoding="utf-8")
    (tmp_path / "ideal.toml").write_text(IDEAL_TOML, encoding="utf-8")
    files = ["--settings", str(tmp_path / "paper.toml"), "--plant", str(tmp_path / "ideal.toml")]
    argv = ["sweep", "--n", "16", "--seed", "11", *files, "--workers", "2", "--out", str(out)]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in (SRC, os.environ.get("PYTHONPATH")) if p)}
    code = "import sys; from hitchpark.cli import main; sys.exit(main(sys.argv[1:]))"
    proc = subprocess.Popen(
        [sys.executable, "-c", code, *argv],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,  # its own process group: the kill takes the pool's workers too
    )
    deadline = time.monotonic() + 60
    try:
        while not (out.exists() and b"\n" in out.read_bytes()):
            assert proc.poll() is None, "the sweep ended before it could be killed"
            assert time.monotonic() < deadline, "no record written within 60 s"
            time.sleep(0.005)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    killed = out.read_bytes()
    finished = killed[: killed.rfind(b"\n") + 1]
    assert 1 <= finished.count(b"\n") < 16
    assert run([*argv[:-4], "--workers", "1", "--out", str(out)]) == 0
    after = out.read_bytes()
    assert after.startswith(finished)
    assert sorted(r["case"] for r in read_lines(out)) == list(range(16))
