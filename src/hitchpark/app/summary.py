"""The summary of a sweep: the numbers over all its cases (:func:`summarize`) and their text
(:func:`format_summary`), from the records of :mod:`.records`."""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

from .records import CaseRecord

__all__ = ["format_summary", "summarize"]


def _values(records: Iterable[CaseRecord], name: str) -> np.ndarray:
    return np.array([v for r in records if (v := getattr(r, name)) is not None], dtype=float)


def _median_p90(values: np.ndarray) -> dict[str, float | None]:
    if not values.size:
        return {"median": None, "p90": None}
    return {"median": float(np.median(values)), "p90": float(np.percentile(values, 90))}


def summarize(records: Sequence[CaseRecord]) -> dict[str, Any]:
    """The numbers over all ``records``.

    ``n``, ``parked`` (how many succeeded), ``success_rate``, ``by_reason`` (count per reason,
    ``"parked"`` first and always present, then the most frequent), the median and 90th percentile
    (linear interpolation) of ``path_length_m``, ``maneuver_time_s`` and ``planning_s``, ``wall_s`` summed over
    the cases, and the largest ``max_abs_steer_deg``, ``max_abs_steer_rate_deg_s`` and ``max_abs_hitch_deg``;
    ``collisions`` (cases where a body touched the scene or left the area), ``min_clearance_m`` (the least over
    the cases; None in open space), ``direction_switches`` (its median and p90) and ``no_switch`` (cases parked
    without a change of direction). Null values are left out of each statistic.
    """
    n = len(records)
    parked = sum(r.success for r in records)
    counts = Counter(r.reason for r in records)
    by_reason = {"parked": counts.pop("parked", 0)}
    by_reason.update(sorted(counts.items(), key=lambda kv: (-kv[1], kv[0])))
    summary: dict[str, Any] = {
        "n": n,
        "parked": parked,
        "success_rate": parked / n if n else None,
        "by_reason": by_reason,
        "path_length_m": _median_p90(_values(records, "path_length_m")),
        "maneuver_time_s": _median_p90(_values(records, "maneuver_time_s")),
        "wall_s": float(np.sum(_values(records, "wall_s"))),
        "collisions": sum(r.collision for r in records),
        "planning_s": _median_p90(_values(records, "planning_s")),
        "direction_switches": _median_p90(_values(records, "direction_switches")),
        "no_switch": sum(r.success and r.direction_switches == 0 for r in records),
    }
    clearances = _values(records, "min_clearance_m")
    summary["min_clearance_m"] = float(np.min(clearances)) if clearances.size else None
    for name in ("max_abs_steer_deg", "max_abs_steer_rate_deg_s", "max_abs_hitch_deg"):
        values = _values(records, name)
        summary[name] = float(np.max(values)) if values.size else None
    return summary


def _num(value: float | None, fmt: str) -> str:
    return "-" if value is None else format(value, fmt)


def format_summary(summary: Mapping[str, Any]) -> str:
    """The summary in a few lines of text."""
    n, rate = summary["n"], summary["success_rate"]
    failed = [f"{reason} {count}" for reason, count in summary["by_reason"].items() if reason != "parked" and count]
    path, time = summary["path_length_m"], summary["maneuver_time_s"]
    planning, switches = summary["planning_s"], summary["direction_switches"]
    return "\n".join(
        [
            f"parked {summary['parked']}/{n} ({_num(None if rate is None else 100 * rate, '.1f')}%)"
            + (f"; not parked: {', '.join(failed)}" if failed else ""),
            f"trailer path length [m]: median {_num(path['median'], '.2f')}, p90 {_num(path['p90'], '.2f')}; "
            f"maneuver time [s]: median {_num(time['median'], '.1f')}, p90 {_num(time['p90'], '.1f')}",
            f"max |front steer| {_num(summary['max_abs_steer_deg'], '.2f')} deg, "
            f"max |steer rate| {_num(summary['max_abs_steer_rate_deg_s'], '.1f')} deg/s, "
            f"max |hitch| {_num(summary['max_abs_hitch_deg'], '.2f')} deg",
            f"collisions {summary['collisions']}"
            + (f" (starts skipped as they collide: {summary['skipped']})" if "skipped" in summary else "")
            + f"; least clearance {_num(summary['min_clearance_m'], '.3f')} m; "
            f"parked without a change of direction {summary['no_switch']}/{n}; "
            f"direction switches: median {_num(switches['median'], '.0f')}, p90 {_num(switches['p90'], '.1f')}",
            f"planning time [s]: median {_num(planning['median'], '.2f')}, p90 {_num(planning['p90'], '.2f')}"
            + (
                f" (the scene's goal tree and rollouts, before the cases: {summary['prepare_s']:.2f} s)"
                if summary.get("prepare_s") is not None
                else ""
            ),
            f"wall clock summed over the cases: {summary['wall_s']:.1f} s",
        ]
    )
