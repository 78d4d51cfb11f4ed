"""``hitchpark sil``: the exported controller drives the paper's four scenarios as the in-process one, to the bit."""

from __future__ import annotations

import ctypes
import dataclasses
import subprocess
from pathlib import Path

import pytest

from hitchpark.app.exported import build_package, cached_package_library
from hitchpark.app.sil import run_sil, sil_settings
from hitchpark.checks import InputError
from hitchpark.control.estimator import EstimatorSettings
from hitchpark.maneuver.scenario import BUILTIN_ORDER, builtin_scenario
from hitchpark.model.plant import load_plant
from hitchpark.ocp.settings import NMPCSettings

FAULTS = Path(__file__).parents[2] / "benchmarks" / "plants" / "faults_long.toml"


@pytest.mark.slow
@pytest.mark.parametrize("name", BUILTIN_ORDER)
def test_sil_equals_in_process_on_the_papers_scenarios(name, library, compiled_in_process):
    ipopt = name == "random"  # IPOPT's step time beside the C's, once
    # With IPOPT, the NMPC settings sil takes by default (NMPCSettings(): the paper's scenarios have the paper's)
    # but nmpc.jit, which IPOPT's functions alone take: uncompiled, IPOPT parks in 1 s where compiling its NLPs
    # (CasADi's jit, tests/solvers/test_compiled.py) takes 10 s. The C and riccati_c are compiled whatever it says.
    nmpc = NMPCSettings(jit=False) if ipopt else None
    report = run_sil(builtin_scenario(name), nmpc=nmpc, library=library, ipopt=ipopt).to_dict()
    assert report["same_outcome"], report
    assert report["exported"]["outcome"] == "parked"
    assert report["rows"]["exported"] == report["rows"]["in_process"]
    assert report["max_command_difference"] == 0.0
    assert report["max_state_difference"] == 0.0
    assert report["c_steps"] > 0 and report["c_step_time_ns"]["median"] > 0
    assert 0 < report["workspace_bytes"] <= report["workspace_bound_bytes"]
    assert report["library_bytes"] > 0
    ratios = report["step_time_ratios"]
    assert ratios["python_over_c"] > 0
    if ipopt:  # a third maneuver, parked by IPOPT in-process: its step times
        assert report["ipopt_step_ms"]["median"] > 0 and ratios["ipopt_over_c"] > 0
    else:
        assert report["ipopt_step_ms"] is None and "ipopt_over_c" not in ratios


@pytest.mark.slow
def test_sil_equals_in_process_on_the_fault_plant_where_the_solver_fails(library, compiled_in_process):
    """A delay, hitch noise and lengths 10% longer: the solver fails at a step of the random scenario, and both
    controllers retry from the cold start (the in-process one as exported, without IPOPT), to the bit."""
    scenario = builtin_scenario("random")
    assert sil_settings(scenario.settings).nmpc.fallback_solver is None
    report = run_sil(scenario, plant=load_plant(FAULTS), library=library, ipopt=False).to_dict()
    assert report["plant"]["delay_steps"] == 1 and report["plant"]["hitch_noise_std_deg"] == 0.5
    assert report["exported"]["stage_ends"][0].startswith("solver:")  # the first stage ends where the solver fails
    assert report["same_outcome"] and report["exported"]["outcome"] == "parked"
    assert report["max_command_difference"] == 0.0 and report["max_state_difference"] == 0.0


@pytest.mark.slow
@pytest.mark.parametrize("plant", [None, FAULTS], ids=["ideal", "faults"])
def test_sil_equals_in_process_tracking_the_planners_path(plant, library, compiled_in_process):
    """The planned process: the planner's path, its forward segment tracked in Python, its reverse one by the NMPC
    tracking the path (the package's tracking OCP and the path's reference in C), to the bit."""
    scenario = builtin_scenario("random")
    report = run_sil(scenario, plant=plant and load_plant(plant), library=library, ipopt=False, process="planned")
    report = report.to_dict()
    assert report["paths_followed"] == 1  # one reverse stage, tracking its path
    assert report["exported"]["stage_ends"] == ["repositioned", "stopped"]
    assert report["same_outcome"] and report["exported"]["outcome"] == "parked"
    assert report["rows"]["exported"] == report["rows"]["in_process"] > 300
    assert report["max_command_difference"] == 0.0 and report["max_state_difference"] == 0.0


@pytest.mark.slow
@pytest.mark.parametrize(("name", "plant"), [("driveway", None), ("curb_parallel", FAULTS)], ids=["driveway", "curb"])
def test_sil_equals_in_process_among_obstacles(name, plant, library, compiled_in_process):
    """The obstacle OCP in C (the scene's lines drawn by clearance_lines.c, the cold start's plan without lines and
    its rounds) tracking the planner's path among the scene, to the bit: the driveway on its own plant, the curb on
    the fault plant (a delay, hitch noise, the lengths 10% longer) with the controller told the sensor's noise, so
    that its estimate has a doubt and the NMPC's clearance is held each tick (hitchpark_nmpc_hold_clearance)."""
    scenario = builtin_scenario(name)
    if plant is not None:
        told = dataclasses.replace(scenario.settings, estimator=EstimatorSettings(hitch_noise_std_deg=0.5))
        scenario = dataclasses.replace(scenario, settings=told)
    report = run_sil(scenario, plant=plant and load_plant(plant), library=library, ipopt=False)
    report = report.to_dict()
    assert report["paths_followed"] >= 1 and report["exported"]["outcome"] == "parked"
    assert report["same_outcome"] and report["rows"]["exported"] == report["rows"]["in_process"]
    assert report["max_command_difference"] == 0.0 and report["max_state_difference"] == 0.0


def test_the_package_is_compiled_once_into_the_cache_for_its_sources(jit_cache, monkeypatch):
    """sil builds a package once: the next run with the same sources (another example start) loads it; other
    sources are another build; sources that do not compile are none (and build_package says why)."""
    files = {"src/probe.c": "double probe(void) { return 1.5; }\n", "include/probe.h": "", "examples/main.c": "1"}
    first = cached_package_library(files)
    assert first is not None and first.is_relative_to(jit_cache[0])
    probe = ctypes.CDLL(str(first)).probe
    probe.restype = ctypes.c_double
    assert probe() == 1.5
    with monkeypatch.context() as patch:
        patch.setattr(subprocess, "run", lambda *a, **k: pytest.fail("compiled again despite the cache"))
        assert cached_package_library({**files, "examples/main.c": "2"}) == first
    other = cached_package_library({**files, "src/probe.c": "double probe(void) { return 2.5; }\n"})
    assert other is not None and other != first and first.is_file()
    broken = {**files, "src/probe.c": "double probe(void) { return }\n"}
    assert cached_package_library(broken) is None
    with pytest.raises(InputError, match=r"did not compile: .*error"):
        build_package(broken, jit_cache[1] / "package")


@pytest.mark.slow
def test_a_sweep_driven_by_the_exported_controller_has_the_in_process_records(library, compiled_in_process, tmp_path,
                                                                              monkeypatch):  # fmt: skip
    """``sweep --exported``: each case parked by the package's C (the suite's build of it; among obstacles the sil
    tests drive it) has the record of the same case parked in-process without a fallback solver, field for field but
    the wall clocks."""
    import dataclasses
    import json

    from hitchpark.app import exported as exported_module
    from hitchpark.app.sweep import SweepConfig, controller_for, run_sweep

    monkeypatch.setattr(exported_module, "cached_package_library", lambda files: library)
    config = SweepConfig(n=2, seed=3)
    settings, lib = exported_module.exported_controller_library(
        config.vehicle, config.settings, config.goal, config.plant, config.scene
    )
    assert lib == library and settings.nmpc.fallback_solver is None and settings.nmpc.kind == "full"
    exported = dataclasses.replace(config, settings=settings, exported=lib)
    assert isinstance(controller_for(exported), exported_module.ExportedNMPC)  # the C drives, run_case's controller
    c = run_sweep(exported, tmp_path / "c.jsonl")
    py = run_sweep(dataclasses.replace(config, settings=settings), tmp_path / "py.jsonl")
    assert c.summary["controller"] == "exported" and "controller" not in py.summary
    lines = [[json.loads(line) for line in (tmp_path / f"{n}.jsonl").read_text().splitlines()] for n in ("c", "py")]
    clock = ("wall_s", "planning_s")
    assert [{k: v for k, v in r.items() if k not in clock} for r in lines[0]] == [
        {k: v for k, v in r.items() if k not in clock} for r in lines[1]
    ]
    assert all(r["success"] for r in lines[0]) and len(lines[0]) == 2


def test_sweep_exported_refuses_what_it_cannot_drive(tmp_path, capsys):
    from hitchpark.cli import EXIT_BAD_INPUT, main

    (tmp_path / "paper.toml").write_text('[nmpc]\nkind = "paper"\n')
    out = tmp_path / "s.jsonl"
    for extra, message in (
        (["--settings", str(tmp_path / "paper.toml")], "nmpc.kind 'full'"),
        (["--assist", "hold"], "--exported drives parking sweeps"),
    ):
        assert main(["sweep", "--n", "2", "--seed", "1", "--exported", "--out", str(out), *extra]) == EXIT_BAD_INPUT
        err = capsys.readouterr().err
        assert message in err and len(err.strip().splitlines()) == 1
        assert not out.exists()
