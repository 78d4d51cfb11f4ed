"""What the opening's reverse-only search buys, and what it costs, at several node budgets.

    python benchmarks/opening_budget.py [N] [SEED] [--budgets B,B,...]

Plans the first N starts (default 1000) of ``hitchpark sweep --n 1000 --seed SEED`` (default 7) with the
sweep's planner settings, once per budget of the opening's search of reverse primitives
(``OPENING_REVERSE_NODES``, default 150; budgets default 150,60,40), over a process pool of one worker
per CPU. Per budget: how many of these searches ran, how many found a single reverse run and after how
many expanded nodes, the seconds they spent in all, the planning time (summed and median), the median
and p90 path length, the plans without a change of direction, and every plan that differs from the
first budget's (its length and changes of direction). A measurement, not a test.
"""

from __future__ import annotations

import itertools
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from typing import Any

import numpy as np

import hitchpark.planning.opening as opening
import hitchpark.planning.search as search
from hitchpark.app.starts import draw_starts
from hitchpark.app.sweep import build_config
from hitchpark.planning import plan

#: (start index, status, nodes expanded, seconds) of each reverse-only search of this worker's plans.
_SEARCHES: list[tuple[int, str, int, float]] = []
_CURRENT = [-1]


def _counted_astar(original: Any) -> Any:
    def astar(self: Any, nodes: Any, h_start: float, reverse_only: bool, budget: int) -> tuple[str, int]:
        before, t0 = self.expanded, time.perf_counter()
        result = original(self, nodes, h_start, reverse_only, budget)
        if reverse_only:
            _SEARCHES.append((_CURRENT[0], result[0], self.expanded - before, time.perf_counter() - t0))
        return result

    astar.counted = True  # type: ignore[attr-defined]
    return astar


def _plan_chunk(job: tuple[int, int, int, int]) -> tuple[list[tuple[int, str, float, int, float]], list[Any]]:
    budget, seed, first, last = job
    opening.OPENING_REVERSE_NODES = budget
    if not hasattr(search._Search._astar, "counted"):  # once per worker, whichever way it was started
        search._Search._astar = _counted_astar(search._Search._astar)
    config = build_config(n=1000, seed=seed)
    starts = draw_starts(seed, 1000, config.region)
    _SEARCHES.clear()
    plans = []
    for i in range(first, last):
        _CURRENT[0] = i
        p = plan(config.vehicle, starts[i].state(), config.goal, config.scene, config.settings.planner)
        plans.append((i, p.status, p.length_m, p.direction_switches, p.planning_s))
    return plans, list(_SEARCHES)


def main() -> None:
    args = sys.argv[1:]
    budgets = [150, 60, 40]
    if "--budgets" in args:
        at = args.index("--budgets")
        budgets = [int(b) for b in args[at + 1].split(",")]
        del args[at : at + 2]
    n = int(args[0]) if args else 1000
    seed = int(args[1]) if len(args) > 1 else 7
    workers = os.cpu_count() or 1
    bounds = np.linspace(0, n, 4 * workers + 1).astype(int)
    reference: list[tuple[int, str, float, int, float]] | None = None
    with ProcessPoolExecutor(workers) as pool:
        for budget in budgets:
            jobs = [(budget, seed, int(a), int(b)) for a, b in itertools.pairwise(bounds) if b > a]
            plans, searches = [], []
            for p, s in pool.map(_plan_chunk, jobs):
                plans += p
                searches += s
            found = sorted(s[2] for s in searches if s[1] == "found")
            lengths = np.array([p[2] for p in plans if p[1] == "found"])
            planning = np.array([p[4] for p in plans])
            print(
                f"budget {budget}: {len(searches)} reverse searches ({sum(s[3] for s in searches):.1f} s),"
                f" {len(found)} found a run, after {found} nodes"
            )
            print(
                f"  {len(lengths)}/{len(plans)} planned; planning {planning.sum():.1f} s summed,"
                f" median {np.median(planning):.3f} s; path median {np.median(lengths):.2f} m,"
                f" p90 {np.percentile(lengths, 90):.2f} m; {sum(p[3] == 0 for p in plans)} without a switch"
            )
            if reference is None:
                reference = plans
                continue
            for old, new in zip(reference, plans, strict=True):
                if old[1] != new[1] or old[3] != new[3] or abs(old[2] - new[2]) > 1e-9:
                    turns = f"{old[3]} changes of direction -> {new[2]:.2f} m, {new[3]}"
                    print(f"  start {old[0]}: {old[2]:.2f} m, {turns}")


if __name__ == "__main__":
    main()
