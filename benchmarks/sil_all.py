"""The exported controller in the loop on every scenario: ``python benchmarks/sil_all.py [--plant FILE.toml]``.

Runs :func:`hitchpark.app.sil.run_sil` (what ``hitchpark sil`` runs) on the paper's four scenarios, each with the
staged and with the planned process, and on the obstacle suite's five scenes (the planned process, the package
built with the obstacle OCP), each on the scenario's own plant and on ``--plant`` (default: the fault plant,
``benchmarks/plants/faults_long.toml``). Prints one row per maneuver (the outcome, the rows, the paths the C
tracked, the largest difference in commands and states, the C step's median and p99 measured inside C) and how
many agree to the bit; exit status 1 if any does not.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from hitchpark.app.sil import run_sil
from hitchpark.maneuver.scenario import BUILTIN_ORDER, builtin_scenario
from hitchpark.model.plant import load_plant

FAULTS = Path(__file__).with_name("plants") / "faults_long.toml"
SCENES = ("driveway", "campsite", "curb_parallel", "bay", "loading_dock")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--plant", type=Path, default=FAULTS, help="the second plant (default: the fault plant)")
    args = parser.parse_args(argv)
    other = load_plant(args.plant)
    cases = [(n, p, pl) for n in BUILTIN_ORDER for p in ("staged", "planned") for pl in (None, other)]
    cases += [(n, None, pl) for n in SCENES for pl in (None, other)]
    same = 0
    for name, process, plant in cases:
        t0 = time.perf_counter()
        r = run_sil(builtin_scenario(name), plant=plant, ipopt=False, process=process).to_dict()
        ok = (
            r["same_outcome"]
            and r["rows"]["exported"] == r["rows"]["in_process"]
            and r["max_command_difference"] == 0.0
            and r["max_state_difference"] == 0.0
        )
        same += ok
        c = r["c_step_time_ns"]
        print(
            f"{name:15} {process or 'planned':8} {'other' if plant else 'own':6} {r['exported']['outcome']:10} "
            f"rows {r['rows']['exported']:4}  paths {r['paths_followed']}  commands {r['max_command_difference']:.3g}"
            f"  states {r['max_state_difference']:.3g}  C step median {c['median'] / 1e3:7.1f} us, p99 "
            f"{c['p99'] / 1e3:7.1f} us  {'same' if ok else 'DIFFERENT'}  ({time.perf_counter() - t0:.0f} s)",
            flush=True,
        )
    print(f"{same} of {len(cases)} maneuvers the same as in-process to the bit")
    return 0 if same == len(cases) else 1


if __name__ == "__main__":
    sys.exit(main())
