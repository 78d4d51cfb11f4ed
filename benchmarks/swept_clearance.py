"""How long the swept clearance check takes on a real maneuver among ten obstacles.

    python benchmarks/swept_clearance.py [--repeat 20]

Parks the shipped ``driveway`` scenario once (full-model NMPC, realistic car, its own scene), takes
the true trajectory, pads it to 600 rows with its own motion run backwards, and adds seven more
obstacles to the scene's three (parked cars, bins, a tree along the street), so the check sees a
600-row maneuver among ten obstacles and an area. Prints the sub-samples checked and the best and
median wall time of :func:`hitchpark.model.collision.swept_clearance` at the default 5 cm step and
at 2 cm. A measurement, not a test.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from hitchpark.maneuver import park
from hitchpark.maneuver.scenario import builtin_scenario
from hitchpark.model.collision import _subsamples, swept_clearance
from hitchpark.model.scene import Area, Obstacle, Scene


def box(x0: float, y0: float, x1: float, y1: float) -> list[list[float]]:
    return [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]


EXTRA = (
    Obstacle("parked car 2", box(15.5, -16.0, 17.3, -11.3)),
    Obstacle("parked car 3", box(15.5, 12.0, 17.3, 16.7)),
    Obstacle("parked car 4", box(10.7, -20.0, 12.5, -15.3)),
    Obstacle("bin", box(10.6, -3.0, 11.2, -2.4)),
    Obstacle("bin 2", box(10.6, 18.0, 11.2, 18.6)),
    Obstacle("tree", [[17.0, 20.0], [17.4, 20.3], [17.4, 20.8], [17.0, 21.1], [16.6, 20.8], [16.6, 20.3]]),
    Obstacle("letterbox", box(9.6, 2.2, 10.0, 2.6)),
)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=20)
    args = parser.parse_args()
    sc = builtin_scenario("driveway")
    result = park(sc.vehicle, sc.start, sc.goal, sc.settings, name=sc.name, plant=sc.plant, scene=sc.scene)
    states = result.trajectory.states()
    states = np.vstack([states, states[::-1][1:]])[:600]
    vehicle = result.plant_vehicle
    print(f"maneuver: {result.reason}, {len(result.trajectory)} rows, padded to {len(states)}")
    scenes = {
        "driveway + 7": Scene(sc.scene.obstacles + EXTRA, sc.scene.area),
        "clear": Scene(sc.scene.obstacles[2:] + EXTRA, Area(box(-5.0, -30.0, 25.0, 30.0))),
    }
    for label, scene in scenes.items():
        for step in (0.05, 0.02):
            n = len(_subsamples(vehicle, states, step)[0])
            times = []
            for _ in range(args.repeat):
                t0 = time.perf_counter()
                least, row = swept_clearance(vehicle, scene, states, max_step_m=step)
                times.append(time.perf_counter() - t0)
            print(
                f"{label} ({len(scene.obstacles)} obstacles, an area), max_step_m {step:g}: {n} sub-samples, "
                f"least clearance {least:.3f} m at row {row}; best {1000 * min(times):.1f} ms, "
                f"median {1000 * statistics.median(times):.1f} ms"
            )


if __name__ == "__main__":
    main()
