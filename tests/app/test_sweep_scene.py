"""``hitchpark sweep --scenario``: starts from a scene's start region, colliding draws redrawn, the scene's fields."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import pytest

from hitchpark import InputError
from hitchpark.app import CaseRecord, draw_starts, run_sweep, scan_records
from hitchpark.app import starts as starts_module
from hitchpark.app.records import RECORD_FIELDS
from hitchpark.app.starts import Region, draw_clear_starts
from hitchpark.app.sweep import config_from_scenario
from hitchpark.cli import EXIT_BAD_INPUT, main
from hitchpark.maneuver.scenario import builtin_scenario, check_start_clear, load_scenario

#: A scene of one shed beside the start region, so that some draws collide. The paper's process on the ideal
#: car (about 0.15 s a case; it does not avoid the shed, the check at the end judges it).
SCENE_TOML = """
name = "shed"
[start]
x = 10.0
y = 3.5
yaw_deg = 0.0
hitch_deg = 0.0
[nmpc]
kind = "paper"
[plant]
kind = "ideal"
[[obstacles]]
name = "shed"
polygon = [[10.0, -7.0], [13.0, -7.0], [13.0, -4.0], [10.0, -4.0]]
[start_region]
x = [8.0, 14.0]
y = [-6.0, 6.0]
yaw_deg = [-20.0, 20.0]
hitch_deg = [-10.0, 10.0]
"""


def run(argv: list[str]) -> int:
    try:
        return main(argv)
    except SystemExit as exc:
        return exc.code if isinstance(exc.code, int) else 1


@pytest.fixture(scope="module")
def scenario(tmp_path_factory):
    path = tmp_path_factory.mktemp("scene") / "shed.toml"
    path.write_text(SCENE_TOML, encoding="utf-8")
    return load_scenario(path)


@pytest.fixture(scope="module")
def config(scenario):
    return config_from_scenario(scenario, n=4, seed=6)  # 3 draws skipped


@pytest.fixture(scope="module")
def scene_run(tmp_path_factory, config):
    out = tmp_path_factory.mktemp("scene_sweep") / "sweep.jsonl"
    return out, run_sweep(config, out)


def test_config_takes_the_scenario(scenario, config):
    assert config.goal == scenario.goal and config.scene == scenario.scene and config.scenario == "shed"
    assert config.settings == scenario.settings and config.plant == scenario.plant
    assert config.region == Region(x=(8.0, 14.0), y=(-6.0, 6.0), yaw_deg=(-20.0, 20.0), hitch_deg=(-10.0, 10.0))


def test_colliding_starts_are_redrawn_and_counted(config):
    starts, skipped = config.draw()
    assert len(starts) == 4 and skipped > 0
    for start in starts:  # every case keeps min_clearance_m
        check_start_clear(config.plant_vehicle, config.scene, start.state(), config.settings.success.min_clearance_m)
    # the cases are the draws of the open-space sweep, in order, less the colliding ones
    drawn = draw_starts(config.seed, 4 + skipped, config.region)
    assert [s for s in drawn if s in starts] == starts and drawn[-1] == starts[-1]
    # and the first cases do not depend on n
    assert replace(config, n=2).draw()[0] == starts[:2]
    assert replace(config, n=9).draw()[0][:4] == starts


def test_open_space_draws_are_unchanged(config):
    open_space = replace(config, scene=builtin_scenario("parallel").scene)
    assert open_space.draw() == (draw_starts(config.seed, 4, config.region), 0)
    assert draw_clear_starts(3, 5, config.region) == (draw_starts(3, 5, config.region), 0)


def test_a_region_that_always_collides_is_refused(config, monkeypatch):
    monkeypatch.setattr(starts_module, "_MIN_DRAWS", 40)
    inside = replace(config, region=Region(x=(11.0, 12.0), y=(-6.0, -5.0), yaw_deg=(0, 0), hitch_deg=(0, 0)))
    with pytest.raises(InputError, match=r"only 0 of 400 starts drawn .* keep clear of the scene"):
        inside.draw()


def test_scene_sweep_records_and_summary(scene_run, config):
    out, outcome = scene_run
    lines = [json.loads(line) for line in out.read_text(encoding="utf-8").splitlines()]
    assert sorted(r["case"] for r in lines) == [0, 1, 2, 3]
    assert all(list(r) == list(RECORD_FIELDS) for r in lines)
    for r in lines:
        assert isinstance(r["collision"], bool) and isinstance(r["direction_switches"], int)
        assert r["min_clearance_m"] is not None and r["min_clearance_m"] >= 0.0
        assert r["collision"] == (r["min_clearance_m"] == 0.0)
        assert r["planning_s"] == 0.0  # the paper's process plans nothing
    summary = outcome.summary
    assert summary["skipped"] == config.draw()[1] > 0
    assert summary["collisions"] == sum(r["collision"] for r in lines)
    assert summary["min_clearance_m"] == min(r["min_clearance_m"] for r in lines)
    assert summary["scenario"] == "shed" and summary["goal"] == {"x": 0.0, "y": 0.0, "yaw_deg": 0.0}


def test_scene_sweep_resumes(scene_run, config, tmp_path):
    full_path, full = scene_run
    lines = full_path.read_bytes().splitlines(keepends=True)
    out = tmp_path / "resume.jsonl"
    out.write_bytes(lines[0] + lines[1][:30])
    outcome = run_sweep(config, out)
    assert (outcome.kept, outcome.ran, outcome.dropped_cut_line) == (1, 3, True)
    assert out.read_bytes().startswith(lines[0])
    clocks = ("wall_s", "planning_s")
    assert [{k: v for k, v in r.to_dict().items() if k not in clocks} for r in outcome.records] == [
        {k: v for k, v in r.to_dict().items() if k not in clocks} for r in full.records
    ]


def test_records_of_an_older_hitchpark_are_refused(scene_run, config, tmp_path):
    full_path, _ = scene_run
    old = json.loads(full_path.read_text(encoding="utf-8").splitlines()[0])
    for name in ("collision", "min_clearance_m", "direction_switches", "planning_s"):
        del old[name]
    with pytest.raises(InputError, match="older hitchpark"):
        CaseRecord.from_dict(old)
    out = tmp_path / "old.jsonl"
    out.write_text(json.dumps(old) + "\n", encoding="utf-8")
    with pytest.raises(InputError, match=r"line 1 is not a sweep record: the record is of an older hitchpark"):
        scan_records(out, config.starts())
    before = out.read_bytes()
    with pytest.raises(InputError, match="refusing to add to it"):
        run_sweep(config, out)
    assert out.read_bytes() == before


def test_a_scenario_without_start_region_is_refused():
    with pytest.raises(InputError, match=r"scenario parallel .*has no \[start_region\]"):
        config_from_scenario(builtin_scenario("parallel"), n=2, seed=1)


@pytest.mark.slow
def test_cli_sweep_over_a_builtin_scene(tmp_path, capsys):
    """The command end to end on a shipped scene, by name: its planner, NMPC and realistic car. One case (each
    takes seconds): the sweep's machinery over several is the module's scene sweep's, and ``test_sweep.py``'s."""
    out, summary, figure = tmp_path / "s.jsonl", tmp_path / "s.json", tmp_path / "s.png"
    argv = ["sweep", "--scenario", "curb_parallel", "--n", "1", "--seed", "1", "--workers", "1"]
    assert run([*argv, "--out", str(out), "--json", str(summary), "--map", str(figure)]) == 0
    records = [json.loads(line) for line in out.read_text(encoding="utf-8").splitlines()]
    region = builtin_scenario("curb_parallel").start_region
    assert region is not None and len(records) == 1
    for r in records:
        assert region.x[0] <= r["start"]["x"] <= region.x[1] and region.y[0] <= r["start"]["y"] <= region.y[1]
        assert r["min_clearance_m"] is not None and r["collision"] is False
    data = json.loads(summary.read_text(encoding="utf-8"))
    assert data["format"] == "hitchpark-sweep-summary/1"
    assert data["scenario"] == "curb_parallel" and data["skipped"] == 0 and data["collisions"] == 0
    # The scene's goal tree is built (or loaded) once before the cases, its time apart from theirs.
    assert data["prepare_s"] > 0.0
    assert figure.read_bytes().startswith(b"\x89PNG")
    printed = capsys.readouterr().out
    assert "scenario curb_parallel" in printed and "collisions 0 (starts skipped as they collide: 0)" in printed
    assert f"the scene's goal tree and rollouts, before the cases: {data['prepare_s']:.2f} s" in printed


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--scenario", "parallel"], "has no [start_region]"),
        (["--scenario", "bay", "--region", "x=1:2"], "give --region or --scenario, not both"),
        (["--scenario", "garage"], "--scenario garage: no such file, nor a built-in scenario"),
        (["--scenario", "nowhere/bay.toml"], "cannot read"),
    ],
)
def test_cli_scenario_bad_input(tmp_path, capsys, args, words):
    argv = ["sweep", "--n", "2", "--seed", "1", "--workers", "1", *args, "--out", str(tmp_path / "o.jsonl")]
    assert run(argv) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1 and "Traceback" not in err and words in err, err
    assert list(Path(tmp_path).iterdir()) == []
