"""``hitchpark bench``: the solver routes side by side on recorded closed-loop NMPC problems.

For each OCP (:data:`BENCH_OCPS`) the default controller drives a set of closed-loop starts (the
paper's scenarios and the usual region in open space; for the obstacle OCP the built-in scenes of
obstacles and their start regions) and records every problem it poses
(:class:`~hitchpark.control.nmpc.NLPProblem`). Every registered
route then solves the same problems, in one run, and is timed call by call: the whole call from
Python (wall clock, and the process's CPU time beside it), failures (a call that would have needed
the fallback), and how far its first move lies from IPOPT's. For the paper's OCP each route also
drives the four paper scenarios, and for each OCP the default route is timed at N = 10, 20, 40, 80.
Speeds are ratios to the ``ipopt`` route measured in the same run: machines are noisy, and their speed
drifts over minutes, so the routes (and the horizons) take turns, each solving its next share of the
problems in each of :data:`~.timing.ROUNDS` rounds (:func:`~.timing.time_interleaved`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ..checks import InputError, check_int
from ..control.nmpc import FullNMPC, NLPProblem, TrailerNMPC, make_nmpc
from ..maneuver import ManeuverSettings, builtin_scenarios, park
from ..maneuver.scenario import OBSTACLE_SUITE, builtin_scenario
from ..maneuver.settings import ProcessSettings
from ..model.plant import PlantSettings
from ..model.scene import Scene
from ..model.state import Pose, State
from ..model.vehicle import VehicleTrailer
from ..ocp.settings import NMPCSettings
from ..solvers.registry import ROUTES, make_solver, quiet_stderr
from .starts import DEFAULT_REGION, draw_starts
from .sweep import config_from_scenario
from .timing import time_interleaved

__all__ = [
    "BENCH_OCPS",
    "HORIZONS",
    "BenchOCP",
    "BenchStart",
    "OCPBench",
    "RouteBench",
    "bench_table",
    "own_problems",
    "record_problems",
    "run_bench",
]

#: Horizons of the scaling test.
HORIZONS = (10, 20, 40, 80)

#: A route's calls on one OCP stop after this many seconds (its figures then cover the first ``calls``
#: problems): BFGS takes seconds per obstacle problem, and would hold the bench up for hours.
ROUTE_BUDGET_S = 120.0


#: Seed of the starts drawn from the usual region beside the paper's four scenarios.
START_SEED = 2025


@dataclass(frozen=True)
class BenchStart:
    """A closed loop that records problems: where it starts, its goal, and the scene around it."""

    name: str
    start: State
    goal: Pose = field(default_factory=Pose)
    scene: Scene = field(default_factory=Scene)


@dataclass(frozen=True)
class BenchOCP:
    """An OCP to bench: its NMPC settings, the plant and process its closed loops run on, and where they run.

    ``scenes``: the loops park in the built-in scenes of obstacles (the obstacle OCP); else in open space.
    """

    name: str
    nmpc: NMPCSettings
    plant: PlantSettings
    process: ProcessSettings = field(default_factory=ProcessSettings)
    scenes: bool = False

    def settings(self, horizon: int | None = None) -> ManeuverSettings:
        nmpc = self.nmpc if horizon is None else replace(self.nmpc, horizon=horizon)
        return ManeuverSettings(nmpc=nmpc, process=self.process)

    def starts(self, n: int) -> list[BenchStart]:
        """``n`` closed loops: the paper's four scenarios then the usual region; or each scene's start, then
        clear starts drawn from the scenes' regions in turn."""
        if not self.scenes:
            return _starts(n)
        scenes = [builtin_scenario(name) for name in OBSTACLE_SUITE]
        out = [BenchStart(sc.name, sc.start, sc.goal, sc.scene) for sc in scenes][:n]
        extra = n - len(out)
        for i, sc in enumerate(scenes):
            count = extra // len(scenes) + (i < extra % len(scenes))
            if count and sc.start_region is not None:
                drawn = config_from_scenario(sc, n=count, seed=START_SEED).starts()
                out += [BenchStart(f"{sc.name} {j}", s.state(), sc.goal, sc.scene) for j, s in enumerate(drawn)]
        return out


#: The OCPs ``bench`` knows: the paper's (its 3-stage process on the ideal car), the full model's (parking
#: at the goal on the realistic car, open space), the obstacle OCP (the full model keeping clear of the
#: scene, :mod:`~hitchpark.ocp.obstacles`, in the built-in scenes of obstacles) and the tracking OCP
#: (the full model tracking the planned path, :mod:`~hitchpark.ocp.reference`: the default process in
#: open space). The full and obstacle OCPs park at the goal: their planned processes hand the last metres
#: to the NMPC instead of letting it track the whole last segment (``process.nmpc_tracking``).
_PARKING = ProcessSettings(nmpc_tracking=False)
BENCH_OCPS: dict[str, BenchOCP] = {
    "paper": BenchOCP("paper", NMPCSettings(kind="paper"), PlantSettings(kind="ideal"), ProcessSettings(kind="staged")),
    "full": BenchOCP("full", NMPCSettings(kind="full"), PlantSettings(), _PARKING),
    "obstacles": BenchOCP("obstacles", NMPCSettings(kind="full"), PlantSettings(), _PARKING, scenes=True),
    "tracking": BenchOCP("tracking", NMPCSettings(kind="full"), PlantSettings()),
}


@dataclass(frozen=True)
class RouteBench:
    """One route on one OCP's recorded problems (times in ms, per call)."""

    median_ms: float
    p99_ms: float
    max_ms: float
    cpu_median_ms: float
    failures: int
    calls: int
    speedup_vs_ipopt: float
    max_move_diff: float  # largest |first move - IPOPT's| over the problems both solved (input units)
    final_errors: dict[str, dict[str, float]] = field(default_factory=dict)
    #: The solver's own count per call, median and p99 (NaN: the route reports none). Time over iterations
    #: is what carries over to another computer; the count is the route's and the problems'.
    iterations_median: float = math.nan
    iterations_p99: float = math.nan

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {k: getattr(self, k) for k in self.__dataclass_fields__ if k != "final_errors"}
        for key in ("max_move_diff", "iterations_median", "iterations_p99"):
            if math.isnan(out[key]):  # no problem solved by both; no count reported
                out[key] = None
        if self.final_errors:
            out["final_errors"] = self.final_errors
        return out


@dataclass(frozen=True)
class OCPBench:
    """All routes on one OCP, the default route and its horizon scaling."""

    routes: dict[str, RouteBench]
    default: str
    horizon_scaling_ms: dict[str, float]
    problems: int
    starts: int
    #: Per horizon, the default route's calls that failed (that the fallback would have answered).
    horizon_scaling_failures: dict[str, int] = field(default_factory=dict)
    #: Per horizon, the default route's median iterations (NaN: it reports none): N = 80 against N = 10 in
    #: time is the cost of a stage times the ratio of these.
    horizon_scaling_iterations: dict[str, float] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {
            "routes": {name: r.to_dict() for name, r in self.routes.items()},
            "default": self.default,
            "horizon_scaling_ms": dict(self.horizon_scaling_ms),
            "horizon_scaling_failures": dict(self.horizon_scaling_failures),
            "horizon_scaling_iterations": {
                n: (None if math.isnan(its) else its) for n, its in self.horizon_scaling_iterations.items()
            },
            "problems": self.problems,
            "starts": self.starts,
        }


def _starts(n: int) -> list[BenchStart]:
    """The paper's four scenarios' starts, then starts drawn from the usual region, ``n`` in all."""
    out = [BenchStart(sc.name, sc.start, sc.goal) for sc in builtin_scenarios()][:n]
    if n > len(out):
        drawn = draw_starts(START_SEED, n - len(out), DEFAULT_REGION)
        out += [BenchStart(f"start {i}", s.state()) for i, s in enumerate(drawn)]
    return out


def record_problems(
    ocp: BenchOCP, vehicle: VehicleTrailer, starts: Sequence[BenchStart], horizon: int | None = None
) -> tuple[TrailerNMPC | FullNMPC, list[NLPProblem]]:
    """The default controller of ``ocp`` and every problem it poses while parking from ``starts``.

    Among obstacles the controller solves the obstacle OCP (``keep_clear``), which ``transcription`` then lays out.
    """
    settings = ocp.settings(horizon)
    controller = make_nmpc(vehicle, settings.nmpc)
    problems: list[NLPProblem] = []
    controller.recorder = problems
    for s in starts:
        park(vehicle, s.start, s.goal, settings, name=s.name, controller=controller, plant=ocp.plant, scene=s.scene)
    controller.recorder = None
    return controller, problems


def own_problems(controller: TrailerNMPC | FullNMPC, problems: Sequence[NLPProblem]) -> list[NLPProblem]:
    """The problems of the OCP ``controller`` solves now (the one its solver takes): not those of a tracking
    loop that fell back on the 3-stage process parked at the goal, whose parameters differ."""
    n_p = controller.transcription.nlp["p"].numel()
    return [problem for problem in problems if len(problem.p) == n_p]


def _final_errors(route: str, ocp: BenchOCP) -> dict[str, dict[str, float]]:
    """Final distance and orientation error when ``route`` drives each of the paper's four scenarios."""
    out = {}
    for sc in builtin_scenarios():
        settings = ocp.settings()
        settings = replace(settings, nmpc=replace(settings.nmpc, solver=route))
        result = park(sc.vehicle, sc.start, sc.goal, settings, name=sc.name, plant=ocp.plant)
        last = result.stages[-1]
        out[sc.name] = {
            "distance_m": float(last.distance_error_m),
            "orientation_deg": float(last.orientation_error_deg),
            "parked": bool(result.success),
        }
    return out


def bench_ocp(
    ocp: BenchOCP,
    routes: Sequence[str],
    n_starts: int,
    horizons: Sequence[int] = HORIZONS,
    progress: Callable[[str], None] = lambda _: None,
) -> OCPBench:
    """Record ``ocp``'s problems from ``n_starts`` closed loops and time every route in ``routes`` on them."""
    vehicle = VehicleTrailer()
    starts = ocp.starts(n_starts)
    progress(f"{ocp.name}: recording the default controller on {len(starts)} closed-loop starts")
    recorder, problems = record_problems(ocp, vehicle, starts)
    tr = recorder.transcription  # it lays out the problems
    problems = own_problems(recorder, problems)
    equality = list(tr.lbg == tr.ubg)
    jobs = {}
    for name in dict.fromkeys(["ipopt", *routes]):
        progress(f"{ocp.name}: building the {name} route")
        with quiet_stderr():
            solver = make_solver(
                name,
                tr.nlp,
                equality,
                jit=bool(ocp.nmpc.jit),
                transcription=tr,
                dual_floor=recorder.settings.dual_floor,
            )
        jobs[name] = (solver, problems, math.inf if name == "ipopt" else ROUTE_BUDGET_S)
    progress(f"{ocp.name}: {', '.join(jobs)} on {len(problems)} problems, taking turns")
    timed = time_interleaved(jobs)
    ipopt_median = float(np.median(timed["ipopt"].wall))
    results = {}
    for name in routes:
        wall, cpu, answers, iterations = timed[name]
        diffs = [
            np.max(np.abs(tr.unpack(a, p.p)[1][0] - tr.unpack(b, p.p)[1][0]))
            for a, b, p in zip(answers, timed["ipopt"].answers, problems, strict=False)  # a route cut short: its calls
            if a is not None and b is not None
        ]
        finals = {}
        if ocp.name == "paper":
            progress(f"{ocp.name}: {name} drives the four paper scenarios")
            finals = _final_errors(name, ocp)
        results[name] = RouteBench(
            float(np.median(wall)),
            float(np.percentile(wall, 99)),
            float(np.max(wall)),
            float(np.median(cpu)),
            sum(a is None for a in answers),
            len(answers),
            ipopt_median / float(np.median(wall)),
            float(max(diffs)) if diffs else math.nan,
            finals,
            *_iteration_stats(iterations),
        )
    default = ocp.nmpc.solver
    assert default is not None
    horizon_jobs = {}
    for horizon in horizons:
        progress(f"{ocp.name}: recording the default route ({default}) at N = {horizon}")
        controller, recorded = record_problems(ocp, vehicle, starts[:4], horizon)
        horizon_jobs[str(horizon)] = (controller.solver, own_problems(controller, recorded), math.inf)
    progress(f"{ocp.name}: the default route at N = {', '.join(horizon_jobs)}, taking turns")
    timed_horizons = time_interleaved(horizon_jobs)
    scaling = {key: float(np.median(calls.wall)) for key, calls in timed_horizons.items()}
    failed = {key: sum(a is None for a in calls.answers) for key, calls in timed_horizons.items()}
    counts = {key: _iteration_stats(calls.iterations)[0] for key, calls in timed_horizons.items()}
    return OCPBench(results, default, scaling, len(problems), len(starts), failed, counts)


def _iteration_stats(iterations: np.ndarray) -> tuple[float, float]:
    """Median and p99 of the iterations of the calls that report them (NaN, NaN: none does)."""
    known = iterations[np.isfinite(iterations)]
    if not len(known):
        return math.nan, math.nan
    return float(np.median(known)), float(np.percentile(known, 99))


def run_bench(
    ocps: Sequence[str] | None = None,
    routes: Sequence[str] | None = None,
    n_starts: int = 12,
    horizons: Sequence[int] = HORIZONS,
    progress: Callable[[str], None] = lambda _: None,
) -> dict[str, OCPBench]:
    """Bench ``routes`` (default: all registered) on ``ocps`` (default: all of :data:`BENCH_OCPS`)."""
    ocps = list(BENCH_OCPS) if ocps is None else list(ocps)
    routes = list(ROUTES) if routes is None else list(routes)
    for name in ocps:
        if name not in BENCH_OCPS:
            raise InputError(f"--ocp must name OCPs among {', '.join(BENCH_OCPS)}, got {name!r}")
    for name in routes:
        if name not in ROUTES:
            raise InputError(f"--routes must name routes among {', '.join(ROUTES)}, got {name!r}")
    check_int("--starts", n_starts, 1, 1000)
    return {name: bench_ocp(BENCH_OCPS[name], routes, n_starts, horizons, progress) for name in ocps}


def bench_table(results: dict[str, OCPBench]) -> str:
    """The printed table: one row per OCP and route, the default marked."""
    head = (
        f"{'OCP':<10}{'route':<11}{'median ms':>10}{'p99 ms':>10}{'max ms':>10}{'cpu ms':>8}{'fails':>7}"
        f"{'its':>5}{'x ipopt':>9}{'move diff':>11}{'worst final error':>22}"
    )
    lines = [head]
    for ocp, bench in results.items():
        for name, r in bench.routes.items():
            mark = "*" if name == bench.default else " "
            final = ""
            if r.final_errors:
                d = max(e["distance_m"] for e in r.final_errors.values())
                o = max(abs(e["orientation_deg"]) for e in r.final_errors.values())
                final = f"{1e3 * d:.3f} mm {o:.4f} deg"
            cut = (
                f"  (first {r.calls} of {bench.problems} problems: {ROUTE_BUDGET_S:g} s spent)"
                if r.calls < bench.problems
                else ""
            )
            lines.append(
                f"{ocp:<10}{name + mark:<11}{r.median_ms:>10.3f}{r.p99_ms:>10.3f}{r.max_ms:>10.3f}"
                f"{r.cpu_median_ms:>8.3f}{r.failures:>7d}{_its(r.iterations_median):>5}{r.speedup_vs_ipopt:>9.1f}"
                f"{r.max_move_diff:>11.1e}{final:>22}{cut}"
            )
        scaling = ", ".join(
            f"N={n}: {ms:.3f}"
            + (f" ({its} its)" if (its := _its(bench.horizon_scaling_iterations.get(n, math.nan))) != "-" else "")
            + (f" ({fails} failed)" if (fails := bench.horizon_scaling_failures.get(n, 0)) else "")
            for n, ms in bench.horizon_scaling_ms.items()
        )
        lines.append(f"{'':<10}default {bench.default} by horizon [ms]: {scaling}")
    lines.append(
        "* the default route; its = the route's median iterations; x ipopt = IPOPT's median over the route's, same run"
    )
    return "\n".join(lines)


def _its(count: float) -> str:
    return "-" if math.isnan(count) else f"{count:g}"
