"""Whether two sweeps' records are the same case for case, but for the wall-clock fields.

    python benchmarks/compare_records.py A.jsonl B.jsonl

Prints how many records differ (``wall_s`` and ``planning_s`` aside, the only fields that may vary between runs
of the same sweep) and the first few differences; exit status 1 if any differ.
"""

from __future__ import annotations

import json
import sys

#: The fields that measure the machine, not the maneuver.
WALL_CLOCK = ("wall_s", "planning_s")


def load(path: str) -> dict[int, dict]:
    with open(path, encoding="utf-8") as f:
        return {r["case"]: {k: v for k, v in r.items() if k not in WALL_CLOCK} for r in map(json.loads, f)}


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    a, b = load(argv[0]), load(argv[1])
    differ = [k for k in sorted(set(a) | set(b)) if a.get(k) != b.get(k)]
    print(f"{len(a)} and {len(b)} records; {len(differ)} differ (wall_s and planning_s aside)")
    for k in differ[:5]:
        ra, rb = a.get(k) or {}, b.get(k) or {}
        print(f"  case {k}:", {f: (ra.get(f), rb.get(f)) for f in sorted(set(ra) | set(rb)) if ra.get(f) != rb.get(f)})
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
