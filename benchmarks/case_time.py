"""Where the time of one open-space case goes: the NMPC's solves, the planner, and the rest of the loop.

    python benchmarks/case_time.py [N] [SEED]

Parks the first N starts (default 40) of ``hitchpark sweep --n 1000 --seed SEED`` (default 7) one after
the other in this process, with the sweep's controller (warmed up on another start first), and prints per
case: the wall-clock time, the time of the NMPC's solve calls (``solve_ms`` of each row: the whole call,
warm start and parameters included), the planning time, and the rest (sensing, the reference window, the
plant's step, the record), per case and per control step. Run it twice around a change, interleaved: this
machine's speed drifts by 10-20% over minutes. A measurement, not a test.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from hitchpark.app.sweep import build_config, controller_for, draw_starts
from hitchpark.maneuver.process import park


def main() -> None:
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 40
    seed = int(sys.argv[2]) if len(sys.argv) > 2 else 7
    config = build_config(n=1000, seed=seed)
    starts = draw_starts(seed, 1000, config.region)
    controller = controller_for(config)

    def case(i: int):
        return park(
            config.vehicle,
            starts[i].state(),
            config.goal,
            config.settings,
            controller=controller,
            plant=config.plant,
            scene=config.scene,
        )

    case(999)  # libraries loaded, caches filled
    wall = solve = planning = 0.0
    steps = solves = parked = 0
    for i in range(n):
        t0 = time.perf_counter()
        result = case(i)
        wall += time.perf_counter() - t0
        ms = np.asarray(result.trajectory.columns["solve_ms"], dtype=float)
        solve += float(np.nansum(ms)) / 1e3
        solves += int(np.sum(np.isfinite(ms)))
        steps += len(ms)
        planning += result.planning_s
        parked += result.outcome.value == "parked"
    rest = wall - solve - planning
    print(f"{n} cases (seed {seed}), {parked} parked; per case: {steps / n:.0f} control steps, {solves / n:.0f} solves")
    print(
        f"per case [ms]: wall {1e3 * wall / n:.1f} = solves {1e3 * solve / n:.1f} + planning {1e3 * planning / n:.1f}"
        f" + rest {1e3 * rest / n:.1f}"
    )
    print(f"per control step [us]: solve {1e6 * solve / max(solves, 1):.0f}, rest {1e6 * rest / max(steps, 1):.0f}")


if __name__ == "__main__":
    main()
