"""Horizon and weights of the full-model NMPC, chosen by measured success on the plants that hurt.

    python benchmarks/full_tuning.py [N_STARTS] [SEED] [LABEL_PART]

Sweeps N_STARTS (default 100) seeded starts of the default region for each candidate setting on
the default plant and on the two combined-fault plants of ``benchmarks/plants`` (one-sample delay,
0.5 deg hitch noise, L_H and L_T 10% longer or shorter), with a process pool, and prints the share
parked, the failure reasons, the median path length and maneuver time, and the CPU seconds per case.
LABEL_PART runs only the candidates whose label contains it.
"""

from __future__ import annotations

import sys
import tempfile
from dataclasses import replace
from pathlib import Path

from hitchpark.app.executors import sweep_executor
from hitchpark.app.sweep import SweepConfig, run_sweep
from hitchpark.control import NMPCSettings
from hitchpark.maneuver import ManeuverSettings
from hitchpark.model.plant import PlantSettings, load_plant

PLANTS = Path(__file__).parent / "plants"

#: Candidates: (label, changes to the full kind's defaults).
CANDIDATES: list[tuple[str, dict[str, object]]] = [
    ("N10 dt0.3 (default)", {}),
    ("N6 dt0.3", {"horizon": 6}),
    ("N8 dt0.3", {"horizon": 8}),
    ("N10 dt0.2", {"prediction_dt": 0.2}),
    ("N10 dt0.45", {"prediction_dt": 0.45}),
    ("N15 dt0.3", {"horizon": 15}),
    ("N20 dt0.3", {"horizon": 20}),
    ("N15 dt0.3 margin 8deg", {"horizon": 15, "hitch_margin": 0.1396}),
]


def main(n: int = 100, seed: int = 31, only: str = "") -> None:
    plants: list[tuple[str, PlantSettings | None]] = [
        ("default", None),
        ("faults_long", load_plant(PLANTS / "faults_long.toml")),
        ("faults_short", load_plant(PLANTS / "faults_short.toml")),
    ]
    print(f"{n} starts per row, seed {seed}")
    head = (
        f"{'setting':<24}{'plant':<14}{'parked':>8}  {'path med m':>10}{'time med s':>11}{'cpu s/case':>11}"
        f"{'err max mm':>11}{'hitch max':>10}"
    )
    print(head + "  failures")
    with tempfile.TemporaryDirectory() as tmp:
        for label, changes in CANDIDATES:
            if only not in label:
                continue
            settings = ManeuverSettings(nmpc=replace(NMPCSettings(), **changes))  # type: ignore[arg-type]
            for plant_name, plant in plants:
                config = SweepConfig(settings=settings, plant=plant, seed=seed, n=n)
                out = Path(tmp) / f"{len(list(Path(tmp).iterdir()))}.jsonl"
                done = run_sweep(config, out, sweep_executor())
                s = done.summary
                errors = [r.distance_error_m for r in done.records if r.success and r.distance_error_m is not None]
                failures = {k: v for k, v in s["by_reason"].items() if k != "parked"}
                print(
                    f"{label:<24}{plant_name:<14}{s['parked']:>4}/{n:<3}  {s['path_length_m']['median']:>10.1f}"
                    f"{s['maneuver_time_s']['median']:>11.1f}{s['wall_s'] / n:>11.2f}"
                    f"{1e3 * max(errors, default=float('nan')):>11.2f}{s['max_abs_hitch_deg']:>10.1f}"
                    f"  {failures or ''}",
                    flush=True,
                )


if __name__ == "__main__":
    args = sys.argv[1:]
    main(int(args[0]) if args else 100, int(args[1]) if len(args) > 1 else 31, args[2] if len(args) > 2 else "")
