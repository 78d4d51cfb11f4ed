"""The ``hitchpark`` command: parses, calls the library, prints. No logic of its own."""

from __future__ import annotations

import argparse
import math
import os
import re
import signal
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NoReturn

from .checks import InputError
from .model.plant import PlantSettings, load_plant
from .model.state import Pose, State, check_pose
from .model.vehicle import VehicleTrailer, load_vehicle, vehicle_from_dict

_VEHICLE_OVERRIDES = ("wheelbase", "hitch_offset", "trailer_length")

EXIT_BAD_INPUT = 2

#: Exit status after Ctrl-C (SIGINT), by convention 128 + SIGINT.
EXIT_INTERRUPTED = 128 + signal.SIGINT


class UsageError(InputError):
    """Bad command-line input: reported on one line, exit status 2."""


class _Parser(argparse.ArgumentParser):
    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        # Let "--start -5,2,0,0" pass a negative comma list as a value, not an option; "-inf" and "-nan"
        # too, so that the value's own check refuses them with its message.
        self._negative_number_matcher = re.compile(r"^-(\.?\d[\d.,eE+-]*|inf(inity)?|nan)(,.*)?$", re.IGNORECASE)

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {one_line(message)} (see --help)\n")


def one_line(text: str) -> str:
    """``text`` safe to print as one line: control characters (a newline in an argument, say) escaped."""
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in " ".join(text.split()))


def _floats(text: str, count: int, what: str, names: str) -> list[float]:
    parts = text.split(",")
    try:
        values = [float(p) for p in parts]
    except ValueError:
        values = []
    if len(values) != count or len(parts) != count:
        raise UsageError(f"{what} must be {count} comma-separated numbers {names}, got {text!r}")
    for name, v in zip(names.split(","), values, strict=True):
        if not math.isfinite(v):
            raise UsageError(f"{what}: {name} must be finite, got {v}")
    return values


def parse_start(text: str) -> State:
    """``X,Y,YAW_DEG,HITCH_DEG`` -> :class:`State` (trailer-axle pose and hitch angle)."""
    x, y, yaw, hitch = _floats(text, 4, "--start", "X,Y,YAW_DEG,HITCH_DEG")
    check_pose("start", x, y, math.radians(yaw))  # named as the user knows it, before State checks it again
    return State(x, y, math.radians(yaw), math.radians(hitch))


def _finite(name: str, value: float) -> float:
    if not math.isfinite(value):
        raise UsageError(f"{name} must be finite, got {value}")
    return value


def _add_vehicle_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("vehicle (default: the paper's Table 4 vehicle)")
    g.add_argument("--vehicle", metavar="FILE.toml", type=Path, help="TOML file with VehicleTrailer field names")
    g.add_argument("--wheelbase", type=float, metavar="M", help="L, rear to front axle [m]; overrides the file")
    g.add_argument("--hitch-offset", type=float, metavar="M", help="L_H, rear axle to hitch [m]; overrides the file")
    g.add_argument(
        "--trailer-length", type=float, metavar="M", help="L_T, hitch to trailer axle [m]; overrides the file"
    )


def _add_plant_option(p: argparse.ArgumentParser, default: str) -> None:
    p.add_argument(
        "--plant",
        type=Path,
        metavar="FILE.toml",
        help=f"the simulated car: PlantSettings fields at the top level or under [plant] {default}",
    )


def vehicle_from_args(args: argparse.Namespace, default: VehicleTrailer | None = None) -> VehicleTrailer:
    """The vehicle file (else ``default``, else Table 4) with the command-line overrides on top."""
    base = load_vehicle(args.vehicle) if args.vehicle is not None else (default or VehicleTrailer())
    overrides = {name: getattr(args, name) for name in _VEHICLE_OVERRIDES if getattr(args, name) is not None}
    return vehicle_from_dict(overrides, base) if overrides else base


def _cmd_simulate(args: argparse.Namespace) -> int:
    from .io import write_json
    from .outputs import check_output_file
    from .sim import simulate

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
    from .io import StagedFolder, write_json
    from .studies import TABLE2_VEHICLE, inverse_kinematics_study

    staged = StagedFolder(args.out, IK_STUDY_FILES, "--out")  # checks --out before any work
    out = staged.target
    result = inverse_kinematics_study(TABLE2_VEHICLE, rear_speed=_finite("--speed", args.speed))
    with staged as stage:
        write_json(stage / IK_STUDY_FILES[0], result.to_dict())
        if not args.no_plots:
            from .viz.ik import plot_ik_study

            plot_ik_study(result, stage / IK_STUDY_FILES[1])
    print(
        f"inverse kinematics study (Table 2): max |actual - desired virtual steer| = {result.max_steer_error:.3e} rad, "
        f"max trailer gap full vs trailer-only model = {result.max_pose_error:.3e} m"
    )
    if not args.no_plots:
        print(f"figure: {out / IK_STUDY_FILES[1]}")
    print(f"data: {out / IK_STUDY_FILES[0]}")
    return 0


def parse_goal(text: str) -> Pose:
    """``X,Y,YAW_DEG`` -> goal :class:`Pose` of the trailer axle."""
    x, y, yaw = _floats(text, 3, "--goal", "X,Y,YAW_DEG")
    return Pose(x, y, math.radians(yaw))


def _plant(args: argparse.Namespace) -> PlantSettings | None:
    return load_plant(args.plant) if args.plant is not None else None


def _cmd_reproduce(args: argparse.Namespace) -> int:
    from .app.report import reproduce, table5
    from .outputs import check_output_folder

    out = check_output_folder(args.out, "--out")
    plots = not args.no_plots
    results, summary = reproduce(out, plots=plots, animation=plots, progress=print, plant=_plant(args))
    print()
    print("Table 5 (trailer distance error, orientation error, final hitch angle):")
    print(table5(results))
    print(f"\nsummary: {summary}")
    return 0 if all(r.success for r in results) else 1


def _cmd_park(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from .app.report import MANEUVER_FILES, save_maneuver, summary_entry, table5
    from .io import StagedFolder
    from .maneuver.scenario import Scenario, load_scenario

    staged = StagedFolder(args.out, MANEUVER_FILES, "--out")  # checks --out before any work
    out = staged.target
    if args.scenario is None and args.start is None:
        raise UsageError("give --start X,Y,YAW_DEG,HITCH_DEG or --scenario FILE")
    sc = load_scenario(args.scenario) if args.scenario is not None else Scenario("park", parse_start(args.start))
    changes: dict[str, Any] = {}
    if args.start is not None:
        changes["start"] = parse_start(args.start)
    if args.goal is not None:
        changes["goal"] = parse_goal(args.goal)
    if args.plant is not None:
        changes["plant"] = _plant(args)
    changes["vehicle"] = vehicle_from_args(args, default=sc.vehicle)
    sc = replace(sc, **changes)

    from .maneuver.process import park

    result = park(sc.vehicle, sc.start, sc.goal, sc.settings, name=sc.name, plant=sc.plant)  # checks the start
    plots = not args.no_plots
    with staged as stage:
        files = {k: out / p.relative_to(stage) for k, p in save_maneuver(result, stage, plots, plots).items()}
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


def _cmd_plot(args: argparse.Namespace) -> int:
    from .app.report import ANIMATION_FILE, FIGURE_FILES, render_maneuver
    from .io import StagedFolder, read_json
    from .maneuver.result import ManeuverResult

    flag, out = ("--out", args.out) if args.out is not None else ("output folder", args.maneuver.parent)
    staged = StagedFolder(out, (*FIGURE_FILES, ANIMATION_FILE), flag)  # checks it before any work
    try:
        data = read_json(args.maneuver)
    except OSError as exc:
        raise UsageError(f"cannot read {args.maneuver}: {exc.strerror or exc}") from None
    except ValueError:  # not JSON, or not UTF-8 text
        raise UsageError(f"{args.maneuver} is not a hitchpark maneuver JSON (not JSON text)") from None
    if not isinstance(data, dict):
        raise UsageError(f"{args.maneuver} is not a hitchpark maneuver JSON (not a JSON object)")
    try:
        result = ManeuverResult.from_dict(data)
    except InputError as exc:
        raise UsageError(f"{args.maneuver} is not a hitchpark maneuver JSON: {exc}") from None
    with staged as stage:
        files = render_maneuver(result, stage, plots=True, animation=not args.no_animation)
    for name, path in files.items():
        print(f"{name}: {staged.target / path.relative_to(stage)}")
    return 0


def _cmd_sweep(args: argparse.Namespace) -> int:
    from .app.executors import sweep_executor
    from .app.records import format_summary
    from .app.sweep import build_config, run_sweep
    from .io import write_json
    from .outputs import check_figure_name, check_output_files

    files = check_output_files({"--out": args.out, "--json": args.json, "--map": args.map}, append=["--out"])
    if "--map" in files:
        check_figure_name(files["--map"], "--map")
    config = build_config(
        n=args.n,
        seed=args.seed,
        region=args.region,
        vehicle=vehicle_from_args(args),
        settings_file=args.settings,
        plant_file=args.plant,
    )
    executor = sweep_executor(args.workers, args.dask)
    outcome = run_sweep(config, files["--out"], executor, progress=True)
    if "--json" in files:
        write_json(files["--json"], outcome.summary)
    if "--map" in files:
        from .viz.sweep import plot_sweep_map

        title = f"Sweep, seed {config.seed}"
        plot_sweep_map(outcome.records, files["--map"], config.vehicle, config.region, title=title)
    cut = ", a cut last line dropped" if outcome.dropped_cut_line else ""
    print(
        f"sweep of {config.n} starts (seed {config.seed}, region {config.region}): {outcome.ran} run now in "
        f"{outcome.elapsed_s:.1f} s on {outcome.where}, {outcome.kept} kept from {files['--out']}{cut}"
    )
    print(format_summary(outcome.summary))
    print(f"records: {files['--out']}")
    for name, flag in (("summary", "--json"), ("map", "--map")):
        if flag in files:
            print(f"{name}: {files[flag]}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="hitchpark",
        description="Reverse parking of a car with a trailer: kinematics, inverse kinematics, NMPC (Cao et al. 2025).",
    )
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser, metavar="COMMAND")

    p = sub.add_parser(
        "simulate",
        help="drive the full model with a constant speed and steer",
        description="Drive the full vehicle-trailer model (Eqs. 19-24) with a constant rear-axle speed and front "
        "steer, and save the trajectory as JSON (SI units, radians).",
    )
    p.add_argument("--start", required=True, metavar="X,Y,YAW_DEG,HITCH_DEG", help="trailer-axle pose and hitch angle")
    p.add_argument("--speed", required=True, type=float, metavar="V", help="rear-axle speed V_R [m/s], < 0 reverses")
    p.add_argument("--steer", required=True, type=float, metavar="DEG", help="front steer [deg], within max_steer")
    p.add_argument("--duration", required=True, type=float, metavar="T", help="duration [s]")
    p.add_argument("--dt", type=float, default=0.1, metavar="S", help="sample time of the record [s] (default 0.1)")
    _add_vehicle_options(p)
    p.add_argument("--json", required=True, metavar="FILE", help="where to write the trajectory")
    p.set_defaults(func=_cmd_simulate)

    p = sub.add_parser(
        "ik-study",
        help="the inverse-kinematics validation study (Figs. 3-4)",
        description="Feed a desired virtual-steer profile through Eq. (45) into the full model (Table 2 vehicle), "
        "read it back with Eq. (46), and compare the trailer with the trailer-only model.",
    )
    p.add_argument("--out", required=True, metavar="DIR", help="folder for ik_study.json and .png")
    p.add_argument("--speed", type=float, default=-1.0, metavar="V", help="rear-axle speed [m/s] (default -1)")
    p.add_argument("--no-plots", action="store_true", help="write the JSON only")
    p.set_defaults(func=_cmd_ik_study)

    p = sub.add_parser(
        "reproduce",
        help="run the paper's four scenarios (Section 6.1, Table 5)",
        description="Park from the four shipped scenarios (parallel, parallel with hitch angle, perpendicular, "
        "random) with the 3-stage process, print Table 5, and write DIR/summary.json and, per scenario, "
        "DIR/NAME/maneuver.json with figures (Figs. 8-15) and an animation. Exit status 1 if any fails to park.",
    )
    p.add_argument("--out", required=True, metavar="DIR", help="output folder")
    _add_plant_option(p, "instead of the paper's ideal plant")
    p.add_argument("--no-plots", action="store_true", help="write JSON only (no figures, no animation)")
    p.set_defaults(func=_cmd_reproduce)

    p = sub.add_parser(
        "park",
        help="park from one start pose",
        description="Park the trailer from one start: reverse NMPC, and forward pure pursuit and reverse again as "
        "needed, on a simulated car (--plant), and write DIR/maneuver.json"
        ", figures and an animation. Exit status 1 if it does not park.",
    )
    p.add_argument("--start", metavar="X,Y,YAW_DEG,HITCH_DEG", help="trailer-axle pose and hitch angle (world frame)")
    p.add_argument("--goal", metavar="X,Y,YAW_DEG", help="goal trailer-axle pose (default 0,0,0 or the scenario's)")
    p.add_argument("--scenario", type=Path, metavar="FILE.toml", help="scenario file; --start/--goal override it")
    _add_vehicle_options(p)
    _add_plant_option(p, "(default: the scenario's [plant], else the realistic car)")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder")
    p.add_argument("--no-plots", action="store_true", help="write maneuver.json only")
    p.set_defaults(func=_cmd_park)

    p = sub.add_parser(
        "plot",
        help="re-plot a saved maneuver.json",
        description="Draw the figures and the animation of a saved maneuver without re-running it.",
    )
    p.add_argument("maneuver", type=Path, metavar="MANEUVER.json", help="a maneuver.json written by park/reproduce")
    p.add_argument("--out", metavar="DIR", help="output folder (default: beside the JSON)")
    p.add_argument("--no-animation", action="store_true", help="figures only")
    p.set_defaults(func=_cmd_plot)

    p = sub.add_parser(
        "sweep",
        help="park from many random starts and map where it succeeds",
        description="Park from N starts drawn uniformly from a region of the parking frame (goal at the origin, "
        "heading 0) with a seeded generator, one JSON line per case in --out as each finishes. Run again with "
        "the same --out to resume: finished cases are kept, only the missing ones run. Exit status 0 when every "
        "case ran, parked or not.",
    )
    p.add_argument("--n", required=True, type=int, metavar="N", help="number of starts (cases)")
    p.add_argument("--seed", required=True, type=int, metavar="S", help="seed of the random starts (>= 0)")
    p.add_argument(
        "--region",
        metavar="x=LO:HI,y=LO:HI,yaw=LO:HI,hitch=LO:HI",
        help="ranges of the trailer-axle x, y [m], yaw [deg] and hitch angle [deg]; a key left out keeps its "
        "default (x=4:16,y=-8:8,yaw=-90:90,hitch=-30:30)",
    )
    p.add_argument(
        "--settings", type=Path, metavar="FILE.toml", help="maneuver settings: [nmpc], [forward], [success] tables"
    )
    p.add_argument(
        "--plant",
        type=Path,
        metavar="FILE.toml",
        help="the simulated car: PlantSettings fields at the top level or under [plant] (default: the realistic car)",
    )
    _add_vehicle_options(p)
    p.add_argument("--workers", type=int, metavar="K", help="worker processes (default: one per core)")
    p.add_argument(
        "--dask",
        metavar="local|ADDRESS",
        help="run on Dask: 'local' starts a LocalCluster of --workers processes, an address joins a scheduler",
    )
    p.add_argument("--out", required=True, metavar="FILE.jsonl", help="one JSON record per case")
    p.add_argument("--json", metavar="SUMMARY.json", help="write the summary here")
    p.add_argument("--map", metavar="FILE.png", help="draw the outcome over the start positions")
    p.set_defaults(func=_cmd_sweep)
    return parser


def _interrupted(args: argparse.Namespace) -> str:
    """The one line printed on Ctrl-C; a sweep says where its finished cases are."""
    if args.command == "sweep":
        return f"hitchpark sweep: interrupted; the finished cases stay in {args.out}, the same command resumes"
    return f"hitchpark {args.command}: interrupted"


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line ``argv``; return the exit status.

    0 on success, 1 when a maneuver does not park, 2 on bad input, 130 on Ctrl-C (SIGINT).
    """
    parser = build_parser()
    args = parser.parse_args(argv)
    from .interrupts import Interrupts, caused_by_interrupt

    interrupts = Interrupts()
    try:
        try:
            return int(args.func(args))
        except Exception as exc:  # an interrupt that landed in C code comes back as another exception
            if caused_by_interrupt(exc):
                raise KeyboardInterrupt from exc
            raise
    except KeyboardInterrupt:  # what was half-built is gone by now, and the workers of a pool
        interrupts.exiting()
        print(_interrupted(args), file=sys.stderr)
        return EXIT_INTERRUPTED
    except InputError as exc:  # any other exception is a bug and keeps its traceback
        print(f"hitchpark {args.command}: error: {one_line(str(exc))}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except BrokenPipeError:  # the reader of stdout went away (`hitchpark ... | head`): stop quietly
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    except OSError as exc:  # an output path that cannot be written
        where = f": {exc.filename}" if exc.filename else ""
        message = one_line(f"cannot write output{where}: {exc.strerror or exc}")
        print(f"hitchpark {args.command}: error: {message}", file=sys.stderr)
        return EXIT_BAD_INPUT
    finally:
        interrupts.restore()


if __name__ == "__main__":
    sys.exit(main())
