"""``hitchpark bench`` and ``hitchpark realtime``: what they measure and write, and bad input."""

from __future__ import annotations

import gc
import json
import time
from dataclasses import replace

import numpy as np
import pytest

from hitchpark.app import bench as bench_module
from hitchpark.app.bench import BENCH_OCPS, OCPBench, RouteBench, bench_table, run_bench
from hitchpark.app.realtime import WallClock, run_realtime
from hitchpark.app.timing import time_interleaved
from hitchpark.cli import EXIT_BAD_INPUT, main
from hitchpark.control import NMPCSettings
from hitchpark.control.nmpc import NLPProblem, make_nmpc
from hitchpark.maneuver import park
from hitchpark.maneuver.scenario import OBSTACLE_SUITE, builtin_scenario
from hitchpark.model import VehicleTrailer

ROUTE_KEYS = {"median_ms", "p99_ms", "max_ms", "cpu_median_ms", "failures", "speedup_vs_ipopt"}


@pytest.fixture(scope="module")
def paper_bench():
    return run_bench(["paper"], ["ipopt", "sqp"], n_starts=1, horizons=(10, 20))


@pytest.mark.slow
def test_bench_times_every_route_on_the_same_recorded_problems(paper_bench):
    bench = paper_bench["paper"]
    assert bench.default == BENCH_OCPS["paper"].nmpc.solver
    assert bench.problems > 100 and bench.starts == 1
    assert set(bench.routes) == {"ipopt", "sqp"}
    for route in bench.routes.values():
        assert route.calls == bench.problems and route.failures == 0
        assert 0 < route.median_ms <= route.p99_ms <= route.max_ms
        assert route.cpu_median_ms > 0
        assert route.max_move_diff < 1e-3  # the same optimum as IPOPT's on every recorded problem
    assert bench.routes["ipopt"].speedup_vs_ipopt == 1.0
    assert bench.routes["ipopt"].max_move_diff == 0.0
    assert list(bench.horizon_scaling_ms) == ["10", "20"] and all(v > 0 for v in bench.horizon_scaling_ms.values())
    assert bench.horizon_scaling_failures == {"10": 0, "20": 0}
    # Every route here counts its iterations: IPOPT's interior point takes more than the warm-started SQP.
    for route in bench.routes.values():
        assert 1 <= route.iterations_median <= route.iterations_p99 and route.iterations_median % 0.5 == 0
    assert bench.routes["ipopt"].iterations_median > bench.routes["sqp"].iterations_median
    assert list(bench.horizon_scaling_iterations) == ["10", "20"]
    assert all(v >= 1 for v in bench.horizon_scaling_iterations.values())


def test_bench_drives_the_paper_scenarios_with_each_route(paper_bench):
    routes = paper_bench["paper"].routes
    assert list(routes["ipopt"].final_errors) == ["parallel", "parallel_hitch", "perpendicular", "random"]
    for name, ref in routes["ipopt"].final_errors.items():
        got = routes["sqp"].final_errors[name]
        assert ref["parked"] and got["parked"]
        assert abs(got["distance_m"] - ref["distance_m"]) < 1e-3
        assert abs(got["orientation_deg"] - ref["orientation_deg"]) < 0.01


@pytest.mark.slow
def test_the_obstacle_ocp_is_benched_on_the_scenes_and_a_slow_route_is_cut_short(monkeypatch):
    starts = BENCH_OCPS["obstacles"].starts(7)
    assert [s.name for s in starts[:5]] == list(OBSTACLE_SUITE) and len(starts) == 7
    assert all(not s.scene.is_empty for s in starts)
    monkeypatch.setattr(bench_module, "ROUTE_BUDGET_S", 0.05)  # the routes but IPOPT stop after 50 ms of calls
    bench = run_bench(["obstacles"], ["ipopt", "fatrop"], n_starts=1, horizons=())["obstacles"]
    assert bench.starts == 1 and bench.problems > 50  # the driveway's NMPC stage
    ipopt, fatrop = bench.routes["ipopt"], bench.routes["fatrop"]
    assert ipopt.calls == bench.problems and ipopt.failures == 0
    assert 0 < fatrop.calls < bench.problems and fatrop.failures == 0
    assert fatrop.max_move_diff < 1e-3  # the same optimum as IPOPT's where both ran
    assert f"first {fatrop.calls} of {bench.problems}" in bench_table({"obstacles": bench})


@pytest.mark.slow
def test_the_tracking_ocp_is_benched_on_the_problems_of_the_nmpc_tracking_the_plan():
    bench = run_bench(["tracking"], ["ipopt", "fatrop_c"], n_starts=1, horizons=(10,))["tracking"]
    assert bench.starts == 1 and bench.problems > 100  # the NMPC drives the whole reverse run
    ipopt, fast = bench.routes["ipopt"], bench.routes["fatrop_c"]
    assert ipopt.failures == 0 and fast.failures == 0 and fast.calls == bench.problems
    assert fast.max_move_diff < 1e-3
    assert set(bench.horizon_scaling_ms) == {"10"}


class _Problem:
    def __init__(self, value: float):
        self.value = value

    def inputs(self, duals: bool = False) -> dict:
        return {"x0": self.value}


class _Solver:
    """Answers its input back and logs each call; fails on negative inputs."""

    def __init__(self, name: str, log: list, sleep_s: float = 0.0):
        self.name, self.log, self.sleep_s, self.ok = name, log, sleep_s, True

    def __call__(self, x0: float) -> dict:
        self.log.append((self.name, x0))
        self.ok = x0 >= 0
        time.sleep(self.sleep_s)
        return {"x": np.array([x0])}

    def stats(self) -> dict:
        return {"success": self.ok}


def test_timed_jobs_take_turns_each_solving_its_problems_in_order_once():
    log: list = []
    a = [_Problem(float(i)) for i in range(8)]
    b = [_Problem(float(100 + i)) for i in range(4)] + [_Problem(-1.0)]
    timed = time_interleaved(
        {"a": (_Solver("a", log), a, float("inf")), "b": (_Solver("b", log), b, float("inf"))}, rounds=4
    )
    warm = len(a) + len(b)  # each job's first (up to 20) problems are solved once, untimed, before any timing
    assert log[:warm] == [("a", p.value) for p in a] + [("b", p.value) for p in b]
    timed_log = log[warm:]
    # round r: a's problems 2r, 2r+1, then b's share (5 problems in 4 rounds: 1, 1, 1, 2)
    assert [name for name, _ in timed_log] == list("aabaabaabaabb")
    assert [x for name, x in timed_log if name == "a"] == [p.value for p in a]
    assert [x for name, x in timed_log if name == "b"] == [p.value for p in b]
    wall, cpu, answers, iterations = timed["b"]
    assert len(wall) == len(cpu) == len(answers) == len(iterations) == len(b) and np.all(wall >= 0)
    assert [None if x is None else float(x[0]) for x in answers] == [100.0, 101.0, 102.0, 103.0, None]
    assert np.all(np.isnan(iterations))  # this solver reports no iterations


class _DualSolver(_Solver):
    """A solver that starts from given multipliers (as a warm-start build of fatrop_c): logs what it got."""

    warm_duals = True

    def __call__(self, x0: float, lam_x0: float | None = None) -> dict:  # type: ignore[override]
        self.log.append((self.name, x0, lam_x0))
        return {"x": np.array([x0])}


class _DualProblem(_Problem):
    def inputs(self, duals: bool = False) -> dict:
        return {"x0": self.value, **({"lam_x0": -self.value} if duals else {})}


def test_timed_jobs_give_the_recorded_multipliers_only_to_a_solver_that_takes_them():
    log: list = []
    problems = [_DualProblem(float(i)) for i in range(3)]
    time_interleaved(
        {"warm": (_DualSolver("warm", log), problems, float("inf")), "plain": (_Solver("plain", log), problems, 1e9)},
        rounds=1,
    )
    assert [entry for entry in log if entry[0] == "warm"] == [("warm", float(i), -float(i)) for i in range(3)] * 2
    assert [entry for entry in log if entry[0] == "plain"] == [("plain", float(i)) for i in range(3)] * 2


def test_a_timed_job_stops_once_its_budget_is_spent_while_the_others_go_on():
    log: list = []
    problems = [_Problem(float(i)) for i in range(40)]
    timed = time_interleaved(
        {
            "slow": (_Solver("slow", log, sleep_s=0.002), problems, 0.01),
            "fast": (_Solver("fast", log), problems, float("inf")),
        },
        rounds=4,
    )
    slow_wall, _, slow_answers, _ = timed["slow"]
    # Stopped after the call that took the job past its 10 ms: each call sleeps 2 ms or more (longer on a busy
    # machine), so that is within the first round of 10 problems, whatever the machine's load.
    assert 1 <= len(slow_wall) <= 6
    assert sum(slow_wall[:-1]) <= 10.0 + 1e-9 < sum(slow_wall)
    assert [float(x[0]) for x in slow_answers] == [p.value for p in problems[: len(slow_answers)]]
    assert len(timed["fast"][0]) == len(problems)


@pytest.mark.slow
def test_cli_bench_writes_the_schema(tmp_path, capsys):
    """The command end to end, its JSON and table. Its route is sqp: each route's entry has the same keys, and sqp
    drives the paper's four scenarios in a quarter of IPOPT's time (the module's bench drives them with both)."""
    out = tmp_path / "bench.json"
    argv = ["bench", "--json", str(out), "--ocp", "paper", "--routes", "sqp", "--starts", "1", "--no-scaling"]
    assert main(argv) == 0
    data = json.loads(out.read_text(encoding="utf-8"))
    paper = data["ocps"]["paper"]
    assert set(paper["routes"]) == {"sqp"}
    assert ROUTE_KEYS <= set(paper["routes"]["sqp"]) and set(paper["routes"]["sqp"]["final_errors"]) == {
        "parallel",
        "parallel_hitch",
        "perpendicular",
        "random",
    }
    assert paper["default"] == BENCH_OCPS["paper"].nmpc.solver and paper["horizon_scaling_ms"] == {}
    assert paper["horizon_scaling_failures"] == {} and paper["horizon_scaling_iterations"] == {}
    assert paper["routes"]["sqp"]["iterations_median"] >= 1
    assert "x ipopt" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("argv", "match"),
    [
        (["--routes", "cplex"], "--routes must name routes among"),
        (["--ocp", "corridor,paper"], "--ocp must name OCPs among"),
        (["--starts", "0"], "--starts"),
        (["--routes", ","], "--routes must list names"),
    ],
)
def test_cli_bench_bad_input(tmp_path, capsys, argv, match):
    out = tmp_path / "bench.json"
    assert main(["bench", "--json", str(out), *argv]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert match in err and err.count("\n") == 1 and "Traceback" not in err
    assert not out.exists()


def test_wall_clock_holds_ticks_to_the_period_and_counts_overruns():
    clock = WallClock(0.05)
    clock.restart()
    start = time.perf_counter()
    clock.tick()  # no work: waits out the period
    assert time.perf_counter() - start >= 0.05
    time.sleep(0.25)  # five periods of work
    clock.tick()
    assert clock.ticks == 2 and clock.overruns == 1
    assert clock.work_s[1] >= 0.25


def test_wall_clock_restart_freezes_what_lives_and_realtime_thaws_it():
    """A clock's restart (a stage begins, standing still) collects and freezes the objects alive, so that a
    full collection in a tick does not walk through them; after the run they are collectable again."""
    gc.unfreeze()
    before = gc.get_freeze_count()
    clock = WallClock(0.05)
    clock.restart()
    assert gc.get_freeze_count() > before
    gc.unfreeze()
    run_realtime(builtin_scenario("parallel"), speed_up=1000.0)
    assert gc.get_freeze_count() == 0


def test_realtime_drives_the_same_maneuver_as_park():
    scenario = builtin_scenario("parallel")
    run = run_realtime(scenario, speed_up=1000.0)  # a 0.1 ms tick: the clock paces, it must not steer
    plain = park(scenario.vehicle, scenario.start, scenario.goal, scenario.settings, plant=scenario.plant)
    tr, ref = run.maneuver.trajectory, plain.trajectory
    assert run.maneuver.success and len(tr) == len(ref)
    np.testing.assert_array_equal(tr.states(), ref.states())
    assert run.ticks == len(tr) - 1  # one tick per applied sample
    assert run.period_ms == pytest.approx(0.1)
    assert run.tick_ms["median"] <= run.tick_ms["p99"] <= run.tick_ms["max"]


def test_cli_realtime_writes_ticks_and_refuses_bad_speed_up(tmp_path, capsys):
    out = tmp_path / "rt.json"
    code = main(["realtime", "--scenario", "parallel", "--speed-up", "1000", "--json", str(out)])
    data = json.loads(out.read_text(encoding="utf-8"))
    assert code == (0 if data["overruns"] == 0 and data["parked"] else 1)
    assert {"ticks", "overruns", "tick_ms"} <= set(data) and set(data["tick_ms"]) == {"median", "p99", "max"}
    assert data["parked"] is True
    bad = tmp_path / "bad.json"
    assert main(["realtime", "--scenario", "parallel", "--speed-up", "0", "--json", str(bad)]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert "--speed-up" in err and err.count("\n") == 1
    assert not bad.exists()


def test_the_table_names_the_failures_of_a_horizon():
    route = RouteBench(1.0, 2.0, 3.0, 1.0, 0, 10, 1.0, 0.0)
    bench = OCPBench({"ipopt": route}, "ipopt", {"10": 0.1, "80": 0.9}, 10, 1, {"10": 0, "80": 2})
    table = bench_table({"paper": bench})
    assert "N=10: 0.100, N=80: 0.900 (2 failed)" in table
    assert bench.to_dict()["horizon_scaling_failures"] == {"10": 0, "80": 2}
    assert route.to_dict()["iterations_median"] is None  # no count: null in JSON, "-" in the table
    counted = OCPBench({"ipopt": replace(route, iterations_median=4.0)}, "ipopt", {"10": 0.1}, 10, 1, {}, {"10": 4.0})
    table = bench_table({"paper": counted})
    assert "N=10: 0.100 (4 its)" in table and counted.to_dict()["horizon_scaling_iterations"] == {"10": 4.0}


def test_a_horizon_is_timed_on_the_problems_of_the_ocp_its_solver_takes():
    """A loop can pose problems of two OCPs (a tracking loop that fell back on the 3-stage process); only
    those of the OCP the controller solves now go to its solver, at every horizon as in the routes' runs."""
    controller = make_nmpc(VehicleTrailer(), NMPCSettings(kind="paper"))
    n_p = controller.transcription.nlp["p"].numel()
    own, other = (NLPProblem(*(np.zeros(n) for n in (k, 3, 3, 3, 1, 1))) for k in (n_p, n_p + 6))
    kept = bench_module.own_problems(controller, [own, other, own])
    assert len(kept) == 2 and all(problem is own for problem in kept)
