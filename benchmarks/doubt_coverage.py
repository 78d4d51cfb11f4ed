"""How often the true hitch fell outside the estimator's doubt, over the maneuvers a sweep kept.

    hitchpark sweep ... --settings benchmarks/settings/hitch_sensor.toml --length-tolerance 0.1 \\
        --keep-maneuvers DIR --out FILE.jsonl
    python benchmarks/doubt_coverage.py DIR

Reads each ``DIR/case_NNNN/maneuver.json`` and compares, row by row, the hitch the controllers saw
(``hitch_measured``) with the true one (``hitch``) and with ``hitch_doubt``, the estimator's bound of their gap,
which the guard allows for (:mod:`hitchpark.control.estimator`). Prints each case's largest error and doubt and the
rows the doubt did not cover, then the totals; exit status 1 if no maneuver was found, 2 on bad use.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np

from hitchpark.maneuver.result import ManeuverResult


def main(argv: list[str]) -> int:
    if len(argv) != 1 or not Path(argv[0]).is_dir():
        print("usage: python benchmarks/doubt_coverage.py DIR (a sweep's --keep-maneuvers folder)", file=sys.stderr)
        return 2
    files = sorted(Path(argv[0]).glob("case_*/maneuver.json"))
    if not files:
        print(f"no case_*/maneuver.json under {argv[0]}", file=sys.stderr)
        return 1
    rows = missed = 0
    worst = 0.0  # the largest error as a fraction of its doubt
    largest = 0.0
    for path in files:
        tr = ManeuverResult.from_dict(json.loads(path.read_text(encoding="utf-8"))).trajectory
        error, doubt = np.abs(tr["hitch_measured"] - tr["hitch"]), tr["hitch_doubt"]
        out = int(np.sum(error > doubt))
        rows, missed = rows + len(error), missed + out
        largest = max(largest, float(error.max()))
        ratio = error / np.maximum(doubt, 1e-12)
        worst = max(worst, float(ratio.max()))
        print(
            f"{path.parent.name}: {len(error)} rows, largest error {math.degrees(error.max()):.2f} deg, "
            f"doubt median {math.degrees(np.median(doubt)):.2f} / max {math.degrees(doubt.max()):.2f} deg, "
            f"{out} rows outside it"
        )
    print(
        f"{len(files)} maneuvers, {rows} rows: the doubt covered {rows - missed} ({100.0 * (rows - missed) / rows:.2f}%); "
        f"largest error {math.degrees(largest):.2f} deg; largest error over its doubt {worst:.2f}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
