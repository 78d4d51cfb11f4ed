"""Sweeps of the knob assist (hitchpark.app.assist_sweep, ``sweep --assist``): profiles from the seed, the same
records on any number of workers, every limit kept, the command's summary."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from hitchpark.app.assist_sweep import FAMILIES, knob_profile, run_assist_sweep
from hitchpark.app.executors import make_executor
from hitchpark.app.sweep import build_config
from hitchpark.cli import main


@pytest.mark.parametrize("family", FAMILIES)
def test_a_profile_is_a_pure_function_of_the_seed_and_the_case(family):
    a, b, other = knob_profile(family, 7, 3), knob_profile(family, 7, 3), knob_profile(family, 7, 4)
    assert np.array_equal(a.knob, b.knob) and np.array_equal(a.speed_request, b.speed_request)
    assert a.duration == 60.0 and np.all(np.abs(a.knob) <= 1.0) and np.all(a.speed_request >= 0.0)
    if family != "hold":
        assert not np.array_equal(a.knob, other.knob)
    else:
        assert np.all(np.abs(a.knob) == 1.0)


@pytest.mark.slow
def test_the_records_are_the_same_on_one_worker_and_two_and_keep_every_limit(tmp_path):
    config = build_config(n=2, seed=3)
    records = {}
    for workers in (1, 2):
        executor = make_executor("pool" if workers > 1 else "serial", workers)
        found, summary = run_assist_sweep(config, ("hold", "noise"), tmp_path / f"{workers}.jsonl", executor)
        records[workers] = [replace(r, wall_s=0.0) for r in found]
    assert records[1] == records[2]
    assert [(r.family, r.case) for r in records[1]] == [("hold", 0), ("hold", 1), ("noise", 0), ("noise", 1)]
    every = summary["all"]
    for field in ("hitch_limit_rows", "steer_violations", "steer_rate_violations", "accel_violations"):
        assert every[field] == 0
    assert every["nonfinite_commands"] == 0 and every["max_abs_hitch_deg"] < 70.0


def test_the_command_prints_the_summary_and_refuses_a_map(tmp_path, capsys):
    out, summary = tmp_path / "a.jsonl", tmp_path / "a.json"
    args = ["sweep", "--assist", "steps", "--n", "1", "--seed", "1", "--workers", "1", "--out", str(out)]
    assert main([*args, "--json", str(summary)]) == 0
    printed = capsys.readouterr().out
    assert "steps (n=1)" in printed and "rows past the jackknife limit 0" in printed
    assert json.loads(summary.read_text())["all"]["steer_violations"] == 0
    assert len(out.read_text().splitlines()) == 1
    assert main([*args[:-1], str(tmp_path / "b.jsonl"), "--map", str(tmp_path / "m.png")]) == 2
    assert "--map" in capsys.readouterr().err
    assert main(args) == 2  # --out holds records already
