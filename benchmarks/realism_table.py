"""The README's table of the realism sweeps, from their summary files, with the limits checked.

    python benchmarks/realism_table.py LABEL=SUMMARY.json [LABEL=SUMMARY.json ...]

Each SUMMARY.json is what ``hitchpark sweep --json`` wrote. Prints a Markdown table: parked, the
failure reasons, the largest actual steer, steer rate and hitch over every case against the
vehicle's limits (Table 4 defaults: 42.97 deg, 34.38 deg/s, 70 deg), medians of path and maneuver
time, and the sweep's wall-clock time. Exits 1 if any sweep passed a limit.
"""

from __future__ import annotations

import json
import math
import sys

from hitchpark.model import VehicleTrailer


def main(args: list[str]) -> int:
    v = VehicleTrailer()
    limits = {
        "max_abs_steer_deg": math.degrees(v.max_steer),
        "max_abs_steer_rate_deg_s": math.degrees(v.max_steer_rate),
        "max_abs_hitch_deg": math.degrees(v.max_hitch),
    }
    print(
        "| plant | parked | failures | max steer [deg] | max steer rate [deg/s] | max hitch [deg] "
        "| median path [m] | median time [s] |"
    )
    print("|---|---|---|---|---|---|---|---|")
    broken = False
    for arg in args:
        label, _, path = arg.partition("=")
        with open(path) as f:
            s = json.load(f)
        failures = ", ".join(f"{k} {v}" for k, v in s["by_reason"].items() if k != "parked") or "none"
        cells = []
        for name, limit in limits.items():
            over = s[name] > limit + 1e-9
            broken |= over
            cells.append(f"{s[name]:.2f}{' OVER' if over else ''}")
        print(
            f"| {label} | {s['parked']}/{s['n']} ({100 * s['success_rate']:.1f}%) | {failures} | "
            + " | ".join(cells)
            + f" | {s['path_length_m']['median']:.1f} | {s['maneuver_time_s']['median']:.1f} |"
        )
    print(
        "\nlimits: "
        + ", ".join(f"{k} {v:.2f}" for k, v in limits.items())
        + (" -- A LIMIT WAS EXCEEDED" if broken else "")
    )
    return 1 if broken else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
