"""What the planner's refined end (``planner.refine_m``) costs: each plan made twice, with and without it.

    python benchmarks/refine_time.py [N] [SEED] [--solver NAME]

N starts of the open-space sweep's usual region (as ``hitchpark sweep --n N --seed SEED``, default 40
and 7), planned to the goal in an empty scene, then the five obstacle scenes from their ``[start]``
(the planner's clearance 0.3 m, as the planned process asks): the extra planning time of the refined
plan over the searched one, and whether its end was refined. ``--solver`` names the refinement NLP's
solver (``planner.refine_solver``: ``fatrop``, the default, or ``ipopt``, the reference). A measurement,
not a test.
"""

from __future__ import annotations

import sys
from dataclasses import replace

import numpy as np

from hitchpark.app.starts import DEFAULT_REGION, draw_starts
from hitchpark.maneuver.scenario import OBSTACLE_SUITE, builtin_scenario
from hitchpark.model import Pose, VehicleTrailer
from hitchpark.model.scene import Scene
from hitchpark.planning import PlannerSettings, plan

CLEARANCE_M = 0.3  # success.min_clearance_m + process.plan_margin_m


def _extra(vehicle, start, goal, scene, settings: PlannerSettings) -> tuple[float, str]:
    searched = plan(vehicle, start, goal, scene, replace(settings, refine_m=0.0))
    refined = plan(vehicle, start, goal, scene, settings)
    return refined.planning_s - searched.planning_s, refined.detail


def main() -> None:
    args = sys.argv[1:]
    solver = "fatrop"
    if "--solver" in args:
        at = args.index("--solver")
        solver = args[at + 1]
        del args[at : at + 2]
    n = int(args[0]) if args else 40
    seed = int(args[1]) if len(args) > 1 else 7
    settings = PlannerSettings(min_clearance_m=CLEARANCE_M, refine_solver=solver)
    vehicle = VehicleTrailer()
    extra, refined = [], 0
    for start in draw_starts(seed, n, DEFAULT_REGION):
        dt, detail = _extra(vehicle, start.state(), Pose(), Scene(), settings)
        extra.append(dt)
        refined += detail.endswith("its end refined to end at the goal")
    print(
        f"refine_solver {solver}; open space, {n} starts (seed {seed}): {refined} refined; extra planning time "
        f"median {np.median(extra) * 1e3:.0f} ms, max {np.max(extra) * 1e3:.0f} ms"
    )
    for name in OBSTACLE_SUITE:
        sc = builtin_scenario(name)
        dt, detail = _extra(
            sc.vehicle,
            sc.start,
            sc.goal,
            sc.scene,
            replace(sc.settings.planner, min_clearance_m=CLEARANCE_M, refine_solver=solver),
        )
        print(f"{name:14s} extra {dt:.3f} s: {detail}")


if __name__ == "__main__":
    main()
