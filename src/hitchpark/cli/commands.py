"""The commands: each parses its options, calls the library and prints. No logic of its own."""

from __future__ import annotations

import argparse
import functools
import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..checks import InputError
from ..outputs import check_output_file
from .arguments import UsageError, _finite, _plant, parse_goal, parse_start, scenario_from_arg, vehicle_from_args

if TYPE_CHECKING:
    from ..app.report import Render
    from ..maneuver.result import ManeuverResult


def _cmd_simulate(args: argparse.Namespace) -> int:
    from ..io import write_json
    from ..model.simulate import simulate
    from ..outputs import check_output_file

    path = check_output_file(args.json, "--json")
    vehicle = vehicle_from_args(args)
    start = parse_start(args.start)
    result = simulate(
        vehicle,
        start,
        rear_speed=_finite("--speed", args.speed),
        front_steer=math.radians(_finite("--steer", args.steer)),
        duration=_finite("--duration", args.duration),
        dt=_finite("--dt", args.dt),
    )
    write_json(path, result.to_dict())
    tr = result.trajectory
    print(
        f"simulated {tr['t'][-1]:.3f} s ({result.reason}): trailer axle at "
        f"({tr['x_trailer'][-1]:.4f}, {tr['y_trailer'][-1]:.4f}) m, yaw {math.degrees(tr['yaw_trailer'][-1]):.3f} deg, "
        f"hitch {math.degrees(tr['hitch'][-1]):.3f} deg -> {path}"
    )
    return 0


IK_STUDY_FILES = ("ik_study.json", "ik_study.png")  #: what ik-study owns in --out


def _cmd_ik_study(args: argparse.Namespace) -> int:
    from ..app.ik_study import TABLE2_VEHICLE, inverse_kinematics_study
    from ..io import StagedFolder, write_json

    staged = StagedFolder(args.out, IK_STUDY_FILES, "--out")  # checks --out before any work
    out = staged.target
    result = inverse_kinematics_study(TABLE2_VEHICLE, rear_speed=_finite("--speed", args.speed))
    with staged as stage:
        write_json(stage / IK_STUDY_FILES[0], result.to_dict())
        if not args.no_plots:
            from ..viz.ik import plot_ik_study

            plot_ik_study(result, stage / IK_STUDY_FILES[1])
    print(
        f"inverse kinematics study (Table 2): max |actual - desired virtual steer| = {result.max_steer_error:.3e} rad, "
        f"max trailer gap full vs trailer-only model = {result.max_pose_error:.3e} m"
    )
    if not args.no_plots:
        print(f"figure: {out / IK_STUDY_FILES[1]}")
    print(f"data: {out / IK_STUDY_FILES[0]}")
    return 0


def _renderer(plots: bool, animation: bool) -> Render | None:
    """What draws a maneuver's figures (and GIF) for :mod:`hitchpark.app.report`, or None: nothing to draw."""
    if not (plots or animation):
        return None
    from ..viz.maneuver import render_maneuver

    return functools.partial(render_maneuver, plots=plots, animation=animation)


def _cmd_reproduce(args: argparse.Namespace) -> int:
    from ..app.report import reproduce, suite_scenarios, suite_table, table5
    from ..outputs import check_output_folder

    scenarios = suite_scenarios(args.suite, "--suite") if args.suite is not None else None
    out = check_output_folder(args.out, "--out")
    plots = not args.no_plots
    render = _renderer(plots, plots)
    results, summary = reproduce(out, scenarios, render, progress=print, plant=_plant(args))
    if plots:
        print(f"figures and animations in {out}/<scenario>/")
    print()
    if args.suite in (None, "paper"):
        print("Table 5 (trailer distance error, orientation error, final hitch angle):")
        print(table5(results))
    else:
        print(f"Suite {args.suite} (path of the trailer axle, least clearance of the real car's bodies):")
        print(suite_table(results))
    print(f"\nsummary: {summary}")
    return 0 if all(r.success for r in results) else 1


def _cmd_park(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from ..app.report import MANEUVER_FILES, save_maneuver, summary_entry, table5
    from ..io import StagedFolder
    from ..maneuver.scenario import Scenario

    staged = StagedFolder(args.out, MANEUVER_FILES, "--out")  # checks --out before any work
    out = staged.target
    if args.scenario is None and args.start is None:
        raise UsageError("give --start X,Y,YAW_DEG,HITCH_DEG or --scenario FILE")
    sc = scenario_from_arg(args.scenario) if args.scenario is not None else Scenario("park", parse_start(args.start))
    changes: dict[str, Any] = {}
    if args.start is not None:
        changes["start"] = parse_start(args.start)
    if args.goal is not None:
        changes["goal"] = parse_goal(args.goal)
    if args.plant is not None:
        changes["plant"] = _plant(args)
    changes["vehicle"] = vehicle_from_args(args, default=sc.vehicle)
    sc = replace(sc, **changes)

    from ..maneuver.process import park

    result = park(
        sc.vehicle,
        sc.start,
        sc.goal,
        sc.settings,
        name=sc.name,
        plant=sc.plant,
        scene=sc.scene,
        predictions=args.predictions,
    )
    plots = not args.no_plots
    with staged as stage:
        saved = save_maneuver(result, stage, _renderer(plots, plots))
        files = {k: out / p.relative_to(stage) for k, p in saved.items()}
    entry = summary_entry(result, "maneuver.json")
    outcome = (
        "parked"
        if result.success
        else f"NOT parked: {result.reason}" + (f" ({result.detail})" if result.detail else "")
    )
    print(table5([result]))
    print(
        f"{outcome} after {len(result.stages)} stages, "
        f"{result.duration:.1f} s; max |front steer| {entry['max_abs_front_steer_deg']:.2f} deg, "
        f"max |hitch| {entry['max_abs_hitch_deg']:.2f} deg"
    )
    for name, path in files.items():
        print(f"{name}: {path}")
    return 0 if result.success else 1


def _assist_sweep(args: argparse.Namespace, config: Any, files: dict[str, Path], executor: Any) -> int:
    import time

    from ..app.assist_sweep import format_assist_summary, run_assist_sweep
    from ..io import write_json

    out = files["--out"]
    if out.exists() and out.stat().st_size > 0:
        raise UsageError(f"{out} is not empty: an assist sweep writes its records afresh, give a new --out")
    families = tuple(dict.fromkeys(args.assist))
    t0 = time.perf_counter()
    _, summary = run_assist_sweep(config, families, out, executor)
    summary = {
        "families": list(families),
        "n": config.n,
        "seed": config.seed,
        "region": config.region.to_dict(),
        **summary,
    }
    if "--json" in files:
        write_json(files["--json"], summary)
    where = f"scenario {config.scenario}, " if config.scenario else ""
    print(
        f"assist sweep of {config.n} starts x {len(families)} knob families ({where}seed {config.seed}, region "
        f"{config.region}) in {time.perf_counter() - t0:.1f} s on {executor.describe()}:"
    )
    print(format_assist_summary({k: summary[k] for k in ("all", *families)}))
    print(f"records: {out}")
    if "--json" in files:
        print(f"summary: {files['--json']}")
    return 0


def _read_maneuver(path: Path) -> ManeuverResult:
    """A saved maneuver.json, or a one-line :class:`UsageError` saying why it is not one."""
    from ..io import read_json
    from ..maneuver.result import ManeuverResult

    try:
        data = read_json(path)
    except OSError as exc:
        raise UsageError(f"cannot read {path}: {exc.strerror or exc}") from None
    except ValueError:  # not JSON, or not UTF-8 text
        raise UsageError(f"{path} is not a hitchpark maneuver JSON (not JSON text)") from None
    if not isinstance(data, dict):
        raise UsageError(f"{path} is not a hitchpark maneuver JSON (not a JSON object)")
    try:
        return ManeuverResult.from_dict(data)
    except InputError as exc:
        raise UsageError(f"{path} is not a hitchpark maneuver JSON: {exc}") from None


def _cmd_plot(args: argparse.Namespace) -> int:
    from ..app.report import ANIMATION_FILE, FIGURE_FILES, VIEWER_FILE
    from ..io import StagedFolder
    from ..viz.maneuver import render_maneuver

    flag, out = ("--out", args.out) if args.out is not None else ("output folder", args.maneuver.parent)
    staged = StagedFolder(out, (*FIGURE_FILES, ANIMATION_FILE, VIEWER_FILE), flag)  # checks it before any work
    result = _read_maneuver(args.maneuver)
    with staged as stage:
        files = render_maneuver(result, stage, plots=True, animation=not args.no_animation)
    for name, path in files.items():
        print(f"{name}: {staged.target / path.relative_to(stage)}")
    return 0


def _cmd_view(args: argparse.Namespace) -> int:
    from ..app.report import VIEWER_FILE
    from ..viz.viewer import write_viewer

    out = Path(args.out) if args.out is not None else args.maneuver.parent / VIEWER_FILE
    check_html_name(out, "--out" if args.out is not None else "the viewer beside the JSON")
    if out.exists() and not args.force:
        raise UsageError(f"{out} exists; give --force to replace it, or another --out FILE.html")
    result = _read_maneuver(args.maneuver)
    path = write_viewer(result, out, force=args.force)
    print(f"viewer: {path} ({path.stat().st_size / 1e6:.2f} MB; opens offline in a browser)")
    return 0


def check_html_name(path: Path, flag: str) -> None:
    """An HTML page's name must end in .html (or .htm): a browser opens it as a page then."""
    if path.suffix.lower() not in (".html", ".htm"):
        raise UsageError(f"{flag} {path}: an HTML page's name must end in .html (or .htm)")
    check_output_file(path, flag)


def _cmd_sweep(args: argparse.Namespace) -> int:
    from ..app.executors import sweep_executor
    from ..app.summary import format_summary
    from ..app.sweep import build_config, run_sweep
    from ..io import write_json
    from ..outputs import check_figure_name, check_output_files, check_output_folder

    named = {"--out": args.out, "--json": args.json, "--map": args.map, "--html": args.html}
    files = check_output_files(named, append=["--out"])
    if "--map" in files:
        check_figure_name(files["--map"], "--map")
    if "--html" in files:
        check_html_name(files["--html"], "--html")
    if args.assist is not None:
        for flag in ("--map", "--html"):
            if flag in files:
                raise UsageError(f"{flag} draws a parking sweep; an assist sweep (--assist) writes --out and --json")
        if args.keep_maneuvers is not None:
            raise UsageError("--keep-maneuvers keeps parking maneuvers; an assist sweep (--assist) writes --out")
        if args.exported:
            raise UsageError("--exported drives parking sweeps with the exported NMPC; an assist sweep has none")
    keep = None if args.keep_maneuvers is None else check_output_folder(args.keep_maneuvers, "--keep-maneuvers")
    scenario = scenario_from_arg(args.scenario) if args.scenario is not None else None
    config = build_config(
        n=args.n,
        seed=args.seed,
        region=args.region,
        vehicle=vehicle_from_args(args, default=scenario.vehicle if scenario else None),
        settings_file=args.settings,
        plant_file=args.plant,
        scenario=scenario,
    )
    if args.exported:
        from dataclasses import replace

        from ..app.exported import exported_controller_library

        settings, library = exported_controller_library(
            config.vehicle, config.settings, config.goal, config.plant, config.scene
        )
        config = replace(config, settings=settings, exported=library)
    executor = sweep_executor(args.workers, args.dask)
    if args.assist is not None:
        return _assist_sweep(args, config, files, executor)
    render = None
    if keep is not None:
        from ..viz.viewer import render_viewer

        render = render_viewer
    outcome = run_sweep(config, files["--out"], executor, progress=True, keep=keep, render=render)
    if "--json" in files:
        write_json(files["--json"], outcome.summary)
    if "--map" in files:
        from ..viz.sweep import plot_sweep_map

        title = f"Sweep{' of ' + config.scenario if config.scenario else ''}, seed {config.seed}"
        plot_sweep_map(
            outcome.records,
            files["--map"],
            config.vehicle,
            config.region,
            title=title,
            goal=config.goal,
            scene=config.scene,
        )
    if "--html" in files:
        from ..viz.sweep_html import write_sweep_page

        title = f"Sweep{' of ' + config.scenario if config.scenario else ''}, seed {config.seed}"
        write_sweep_page(
            outcome.records,
            files["--html"],
            keep,
            vehicle=config.vehicle,
            region=config.region,
            title=title,
            goal=config.goal,
            scene=config.scene,
        )
    cut = ", a cut last line dropped" if outcome.dropped_cut_line else ""
    where = f"scenario {config.scenario}, " if config.scenario else ""
    print(
        f"sweep of {config.n} starts ({where}seed {config.seed}, region {config.region}): {outcome.ran} run now in "
        f"{outcome.elapsed_s:.1f} s on {outcome.where}, {outcome.kept} kept from {files['--out']}{cut}"
    )
    print(format_summary(outcome.summary))
    print(f"records: {files['--out']}")
    for name, flag in (("summary", "--json"), ("map", "--map"), ("page", "--html")):
        if flag in files:
            print(f"{name}: {files[flag]}")
    if keep is not None:
        print(f"maneuvers: {keep}/case_NNNN/ (maneuver.json, maneuver.html)")
    return 0
