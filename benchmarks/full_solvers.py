"""Solver routes for the full-model NMPC, side by side in one run: solve time and closed-loop result.

    python benchmarks/full_solvers.py [N_STARTS]

Parks from N_STARTS (default 3) seeded random starts of the default region on the default
(realistic) plant with each solver, the IPOPT fallback switched off so a failure counts.
"""

from __future__ import annotations

import math
import sys
from dataclasses import replace

import numpy as np

from hitchpark import State, VehicleTrailer
from hitchpark.control import NMPCSettings, make_nmpc
from hitchpark.maneuver import ManeuverSettings, park


def main(n: int = 3) -> None:
    vehicle = VehicleTrailer()
    rng = np.random.default_rng(2026)
    starts = [
        State(
            rng.uniform(4, 16),
            rng.uniform(-8, 8),
            math.radians(rng.uniform(-90, 90)),
            math.radians(rng.uniform(-30, 30)),
        )
        for _ in range(n)
    ]
    print(f"{'solver':<8} {'parked':>7} {'median ms':>10} {'p99 ms':>8} {'max ms':>8}")
    for solver in ("fatrop_c", "fatrop", "ipopt"):
        settings = ManeuverSettings(nmpc=replace(NMPCSettings(), solver=solver, fallback_solver=None))
        controller = make_nmpc(vehicle, settings.nmpc)
        times, parked = [], 0
        for start in starts:
            result = park(vehicle, start, settings=settings, controller=controller)
            parked += result.success
            ms = result.trajectory["solve_ms"]
            times += list(ms[np.isfinite(ms)])
        t = np.array(times)
        print(f"{solver:<8} {parked:>4}/{n:<2} {np.median(t):>10.2f} {np.percentile(t, 99):>8.2f} {t.max():>8.2f}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 3)
