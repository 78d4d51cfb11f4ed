"""The exported controller's step time, per OCP: ``python benchmarks/step_time.py [--rounds R] [--settings FILE.toml
...] [--scenes NAME ...]``.

Builds the package (``hitchpark export``'s, through the compile cache as ``hitchpark sil`` does) for the default
full-model NMPC and for each ``--settings`` file's [nmpc] (default: ``benchmarks/settings/realtime_iteration.toml``),
then parks each of the paper's four starts, with the planned and with the staged process (the full-model OCP), and
each scene of ``--scenes`` (default: driveway and campsite) with the planned process and the package exported with
its obstacles (the obstacle OCP), on the scenario's plant with the exported controller, ``R`` rounds (default 5)
taking turns. The step's time is measured inside C; a step's figure is its least over the rounds (the same maneuver
each round: a shared machine's preemptions fall out), and the table gives their median, p99 and max, with the
outcome and final error, per case and over all steps of an OCP and a setting. Exit status 1 if a round drives
otherwise than the first (its solver iterations differ).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

from hitchpark.app.export import ExportSpec, package_files
from hitchpark.app.exported import ExportedNMPC, build_package, cached_package_library
from hitchpark.app.sil import sil_settings
from hitchpark.app.sweep import load_settings
from hitchpark.checks import InputError
from hitchpark.maneuver.process import park
from hitchpark.maneuver.scenario import BUILTIN_ORDER, builtin_scenario

RTI = Path(__file__).with_name("settings") / "realtime_iteration.toml"


def _figures(us: np.ndarray) -> str:
    return f"{np.median(us):7.1f} {np.percentile(us, 99):7.1f} {us.max():7.1f}"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=5, help="parks of each case, taking turns (default 5)")
    parser.add_argument(
        "--settings", type=Path, nargs="*", default=[RTI], help="settings files to time beside the default"
    )
    parser.add_argument(
        "--scenes", nargs="*", default=["driveway", "campsite"], help="scenes to time the obstacle OCP on"
    )
    args = parser.parse_args(argv)
    try:
        variants = [("default", None)] + [(path.stem, load_settings(path).nmpc) for path in args.settings]
        for name in args.scenes:
            builtin_scenario(name)
    except InputError as exc:
        print(f"step_time: error: {exc}", file=sys.stderr)
        return 2
    runs = [(name, process, "full-model") for name in BUILTIN_ORDER for process in ("planned", "staged")]
    runs += [(name, "planned", "obstacle") for name in args.scenes]
    scratch = tempfile.TemporaryDirectory()
    cases = []
    for label, nmpc in variants:
        for name, process, ocp in runs:
            sc = builtin_scenario(name)
            settings = sil_settings(sc.settings, nmpc, process)
            among = ocp == "obstacle"
            spec = ExportSpec(sc.vehicle, settings.nmpc, sc.start, sc.goal, sc.plant, sc.name, obstacles=among)
            files = package_files(spec)
            library = cached_package_library(files) or build_package(files, Path(scratch.name) / str(len(cases)))
            case = {"label": label, "sc": sc, "process": process, "settings": settings, "lib": library, "ocp": ocp}
            cases.append(case)
    for _ in range(args.rounds):
        for case in cases:
            sc, settings = case["sc"], case["settings"]
            controller = ExportedNMPC(case["lib"], sc.vehicle, settings.nmpc)
            result = park(sc.vehicle, sc.start, sc.goal, settings, sc.name, controller, sc.plant, sc.scene)
            if "result" not in case:
                case["result"], case["iterations"], case["ns"] = result, controller.timing.iterations, []
            elif controller.timing.iterations != case["iterations"]:
                print(f"{case['label']} {sc.name} {case['process']}: a round drove otherwise", file=sys.stderr)
                return 1
            case["ns"].append(controller.timing.step_ns)
    print(f"{'setting':20s} {'scenario':15s} {'process':8s} {'outcome':9s} {'error mm':>8s} {'stages':>6s} "
          f"{'steps':>5s}  {'median':>7s} {'p99':>7s} {'max':>7s} us  >25us >100us")  # fmt: skip
    for (label, _), ocp in ((variant, ocp) for variant in variants for ocp in ("full-model", "obstacle")):
        pooled = []
        for case in (c for c in cases if c["label"] == label and c["ocp"] == ocp):
            us = np.min(np.asarray(case["ns"], dtype=float), axis=0) / 1e3
            pooled.append(us)
            r = case["result"]
            print(f"{label:20s} {case['sc'].name:15s} {case['process']:8s} {r.reason:9s} "
                  f"{1e3 * r.stages[-1].distance_error_m:8.2f} {len(r.stages):6d} {len(us):5d}  {_figures(us)}    "
                  f"{int((us > 25).sum()):5d} {int((us > 100).sum()):6d}")  # fmt: skip
        if not pooled:
            continue
        us = np.concatenate(pooled)
        print(f"{label:20s} {ocp + ' OCP':15s} {'all':8s} {'':9s} {'':8s} {'':6s} {len(us):5d}  {_figures(us)}    "
              f"{int((us > 25).sum()):5d} {int((us > 100).sum()):6d}")  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
