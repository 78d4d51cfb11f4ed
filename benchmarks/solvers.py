"""Compare NMPC solvers and transcriptions on the four scenarios: same answers, how fast.

    python benchmarks/solvers.py

Prints, per configuration, whether all four scenarios park, the stage-3 errors, the
NMPC solve time per step (mean, 95th percentile, max) and the wall time of the four
maneuvers, and the speed of each configuration as a ratio to the default measured in
the same run (machines are noisy; ratios travel better than seconds).
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from hitchpark.control import NMPCSettings
from hitchpark.maneuver import builtin_scenarios, park

CONFIGS = {
    "fatrop_c + ipopt fallback, multiple shooting (default)": {},
    "sqp + ipopt fallback, multiple shooting": {"solver": "sqp"},
    "ipopt, multiple shooting": {"solver": "ipopt", "fallback_solver": None},
    "sqp + ipopt fallback, single shooting": {"solver": "sqp", "transcription": "single_shooting"},
    "ipopt, single shooting": {"solver": "ipopt", "fallback_solver": None, "transcription": "single_shooting"},
}


def main() -> None:
    scenarios = builtin_scenarios()
    rows = []
    for label, changes in CONFIGS.items():
        solve, worst_dist, worst_orient, ok = [], 0.0, 0.0, True
        t0 = time.perf_counter()
        for sc in scenarios:
            settings = replace(sc.settings, nmpc=replace(sc.settings.nmpc, **changes))
            r = park(sc.vehicle, sc.start, sc.goal, settings, name=sc.name)
            ok &= r.success
            ms = r.trajectory["solve_ms"]
            solve.append(ms[np.isfinite(ms)])
            last = [s for s in r.stages if s.kind == "reverse"][-1]
            worst_dist = max(worst_dist, last.distance_error_m)
            worst_orient = max(worst_orient, abs(last.orientation_error_deg))
        wall = time.perf_counter() - t0
        s = np.concatenate(solve)
        rows.append((label, ok, worst_dist, worst_orient, s.mean(), np.percentile(s, 95), s.max(), wall))
    base = rows[0][-1]
    print(
        f"{'configuration':<52}{'parked':>7}{'s3 dist mm':>11}{'s3 deg':>8}{'mean ms':>9}{'p95 ms':>8}"
        f"{'max ms':>8}{'wall s':>8}{'x default':>10}"
    )
    for label, ok, d, o, mean, p95, mx, wall in rows:
        print(
            f"{label:<52}{'4/4' if ok else 'NO':>7}{1e3 * d:>11.3f}{o:>8.4f}{mean:>9.2f}{p95:>8.2f}{mx:>8.1f}"
            f"{wall:>8.2f}{wall / base:>10.2f}"
        )
    print(f"\nNMPC settings: {NMPCSettings()}")


if __name__ == "__main__":
    main()
