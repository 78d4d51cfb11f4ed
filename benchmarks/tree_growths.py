"""Which places' goal trees are grown again from a shifted trunk (a tree that never leaves the goal line).

    python benchmarks/tree_growths.py [--tolerance F ...]

For each place of the obstacle and places suites and each scene of ``benchmarks/scenes``, and each length
tolerance (default 0 and 0.1, the fault plant's), grows the goal tree the planned process plans with (nothing
read from the cache) and prints how many times it was grown, its nodes and how far its farthest node is off the
goal line. A tree grown once is the tree the code before the trunk grew: the same plans, the same records.
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path

import numpy as np

from hitchpark.maneuver.planned import planner_settings
from hitchpark.maneuver.scenario import OBSTACLE_SUITE, PLACES_SUITE, builtin_scenario, load_scenario
from hitchpark.model.state import goal_frame_position
from hitchpark.planning import tree
from hitchpark.planning.prepare import scene_bounds, tree_settings

SCENES = Path(__file__).parent / "scenes"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tolerance", type=float, nargs="+", default=[0.0, 0.1])
    args = parser.parse_args()
    trunks: list[float] = []
    grow = tree.GoalTree._grow

    def counted(*args, **kwargs):  # type: ignore[no-untyped-def]
        trunks.append(kwargs.get("trunk", args[5] if len(args) > 5 else 0.0))
        return grow(*args, **kwargs)

    tree.GoalTree._grow = staticmethod(counted)  # type: ignore[method-assign]
    places = [builtin_scenario(name) for name in dict.fromkeys((*OBSTACLE_SUITE, *PLACES_SUITE))]
    places += [load_scenario(path) for path in sorted(SCENES.glob("*.toml"))]
    print(f"{'place':20s} {'tolerance':>9s} {'growths':>7s} {'nodes':>6s} {'off the line [m]':>16s}")
    for tolerance in args.tolerance:
        for sc in places:
            vehicle = replace(sc.vehicle, length_tolerance=tolerance)
            settings = tree_settings(planner_settings(sc.settings))
            trunks.clear()
            bounds = scene_bounds(vehicle, sc.goal, sc.scene, settings)
            grown = tree.GoalTree(vehicle, sc.goal, sc.scene, settings, bounds)
            _, across = goal_frame_position(sc.goal, grown.states[:, 0], grown.states[:, 1])
            print(f"{sc.name:20s} {tolerance:9g} {len(trunks):7d} {len(grown.states):6d} {np.abs(across).max():16.2f}")


if __name__ == "__main__":
    main()
