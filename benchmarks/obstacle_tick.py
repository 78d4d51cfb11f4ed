"""Where an obstacle scene's control step goes, with the compiled separating lines and with NumPy's.

    python benchmarks/obstacle_tick.py [SCENE ...]

Parks each built-in scene of obstacles (default: all five) once to warm up, then once with the compiled
lines (``ocp/separating_lines.c``) and once with :func:`~hitchpark.ocp.separating.separating_lines_numpy`
alone, in this process, and prints per run the median and largest time a call of: ``separating_lines``,
the lines of a step (``ClearanceConstraints.parameters``), the NMPC's step (``FullNMPC.act``) and the
guard's check (``Guard.check``); then whether the two maneuvers are the same to the last bit (every column of
the trajectory but the solver's own timing). Without a C compiler (or with ``HITCHPARK_JIT=0``) both runs
are NumPy's. A measurement, not a test; this machine's speed drifts, so compare within one run.
"""

from __future__ import annotations

import functools
import sys
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from hitchpark.control.guard import Guard
from hitchpark.control.nmpc import FullNMPC
from hitchpark.maneuver import ManeuverResult, park
from hitchpark.maneuver.scenario import OBSTACLE_SUITE, builtin_scenario
from hitchpark.ocp import obstacles, separating

#: (owner, attribute, label) of the timed parts.
PARTS = (
    (obstacles, "separating_lines", "separating_lines"),
    (obstacles.ClearanceConstraints, "parameters", "lines of a step"),
    (FullNMPC, "act", "NMPC step"),
    (Guard, "check", "guard check"),
)


def timed(function: Callable[..., Any], into: list[float]) -> Callable[..., Any]:
    @functools.wraps(function)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        began = time.perf_counter()
        try:
            return function(*args, **kwargs)
        finally:
            into.append(time.perf_counter() - began)

    return wrapper


def run(name: str, compiled: bool) -> tuple[ManeuverResult, dict[str, list[float]]]:
    scenario = builtin_scenario(name)
    times: dict[str, list[float]] = {label: [] for _, _, label in PARTS}
    originals = [(owner, attribute, getattr(owner, attribute)) for owner, attribute, _ in PARTS]
    kernel = separating._kernel
    try:
        for (owner, attribute, label), (_, _, original) in zip(PARTS, originals, strict=True):
            setattr(owner, attribute, timed(original, times[label]))
        if not compiled:
            separating._kernel = lambda *_: None  # type: ignore[assignment]
        result = park(
            scenario.vehicle,
            scenario.start,
            scenario.goal,
            scenario.settings,
            name=scenario.name,
            plant=scenario.plant,
            scene=scenario.scene,
        )
    finally:
        separating._kernel = kernel  # type: ignore[assignment]
        for owner, attribute, original in originals:
            setattr(owner, attribute, original)
    return result, times


def same(a: ManeuverResult, b: ManeuverResult) -> bool:
    columns = [c for c in a.trajectory.columns if c != "solve_ms"]
    return all(
        np.array_equal(np.asarray(a.trajectory[c]), np.asarray(b.trajectory[c]), equal_nan=True)
        if np.shape(a.trajectory[c]) == np.shape(b.trajectory[c])
        else False
        for c in columns
    )


def main(names: list[str]) -> int:
    unknown = sorted(set(names) - set(OBSTACLE_SUITE))
    if unknown:
        print(f"unknown scene {unknown[0]!r}; the scenes are {', '.join(OBSTACLE_SUITE)}", file=sys.stderr)
        return 2
    print(f"compiled lines available: {separating.prepare_lines()}")
    for name in names or OBSTACLE_SUITE:
        run(name, True)  # warm-up: everything compiled or loaded
        results = {}
        for compiled in (True, False):
            result, times = run(name, compiled)
            results[compiled] = result
            parts = ", ".join(
                f"{label} {1e3 * np.median(t):.3f} / {1e3 * np.max(t):.3f}" for label, t in times.items() if t
            )
            print(f"{name:14s} {'compiled' if compiled else 'numpy   '} {result.reason}: {parts} ms (median / max)")
        print(f"{name:14s} the same maneuver to the last bit: {same(results[True], results[False])}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
