"""``hitchpark realtime`` with the free-steer problem on different routes, interleaved in one run.

    python benchmarks/realtime_routes.py [--speed-up K] [--routes ipopt,sqp_c,riccati_c] SCENARIO [SCENARIO ...]

For each scenario (a built-in name) and, in turn, each route named in ``--routes`` for a stage's
free-steer problem, runs the scenario on a wall-clock tick of 100/K ms (K = 10 by default: an embedded
computer ten times slower) and prints the overruns, the longest tick and the p99 of the work per tick. A
general route (``ipopt``, ``sqp_c``) is ``nmpc.relaxed_solver`` behind ``fatrop_c``, which cannot take the
problem; ``riccati_c`` is the NMPC's solver and takes it itself. The routes alternate scenario by scenario,
so that the machine's drift falls on all. A measurement, not a test.
"""

from __future__ import annotations

import argparse
from dataclasses import replace

from hitchpark.app.realtime import run_realtime
from hitchpark.maneuver.scenario import builtin_scenario
from hitchpark.solvers.registry import ROUTES


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenarios", nargs="+", metavar="SCENARIO")
    parser.add_argument("--speed-up", type=float, default=10.0)
    parser.add_argument("--routes", default="ipopt,sqp_c,riccati_c")
    args = parser.parse_args()
    routes = args.routes.split(",")
    for name in args.scenarios:
        scenario = builtin_scenario(name)
        cells = []
        for route in routes:
            nmpc = scenario.settings.nmpc
            if ROUTES[route].structured:  # the NMPC's own solver
                nmpc = replace(nmpc, solver=route)
            else:
                nmpc = replace(nmpc, solver="fatrop_c", relaxed_solver=route)
            run = run_realtime(replace(scenario, settings=replace(scenario.settings, nmpc=nmpc)), args.speed_up)
            cells.append(
                f"{route}: {run.overruns}/{run.ticks} overruns, max {run.tick_ms['max']:.2f} ms, "
                f"p99 {run.tick_ms['p99']:.2f} ms, {run.maneuver.reason}"
            )
        print(f"{name:<14} " + " | ".join(cells), flush=True)


if __name__ == "__main__":
    main()
