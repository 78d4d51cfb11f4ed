"""Where the time of one open-space case goes: the NMPC's solves, the planner, and the rest of the loop.

    python benchmarks/case_time.py [N] [SEED] [--detail]

Parks the first N starts (default 40) of ``hitchpark sweep --n 1000 --seed SEED`` (default 7) one after
the other in this process, with the sweep's controller (warmed up on another start first), and prints per
case: the wall-clock time, the time of the NMPC's solve calls (``solve_ms`` of each row: the whole call,
warm start and parameters included), the planning time, and the rest (sensing, the reference window, the
plant's step, the record), per case and per control step, and the median, p90 and largest wall of a
case. Run it twice around a change, interleaved: this machine's speed drifts by 10-20% over minutes. A
measurement, not a test.

``--detail`` also times the parts of a control step and of planning (each wrapped in a timer, which adds
about a microsecond a call) and prints, per part, its calls and milliseconds per case and microseconds per
call; the parts nest (the solver's call is within the NMPC's step).
"""

from __future__ import annotations

import functools
import sys
import time
from collections.abc import Callable
from typing import Any

import numpy as np

import hitchpark.model.plant as plant
import hitchpark.ocp.reference as reference
import hitchpark.planning.endgame as endgame
import hitchpark.planning.motion as motion
import hitchpark.planning.rollouts as rollouts
import hitchpark.planning.search as search
import hitchpark.solvers.generated as generated
from hitchpark.app.starts import draw_starts
from hitchpark.app.sweep import build_config, controller_for
from hitchpark.control.nmpc import FullNMPC
from hitchpark.maneuver.process import park

#: (owner, attribute, label) of the parts --detail times.
PARTS = (
    (FullNMPC, "act", "NMPC step (act)"),
    (generated.GeneratedNLP, "__call__", "  solver call (buffers and the compiled solver)"),
    (FullNMPC, "_initial_guess", "  warm start"),
    (reference.PathReference, "window", "  reference window"),
    (FullNMPC, "_step_parameters", "  step parameters"),
    (plant.Plant, "sense", "plant sense"),
    (plant.Plant, "apply", "plant apply"),
    (search, "opening", "planning: opening"),
    (search._Search, "_astar", "  A* (the opening's reverse-only search, or the search)"),
    (endgame.EndGame, "dubins_shots", "  Dubins shots"),
    (rollouts.PathPursuit, "run", "    their pursuit"),
    (endgame.EndGame, "line_shots", "  goal-line shots"),
    (motion.PrimitiveBatch, "run", "  primitives"),
    (search, "refine_plan", "planning: refinement"),
)


def _timed(f: Callable[..., Any], spent: list[float]) -> Callable[..., Any]:
    @functools.wraps(f)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        t0 = time.perf_counter()
        try:
            return f(*args, **kwargs)
        finally:
            spent[0] += time.perf_counter() - t0
            spent[1] += 1

    return wrapper


def main() -> None:
    args = [a for a in sys.argv[1:] if a != "--detail"]
    detail = len(args) < len(sys.argv) - 1
    n = int(args[0]) if args else 40
    seed = int(args[1]) if len(args) > 1 else 7
    spent: dict[str, list[float]] = {}
    if detail:
        for owner, name, label in PARTS:
            spent[label] = [0.0, 0]
            setattr(owner, name, _timed(getattr(owner, name), spent[label]))
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
    for part in spent.values():
        part[:] = [0.0, 0]
    wall = solve = planning = 0.0
    steps = solves = parked = 0
    walls = []
    for i in range(n):
        t0 = time.perf_counter()
        result = case(i)
        walls.append(time.perf_counter() - t0)
        wall += walls[-1]
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
    p50, p90, top = 1e3 * np.percentile(walls, [50, 90, 100])
    print(f"a case's wall [ms]: median {p50:.0f}, p90 {p90:.0f}, max {top:.0f}")
    for label, (seconds, calls) in spent.items():
        print(
            f"{label:<56} {calls / n:7.1f} calls {1e3 * seconds / n:7.1f} ms a case"
            f" {1e6 * seconds / max(calls, 1):9.1f} us a call"
        )


if __name__ == "__main__":
    main()
