"""What the planner's refined end (``planner.refine_m``) costs: each plan made twice, with and without it.

    python benchmarks/refine_time.py [N] [SEED]

N starts of the open-space sweep's usual region (as ``hitchpark sweep --n N --seed SEED``, default 40
and 7), planned to the goal in an empty scene, then the five obstacle scenes from their ``[start]``
(the planner's clearance 0.3 m, as the planned process asks): the extra planning time of the refined
plan over the searched one, and whether its end was refined. A measurement, not a test.
"""

from __future__ import annotations

import sys
from dataclasses import replace

import numpy as np

from hitchpark.app.sweep import DEFAULT_REGION, draw_starts
from hitchpark.control.planner import PlannerSettings, plan
from hitchpark.maneuver.scenario import OBSTACLE_SUITE, builtin_scenario
from hitchpark.model import Pose, VehicleTrailer
from hitchpark.model.scene import Scene

CLEARANCE_M = 0.3  # success.min_clearance_m + process.plan_margin_m


def _extra(vehicle, start, goal, scene, settings: PlannerSettings) -> tuple[float, str]:
    searched = plan(vehicle, start, goal, scene, replace(settings, refine_m=0.0))
    refined = plan(vehicle, start, goal, scene, settings)
    return refined.planning_s - searched.planning_s, refined.detail


def main() -> None:
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 40
    seed = int(sys.argv[2]) if len(sys.argv) > 2 else 7
    settings = PlannerSettings(min_clearance_m=CLEARANCE_M)
    vehicle = VehicleTrailer()
    extra, refined = [], 0
    for start in draw_starts(seed, n, DEFAULT_REGION):
        dt, detail = _extra(vehicle, start.state(), Pose(), Scene(), settings)
        extra.append(dt)
        refined += detail.endswith("its end refined to end at the goal")
    print(
        f"open space, {n} starts (seed {seed}): {refined} refined; extra planning time "
        f"median {np.median(extra) * 1e3:.0f} ms, max {np.max(extra) * 1e3:.0f} ms"
    )
    for name in OBSTACLE_SUITE:
        sc = builtin_scenario(name)
        dt, detail = _extra(
            sc.vehicle, sc.start, sc.goal, sc.scene, replace(sc.settings.planner, min_clearance_m=CLEARANCE_M)
        )
        print(f"{name:14s} extra {dt:.3f} s: {detail}")


if __name__ == "__main__":
    main()
