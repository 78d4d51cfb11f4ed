"""The tables of the documentation's speed page, from a ``hitchpark bench --json`` file and sweep summaries.

    python benchmarks/performance_page.py BENCH.json [SUMMARY.json ...] > docs/_generated/speed-tables.md

Each summary is a ``hitchpark sweep --json`` file; its row is named after the sweep's scenario (or "open
space"). Nothing here measures: the numbers are the files', written out as Markdown tables.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any


def _num(value: Any, fmt: str) -> str:
    return "-" if value is None else format(value, fmt)


def route_tables(bench: dict[str, Any]) -> list[str]:
    lines = []
    for ocp, data in bench["ocps"].items():
        lines += [
            f"**{ocp}** OCP: {data['problems']} recorded problems from {data['starts']} closed-loop starts; "
            f"the default route is `{data['default']}`.",
            "",
            "| route | median [ms] | p99 [ms] | max [ms] | CPU median [ms] | iterations median | failures | x IPOPT |",
            "|---|---|---|---|---|---|---|---|",
        ]
        routes = sorted(data["routes"].items(), key=lambda kv: kv[1]["median_ms"])
        for name, r in routes:
            cut = f" (the first {r['calls']} problems: its time ran out)" if r["calls"] < data["problems"] else ""
            times = f"{r['median_ms']:.3f} | {r['p99_ms']:.3f} | {r['max_ms']:.3f} | {r['cpu_median_ms']:.3f}"
            counts = f"{_num(r['iterations_median'], '.0f')} | {r['failures']}/{r['calls']}"
            lines.append(f"| `{name}`{cut} | {times} | {counts} | {r['speedup_vs_ipopt']:.1f} |")
        scaling = data.get("horizon_scaling_ms") or {}
        if scaling:
            cells = "; ".join(f"N = {n}: {ms:.3f} ms" for n, ms in scaling.items())
            lines += ["", f"`{data['default']}` by horizon (median per call): {cells}."]
        lines.append("")
    return lines


def sweep_table(summaries: list[tuple[str, dict[str, Any]]]) -> list[str]:
    if not summaries:
        return []
    lines = [
        "| sweep | parked | collisions | least clearance [m] | planning median / p90 [s] | path median [m] |",
        "|---|---|---|---|---|---|",
    ]
    for name, s in summaries:
        planning, path = s.get("planning_s") or {}, s.get("path_length_m") or {}
        lines.append(
            f"| {name} | {s['parked']}/{s['n']} | {s.get('collisions', 0)} | {_num(s.get('min_clearance_m'), '.3f')} "
            f"| {_num(planning.get('median'), '.2f')} / {_num(planning.get('p90'), '.2f')} "
            f"| {_num(path.get('median'), '.1f')} |"
        )
    return [*lines, ""]


def main(argv: list[str]) -> int:
    if not argv:
        print(__doc__, file=sys.stderr)
        return 2
    bench = json.loads(Path(argv[0]).read_text())
    summaries = []
    for path in argv[1:]:
        data = json.loads(Path(path).read_text())
        summary = data.get("summary", data)
        name = (data.get("sweep") or {}).get("scenario") or data.get("scenario") or "open space"
        summaries.append((name, summary))
    print("\n".join(route_tables(bench) + sweep_table(summaries)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
