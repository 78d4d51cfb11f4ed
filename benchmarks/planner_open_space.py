"""How the planner does in open space over the sweep's usual region, and once in the driveway scene.

    python benchmarks/planner_open_space.py N SEED [--time-limit S] [--set FIELD=VALUE ...] [--no-driveway]

Draws N starts as ``hitchpark sweep --n N --seed SEED`` does (``numpy.random.default_rng(SEED)``,
uniform over x 4..16 m, y -8..8 m, yaw -90..90 deg, hitch -30..30 deg; trailer-axle pose, goal at the
origin heading 0), plans each in an empty scene and prints the counts of found / no_path / timeout,
the planning time (median, 90th percentile, max, over all N), the changes of direction of the paths
found (and the share with none) and their median trailer-axle length. Then plans the shipped
``driveway`` scenario once and prints its result. ``--set`` overrides :class:`PlannerSettings`
fields (degrees are not converted: radians). A measurement, not a test.
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections import Counter
from pathlib import Path

import numpy as np

from hitchpark.app.starts import DEFAULT_REGION, draw_starts
from hitchpark.maneuver.scenario import load_scenario
from hitchpark.model import Pose, VehicleTrailer
from hitchpark.model.scene import Scene
from hitchpark.model.state import State
from hitchpark.planning import PlannerSettings, plan

DRIVEWAY = Path(__file__).resolve().parents[1] / "src" / "hitchpark" / "maneuver" / "scenarios" / "driveway.toml"


def percentile(values: list[float], q: float) -> float:
    return float(np.percentile(values, q)) if values else float("nan")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("n", type=int)
    parser.add_argument("seed", type=int)
    parser.add_argument("--time-limit", type=float, default=None, help="planner time limit [s]")
    parser.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE")
    parser.add_argument("--no-driveway", action="store_true")
    parser.add_argument("--verbose", action="store_true", help="one line per case")
    args = parser.parse_args()
    overrides: dict[str, float | int] = {}
    for item in args.set:
        key, value = item.split("=", 1)
        overrides[key] = int(value) if value.lstrip("-").isdigit() else float(value)
    if args.time_limit is not None:
        overrides["time_limit_s"] = args.time_limit
    settings = PlannerSettings(**overrides)  # type: ignore[arg-type]
    vehicle = VehicleTrailer()
    starts = draw_starts(args.seed, args.n, DEFAULT_REGION)
    statuses: Counter[str] = Counter()
    times, switches, lengths, expanded = [], [], [], []
    began = time.perf_counter()
    for i, s in enumerate(starts):
        start = State(s.x, s.y, np.radians(s.yaw_deg), np.radians(s.hitch_deg))
        result = plan(vehicle, start, Pose(), Scene(), settings)
        statuses[result.status] += 1
        times.append(result.planning_s)
        expanded.append(result.expanded)
        if result.found:
            switches.append(result.direction_switches)
            lengths.append(result.length_m)
        if args.verbose:
            print(
                f"{i:4d} x={s.x:6.2f} y={s.y:6.2f} yaw={s.yaw_deg:7.1f} hitch={s.hitch_deg:6.1f}  {result.status:8s} "
                f"{result.planning_s:6.2f} s  {result.expanded:6d} nodes  {result.direction_switches} switches  "
                f"{result.length_m:5.1f} m",
                flush=True,
            )
    wall = time.perf_counter() - began
    print(f"settings: {overrides or 'defaults'}")
    print(f"{args.n} starts, seed {args.seed}, region {DEFAULT_REGION.to_dict()}, {wall:.1f} s in all")
    print("status: " + ", ".join(f"{k} {statuses.get(k, 0)}" for k in ("found", "no_path", "timeout")))
    print(
        f"planning time [s]: median {statistics.median(times):.3f}, p90 {percentile(times, 90):.3f}, "
        f"max {max(times):.3f}; nodes expanded: median {statistics.median(expanded):.0f}"
    )
    if switches:
        share = sum(1 for k in switches if k == 0) / args.n
        by = Counter(switches)
        print(f"direction switches (found): {dict(sorted(by.items()))}; share of all starts with none: {share:.0%}")
        print(f"trailer-axle path length [m] (found): median {statistics.median(lengths):.1f}, "
              f"p90 {percentile(lengths, 90):.1f}")  # fmt: skip
    if not args.no_driveway:
        scenario = load_scenario(DRIVEWAY)
        result = plan(scenario.vehicle, scenario.start, scenario.goal, scenario.scene, settings)
        print(
            f"driveway: {result.status} in {result.planning_s:.2f} s, {result.expanded} nodes, "
            f"{result.direction_switches} switches, {result.length_m:.1f} m ({result.detail})"
        )


if __name__ == "__main__":
    main()
