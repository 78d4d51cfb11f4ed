"""The commands that let a driver steer: ``assist`` (a knob profile, the knob assist) and ``drive`` (a live page)."""

from __future__ import annotations

import argparse

from .arguments import _finite, _plant, scenario_from_arg
from .commands import _renderer


def _cmd_assist(args: argparse.Namespace) -> int:
    from ..app.report import MANEUVER_FILES, save_maneuver
    from ..assist import OVERRIDES
    from ..io import StagedFolder
    from ..maneuver.assisted import drive_assisted, load_knob_profile

    staged = StagedFolder(args.out, MANEUVER_FILES, "--out")  # checks --out before any work
    sc = scenario_from_arg(args.scenario)
    profile = load_knob_profile(args.knob)
    plant = _plant(args) or sc.plant
    result = drive_assisted(
        sc.vehicle, sc.start, profile, goal=sc.goal, settings=sc.settings, plant=plant, scene=sc.scene, name=sc.name
    )
    plots = not args.no_plots
    with staged as stage:
        saved = save_maneuver(result, stage, _renderer(plots, plots))
        files = {k: staged.target / p.relative_to(stage) for k, p in saved.items()}
    tr = result.trajectory
    codes = tr["override"][:-1]
    dt = float(tr["t"][1] - tr["t"][0]) if len(tr) > 1 else 0.0
    acted = ", ".join(f"{name} {dt * n:.1f} s" for i, name in enumerate(OVERRIDES) if i and (n := int(sum(codes == i))))
    clearance = "" if result.min_clearance_m is None else f", least clearance {result.min_clearance_m:.2f} m"
    print(
        f"{result.reason}{f' ({result.detail})' if result.detail else ''} after {result.duration:.1f} s: "
        f"max |hitch| {result.max_abs_hitch_deg:.1f} deg, max |front steer| {result.max_abs_front_steer_deg:.1f} deg"
        f"{clearance}; overrides: {acted or 'none'}"
    )
    for name, path in files.items():
        print(f"{name}: {path}")
    return 0 if result.success else 1


def _cmd_drive(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from ..io import StagedFolder
    from ..viz.drive import check_host, save_into, serve_drive

    check_host(args.host, args.allow_remote)
    staged = StagedFolder(args.out, ("maneuver.json", "trajectory.csv", "maneuver.html"), "--out")
    sc = scenario_from_arg(args.scenario)
    plant = _plant(args)
    if plant is not None:
        sc = replace(sc, plant=plant)
    with staged as stage:
        result = serve_drive(
            sc,
            save_into(stage),
            host=args.host,
            port=args.port,
            allow_remote=args.allow_remote,
            max_time=_finite("--max-time", args.max_time),
            on_ready=lambda url: print(f"drive at {url} (Esc on the page stops the car and saves the drive)"),
        )
    print(
        f"{result.reason} after {result.duration:.1f} s: max |hitch| {result.max_abs_hitch_deg:.1f} deg; "
        f"maneuver: {staged.target / 'maneuver.json'}"
    )
    return 0 if result.success else 1
