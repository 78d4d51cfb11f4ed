"""Sweeps of the knob assist: random starts, random knob profiles, and what the assist kept (``sweep --assist``).

Each case is a start of the sweep's :class:`~.sweep.SweepConfig` (drawn from its seed as a parking sweep's, over
its region or scenario) and a knob profile of one family, drawn from
``numpy.random.SeedSequence([seed, family, case])``: the same seed gives the same profiles and records whatever
runs them, on any number of workers. The families (:data:`FAMILIES`), each 60 s of knob and reverse speed
request sampled every 0.1 s and held between samples:

- ``hold``: full lock, on a random side, from the start, at a request of 1 m/s;
- ``slalom``: a sine of random period (6-20 s), amplitude (0.5-1) and phase, at 0.6-1 m/s;
- ``steps``: knob levels in [-1, 1] held for 2-8 s each, requests in 0.3-1 m/s;
- ``noise``: a nervous driver: a random walk of the knob with a jitter on top and flicks to either lock now and
  then, the request dropping to 0 and back.

Parked means nothing here: an :class:`AssistRecord` holds the largest hitch, the commands past a limit (steer,
steer rate, acceleration, non-finite: the assist must keep them all at 0), the time and the number of episodes of
each override, the RMS error of the trailer's curvature where no override acts, collision and least clearance.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..control.assist import OVERRIDES
from ..maneuver.assisted import KnobProfile, drive_assisted
from ..maneuver.result import ManeuverResult
from ..model.kinematics import full_rates
from .executors import Executor, make_executor
from .records import Start
from .sweep import SweepConfig

__all__ = [
    "FAMILIES",
    "AssistRecord",
    "AssistTask",
    "assist_record",
    "format_assist_summary",
    "knob_profile",
    "run_assist_case",
    "run_assist_sweep",
    "summarize_assist",
]

FAMILIES = ("hold", "slalom", "steps", "noise")

#: Length of each profile [s] and its sample [s].
PROFILE_S = 60.0
PROFILE_DT = 0.1

#: Trailer speeds below this [m/s] give no curvature (it is the yaw rate over the speed).
MIN_CURVATURE_SPEED = 0.1


def knob_profile(family: str, seed: int, case: int) -> KnobProfile:
    """The knob profile of ``case`` of ``family`` for the sweep ``seed`` (see the module text)."""
    rng = np.random.default_rng(np.random.SeedSequence([seed, FAMILIES.index(family), case]))
    t = np.arange(0.0, PROFILE_S + PROFILE_DT / 2, PROFILE_DT)
    n = len(t)
    if family == "hold":
        knob, speed = np.full(n, rng.choice([-1.0, 1.0])), np.ones(n)
    elif family == "slalom":
        period, amplitude, phase = rng.uniform(6.0, 20.0), rng.uniform(0.5, 1.0), rng.uniform(0.0, 2 * math.pi)
        knob = amplitude * np.sin(2 * math.pi * t / period + phase)
        speed = np.full(n, rng.uniform(0.6, 1.0))
    elif family == "steps":
        knob, speed, i = np.zeros(n), np.zeros(n), 0
        while i < n:
            j = i + int(rng.uniform(2.0, 8.0) / PROFILE_DT)
            knob[i:j], speed[i:j] = rng.uniform(-1.0, 1.0), rng.uniform(0.3, 1.0)
            i = j
    elif family == "noise":
        walk = np.cumsum(rng.normal(0.0, 0.08, n))
        knob = walk + rng.normal(0.0, 0.15, n)
        flicks = rng.random(n) < 0.02
        knob[flicks] = rng.choice([-1.0, 1.0], int(flicks.sum()))
        speed = np.where(rng.random(n) < 0.1, 0.0, rng.uniform(0.5, 1.0, n))
        speed = np.minimum(speed, np.roll(speed, 1))  # pauses of two samples or more
    else:
        raise ValueError(f"unknown knob profile family {family!r}")
    knob = np.clip(knob, -1.0, 1.0)
    return KnobProfile(t, knob, np.clip(speed, 0.0, 1.0))


@dataclass(frozen=True)
class AssistRecord:
    """One case of an assist sweep (a line of the ``--out`` JSONL; see the module text). ``override_s`` and
    ``override_episodes``: seconds and runs of rows of each override of :data:`~hitchpark.assist.OVERRIDES` but
    ``none``; ``rms_curvature_error``: [1/m] over the rows where none acts and the trailer moves (None if no
    such row)."""

    family: str
    case: int
    start: Start
    reason: str
    max_abs_hitch_deg: float
    hitch_limit_rows: int
    steer_violations: int
    steer_rate_violations: int
    accel_violations: int
    nonfinite_commands: int
    override_s: dict[str, float]
    override_episodes: dict[str, int]
    rms_curvature_error: float | None
    collision: bool
    min_clearance_m: float | None
    wall_s: float

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def assist_record(result: ManeuverResult, family: str, case: int, start: Start, wall_s: float) -> AssistRecord:
    """Measure an assisted drive (see :class:`AssistRecord`)."""
    tr, model, real = result.trajectory, result.vehicle, result.plant_vehicle
    dt = result.settings.nmpc.dt
    steer, speed = tr["front_steer_cmd"], tr["rear_speed_cmd"]
    finite = np.isfinite(steer) & np.isfinite(speed)
    tol = 1e-9
    codes = tr["override"][:-1]
    override_s, episodes = {}, {}
    for i, name in enumerate(OVERRIDES[1:], start=1):
        on = codes == i
        override_s[name] = float(on.sum() * dt)
        episodes[name] = int(np.count_nonzero(on[1:] & ~on[:-1]) + (1 if len(on) and on[0] else 0))
    _, yaw_rate_t, v_t = full_rates(real, tr["hitch"], tr["rear_speed"], tr["front_steer"])
    moving = (np.abs(v_t) > MIN_CURVATURE_SPEED) & (tr["override"] == 0)
    error = yaw_rate_t[moving] / v_t[moving] - tr["curvature_cmd"][moving]
    return AssistRecord(
        family=family,
        case=case,
        start=start,
        reason=result.reason,
        max_abs_hitch_deg=result.max_abs_hitch_deg,
        hitch_limit_rows=int(np.count_nonzero(np.abs(tr["hitch"]) > real.max_hitch)),
        steer_violations=int(np.count_nonzero(np.abs(steer[finite]) > model.max_steer + tol)),
        steer_rate_violations=int(np.count_nonzero(np.abs(np.diff(steer)) > model.max_steer_rate * dt + tol)),
        accel_violations=int(np.count_nonzero(np.abs(np.diff(speed)) > model.max_accel * dt + tol)),
        nonfinite_commands=int(np.count_nonzero(~finite)),
        override_s=override_s,
        override_episodes=episodes,
        rms_curvature_error=float(np.sqrt(np.mean(error**2))) if len(error) else None,
        collision=result.collision,
        min_clearance_m=result.min_clearance_m,
        wall_s=wall_s,
    )


@dataclass(frozen=True)
class AssistTask:
    """One case: the sweep's config, the family, the case index and its start."""

    config: SweepConfig
    family: str
    case: int
    start: Start


def run_assist_case(task: AssistTask) -> AssistRecord:
    """Drive the task's knob profile from its start and measure it. Runs in a worker."""
    c = task.config
    t0 = time.perf_counter()
    result = drive_assisted(
        c.vehicle,
        task.start.state(),
        knob_profile(task.family, c.seed, task.case),
        goal=c.goal,
        settings=c.settings,
        plant=c.plant,
        scene=c.scene,
        name=f"{task.family} {task.case}",
    )
    return assist_record(result, task.family, task.case, task.start, time.perf_counter() - t0)


def summarize_assist(records: list[AssistRecord]) -> dict[str, Any]:
    """The numbers of an assist sweep: per family and over all (see :func:`format_assist_summary`)."""

    def numbers(rs: list[AssistRecord]) -> dict[str, Any]:
        rows = len(rs)
        errors = [r.rms_curvature_error for r in rs if r.rms_curvature_error is not None]
        clear = [r.min_clearance_m for r in rs if r.min_clearance_m is not None]
        return {
            "n": len(rs),
            "by_reason": {k: sum(r.reason == k for r in rs) for k in sorted({r.reason for r in rs})},
            "max_abs_hitch_deg": max(r.max_abs_hitch_deg for r in rs),
            "hitch_limit_rows": sum(r.hitch_limit_rows for r in rs),
            "steer_violations": sum(r.steer_violations for r in rs),
            "steer_rate_violations": sum(r.steer_rate_violations for r in rs),
            "accel_violations": sum(r.accel_violations for r in rs),
            "nonfinite_commands": sum(r.nonfinite_commands for r in rs),
            "override_s_per_case": {k: sum(r.override_s[k] for r in rs) / rows for k in OVERRIDES[1:]},
            "override_episodes_per_case": {k: sum(r.override_episodes[k] for r in rs) / rows for k in OVERRIDES[1:]},
            "rms_curvature_error_median": float(np.median(errors)) if errors else None,
            "rms_curvature_error_max": max(errors) if errors else None,
            "collisions": sum(r.collision for r in rs),
            "min_clearance_m": min(clear) if clear else None,
        }

    families = [f for f in FAMILIES if any(r.family == f for r in records)]
    return {"all": numbers(records)} | {f: numbers([r for r in records if r.family == f]) for f in families}


def _number(value: float | None, fmt: str) -> str:
    return "-" if value is None else format(value, fmt)


def format_assist_summary(summary: dict[str, Any]) -> str:
    """The summary as lines: one per family and one over all."""
    lines = []
    for name, s in summary.items():
        acted = ", ".join(
            f"{k} {s['override_s_per_case'][k]:.1f} s/{s['override_episodes_per_case'][k]:.1f}x"
            for k in OVERRIDES[1:]
            if s["override_s_per_case"][k] > 0
        )
        rms, worst = (_number(s[k], ".4f") for k in ("rms_curvature_error_median", "rms_curvature_error_max"))
        clear = "" if s["min_clearance_m"] is None else f", least clearance {s['min_clearance_m']:.2f} m"
        lines.append(
            f"{name:>6} (n={s['n']}): max |hitch| {s['max_abs_hitch_deg']:.1f} deg, rows past the jackknife limit "
            f"{s['hitch_limit_rows']}, commands past the steer/steer-rate/accel limits {s['steer_violations']}/"
            f"{s['steer_rate_violations']}/{s['accel_violations']}, non-finite {s['nonfinite_commands']}, "
            f"collisions {s['collisions']}{clear}; RMS curvature error (no override) median {rms} 1/m, "
            f"max {worst} 1/m; "
            f"overrides per case (time/episodes): {acted or 'none'}; ends {s['by_reason']}"
        )
    return "\n".join(lines)


def run_assist_sweep(
    config: SweepConfig,
    families: tuple[str, ...],
    out: str | Path,
    executor: Executor | None = None,
    on_record: Callable[[AssistRecord], None] | None = None,
) -> tuple[list[AssistRecord], dict[str, Any]]:
    """Run ``config.n`` cases of each family; write the records to ``out`` (JSONL, in family and case order)
    once all are done, and return them with their summary."""
    starts = config.starts()
    tasks = [AssistTask(config, f, i, s) for f in families for i, s in enumerate(starts)]
    executor = make_executor("serial") if executor is None else executor
    records = []
    with executor as running:
        for record in running.imap_unordered(run_assist_case, tasks):
            records.append(record)
            if on_record is not None:
                on_record(record)
    records.sort(key=lambda r: (FAMILIES.index(r.family), r.case))
    with Path(out).open("w", encoding="utf-8") as f:
        for r in records:
            f.write(json.dumps(r.to_dict()) + "\n")
    return records, summarize_assist(records)
