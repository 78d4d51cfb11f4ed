"""The speed commands: ``bench`` (solver routes side by side) and ``realtime`` (the loop on a wall clock)."""

from __future__ import annotations

import argparse
from pathlib import Path

from .arguments import UsageError


def _names(text: str | None, flag: str) -> list[str] | None:
    if text is None:
        return None
    names = [n.strip() for n in text.split(",") if n.strip()]
    if not names:
        raise UsageError(f"{flag} must list names separated by commas, got {text!r}")
    return names


def _cmd_bench(args: argparse.Namespace) -> int:
    from ..app.bench import HORIZONS, bench_table, run_bench
    from ..io import write_json
    from ..outputs import check_output_file

    path = check_output_file(args.json, "--json")
    horizons = () if args.no_scaling else HORIZONS
    results = run_bench(
        _names(args.ocp, "--ocp"), _names(args.routes, "--routes"), args.starts, horizons, progress=print
    )
    write_json(path, {"ocps": {name: bench.to_dict() for name, bench in results.items()}})
    print()
    print(bench_table(results))
    print(f"\nresults: {path}")
    return 0


def _cmd_realtime(args: argparse.Namespace) -> int:
    from ..app.realtime import run_realtime
    from ..io import write_json
    from ..outputs import check_output_file
    from .arguments import _finite, scenario_from_arg

    path = check_output_file(args.json, "--json")
    scenario = scenario_from_arg(args.scenario)
    run = run_realtime(scenario, _finite("--speed-up", args.speed_up), progress=print)
    write_json(path, run.to_dict())
    t = run.tick_ms
    print(
        f"{run.ticks} ticks of {run.period_ms:g} ms, {run.overruns} overruns; work per tick: "
        f"median {t['median']:.2f} ms, p99 {t['p99']:.2f} ms, max {t['max']:.2f} ms; "
        f"planning standing still {run.standstill_planning_s:.2f} s"
    )
    outcome = "parked" if run.maneuver.success else f"not parked ({run.maneuver.reason})"
    print(f"{outcome} after {run.to_dict()['maneuver_s']:.1f} s of driving, {run.wall_s:.1f} s of wall clock -> {path}")
    return 0 if run.overruns == 0 and run.maneuver.success else 1


def add_speed_commands(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "bench",
        help="time every solver route on recorded closed-loop NMPC problems",
        description="Record the NMPC problems the default controller of each OCP poses over closed-loop starts "
        "(the paper's four scenarios and starts from the usual region), solve them with every registered route "
        "in one run, and report per route: median, p99 and max of the whole solve call [ms, wall clock], the "
        "median CPU time, failures (calls that would need the fallback), the speed-up over the ipopt route, "
        "and for the paper's OCP the final errors when the route drives the four scenarios; plus the default "
        "route's median at N = 10, 20, 40 and 80.",
    )
    p.add_argument("--json", required=True, metavar="FILE", help="where to write the results")
    p.add_argument(
        "--ocp", metavar="NAMES", help="OCPs to bench, comma-separated (default: paper,full,obstacles,tracking)"
    )
    p.add_argument("--routes", metavar="NAMES", help="routes to time, comma-separated (default: all registered)")
    p.add_argument(
        "--starts", type=int, default=12, metavar="K", help="closed-loop starts recorded per OCP (default 12)"
    )
    p.add_argument("--no-scaling", action="store_true", help="skip the horizon scaling of the default route")
    p.set_defaults(func=_cmd_bench)

    p = sub.add_parser(
        "realtime",
        help="run a scenario with the controller on a fixed wall-clock tick (software in the loop)",
        description="Park from a scenario with its controller on a fixed 100 ms tick against the plant in "
        "wall-clock time (--speed-up K: a 100/K ms tick), as the paper's HIL test ran at 10 Hz (Section 6.2). "
        "An overrun is a tick whose work did not finish within the tick: everything between two ticks, the "
        "plant's simulated step and the record as well as sensing, the NMPC or tracking step and the guard. "
        "Writes ticks, overruns and the work per tick (median, p99, max in ms). Exit status 1 if any tick "
        "overran or the maneuver did not park.",
    )
    p.add_argument(
        "--scenario", required=True, type=Path, metavar="FILE.toml|NAME", help="a scenario file or built-in name"
    )
    p.add_argument("--speed-up", type=float, default=1.0, metavar="K", help="run K times faster than real time")
    p.add_argument("--json", required=True, metavar="FILE", help="where to write the results")
    p.set_defaults(func=_cmd_realtime)
