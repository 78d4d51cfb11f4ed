"""How often the 3-stage process parks from anywhere around the goal: a robustness measurement.

    python benchmarks/wide_starts.py [N]

Parks from N (default 150) starts drawn with a fixed seed around the goal at the origin:
x, y ~ U(-15, 15) m, yaw ~ U(-180, 180) deg, hitch ~ U(-60, 60) deg, with the default
vehicle and settings, and prints how many park, why the others stop, the stages used,
and the largest steer and hitch angle seen (never beyond 42.97 deg and 70 deg).
"""

from __future__ import annotations

import collections
import math
import sys
import time

import numpy as np

from hitchpark.control import TrailerNMPC
from hitchpark.maneuver import park
from hitchpark.model import VehicleTrailer
from hitchpark.model.simulate import State


def main(n: int = 150) -> None:
    vehicle = VehicleTrailer()
    controller = TrailerNMPC(vehicle)
    rng = np.random.default_rng(1)
    reasons: collections.Counter[str] = collections.Counter()
    stages, durations, steer, hitch = [], [], 0.0, 0.0
    t0 = time.perf_counter()
    for _ in range(n):
        x, y = rng.uniform(-15, 15, size=2)
        yaw, hitch0 = math.radians(rng.uniform(-180, 180)), math.radians(rng.uniform(-60, 60))
        result = park(vehicle, State(x, y, yaw, hitch0), controller=controller)
        reasons[result.reason] += 1
        stages.append(len(result.stages))
        durations.append(result.duration)
        steer = max(steer, result.max_abs_front_steer_deg)
        hitch = max(hitch, result.max_abs_hitch_deg)
    wall = time.perf_counter() - t0
    print(f"{n} starts: {reasons['parked']} parked; outcomes {dict(reasons)}")
    print(
        f"stages: mean {np.mean(stages):.2f}, max {max(stages)}; maneuver time: mean {np.mean(durations):.1f} s, "
        f"max {max(durations):.1f} s"
    )
    print(
        f"max |front steer| {steer:.2f} deg (limit {math.degrees(vehicle.max_steer):.2f}), "
        f"max |hitch| {hitch:.2f} deg (limit {math.degrees(vehicle.max_hitch):.0f})"
    )
    print(f"wall time {wall:.1f} s ({wall / n:.2f} s per maneuver)")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 150)
