"""The commands that take the controller to a car: ``export`` (a C package) and ``sil`` (it, in the loop)."""

from __future__ import annotations

import argparse
from typing import Any

from .arguments import _plant, scenario_from_arg, vehicle_from_args


def _export_spec(args: argparse.Namespace) -> Any:
    """The package ``export`` writes: the scenario's start, goal, plant and vehicle (``--vehicle`` over it), the
    NMPC of ``--settings``'s [nmpc], else the scenario's when it is the full model's, else the defaults."""
    from ..app.export import ExportSpec
    from ..app.sweep import load_settings
    from ..maneuver.scenario import builtin_scenario

    sc = scenario_from_arg(args.scenario) if args.scenario is not None else builtin_scenario("random")
    from ..ocp.settings import NMPCSettings

    if args.settings is not None:
        nmpc = load_settings(args.settings).nmpc
    else:
        nmpc = sc.settings.nmpc if sc.settings.nmpc.kind == "full" else NMPCSettings()
    vehicle = vehicle_from_args(args, default=sc.vehicle)
    return ExportSpec(
        vehicle, nmpc, start=sc.start, goal=sc.goal, plant=sc.plant, scenario=sc.name, obstacles=args.obstacles
    )


def _cmd_export(args: argparse.Namespace) -> int:
    from ..app.export import package_files
    from ..app.export_folder import write_package

    spec = _export_spec(args)
    files = package_files(spec)
    out = write_package(args.out, files, force=args.force)
    header = files["include/hitchpark_nmpc.h"]
    bound = next(line.split()[-1] for line in header.splitlines() if "WORKSPACE_BYTES " in line)
    among = ", among obstacles" if spec.obstacles else ""
    print(f"wrote {len(files)} files to {out}: the full-model NMPC{among}, horizon {spec.nmpc.horizon}, "
          f"workspace {bound} B")  # fmt: skip
    print(f"build: make -C {out}  (or cmake -S {out} -B {out}/build && cmake --build {out}/build)")
    return 0


def _cmd_sil(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from ..app.sil import run_sil
    from ..io import write_json
    from ..outputs import check_output_files

    check_output_files({"--json": args.json})
    sc = scenario_from_arg(args.scenario)
    plant = _plant(args)
    if plant is not None:
        sc = replace(sc, plant=plant)
    nmpc = None
    if args.settings is not None:
        from ..app.sweep import load_settings
        from ..checks import InputError
        from ..io import read_toml

        loaded = load_settings(args.settings)
        tables = set(read_toml(args.settings, "settings"))
        other = sorted(tables - {"nmpc", "estimator"})
        if other:  # the other tables of a maneuver's settings are the scenario's in both runs: not silently dropped
            raise InputError(
                f"settings file {args.settings}: sil takes its [nmpc] and [estimator] tables, not [{other[0]}] "
                "(put the others in the scenario file)"
            )
        nmpc = loaded.nmpc if "nmpc" in tables else None
        if "estimator" in tables:
            sc = replace(sc, settings=replace(sc.settings, estimator=loaded.estimator))
    report = run_sil(sc, nmpc=nmpc, process=args.process)
    data = report.to_dict()
    write_json(args.json, data)
    c, py = data["exported"], data["in_process"]
    t = data["c_step_time_ns"]
    print(f"{sc.name}: exported {c['outcome']} ({c['final_error_m']:.4f} m), in-process {py['outcome']} "
          f"({py['final_error_m']:.4f} m); largest difference: commands {data['max_command_difference']:.3g}, "
          f"states {data['max_state_difference']:.3g}")  # fmt: skip
    print(f"C step: median {t['median'] / 1e3:.1f} us, p99 {t['p99'] / 1e3:.1f} us, max {t['max'] / 1e3:.1f} us "
          f"({data['c_steps']} steps); workspace {data['workspace_bytes']} bytes; library {data['library_bytes']} "
          "bytes")  # fmt: skip
    ratios, py, ip = data["step_time_ratios"], data["python_step_ms"], data["ipopt_step_ms"]
    print(f"in-process step, median: Python route {py['median']:.3f} ms ({ratios['python_over_c']:.1f}x the C), "
          f"IPOPT {ip['median']:.3f} ms ({ratios['ipopt_over_c']:.0f}x)")  # fmt: skip
    return 0 if report.same_outcome and data["max_command_difference"] <= 1e-9 else 1
