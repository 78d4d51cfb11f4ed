"""The ``hitchpark`` command: parses, calls the library, prints. No logic of its own."""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Sequence
from pathlib import Path

from ..checks import InputError
from .arguments import (
    EXIT_BAD_INPUT,
    EXIT_INTERRUPTED,
    UsageError,
    _add_plant_option,
    _add_vehicle_options,
    _Parser,
    one_line,
    parse_goal,
    parse_start,
    vehicle_from_args,
)
from .assist import _cmd_assist, _cmd_drive
from .car import _cmd_export, _cmd_sil
from .commands import (
    IK_STUDY_FILES,
    _cmd_ik_study,
    _cmd_park,
    _cmd_plot,
    _cmd_reproduce,
    _cmd_simulate,
    _cmd_sweep,
    _cmd_view,
)
from .speed import add_speed_commands

__all__ = [
    "EXIT_BAD_INPUT",
    "EXIT_INTERRUPTED",
    "IK_STUDY_FILES",
    "UsageError",
    "build_parser",
    "main",
    "one_line",
    "parse_goal",
    "parse_start",
    "vehicle_from_args",
]


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
        help="run the paper's four scenarios (Section 6.1, Table 5) or the scenes of obstacles",
        description="Park from the four shipped scenarios (parallel, parallel with hitch angle, perpendicular, "
        "random) with the 3-stage process, print Table 5, and write DIR/summary.json and, per scenario, "
        "DIR/NAME/maneuver.json with figures (Figs. 8-15) and an animation. With --suite obstacles, park in the "
        "five built-in scenes of obstacles instead (driveway, campsite, curb_parallel, bay, loading_dock), with "
        "--suite places in those and eight more places of real dimensions (driveway_fence, garage_end, "
        "campground_angled, trailer_row, dock_alley, boat_ramp, curb_gap, hammerhead), and print a table of "
        "path length, direction switches, least clearance, planning and maneuver time. "
        "Exit status 1 if any fails to park.",
    )
    p.add_argument("--out", required=True, metavar="DIR", help="output folder")
    p.add_argument(
        "--suite",
        metavar="NAME",
        help="'paper' (the default: the paper's four scenarios), 'obstacles' (the five scenes of obstacles) or "
        "'places' (those and eight more places trailers are backed into)",
    )
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
    p.add_argument(
        "--scenario",
        type=Path,
        metavar="FILE.toml|NAME",
        help="scenario file, or a built-in one by name (driveway, bay, parallel, ...); --start/--goal override it",
    )
    _add_vehicle_options(p)
    _add_plant_option(p, "(default: the scenario's [plant], else the realistic car)")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder")
    p.add_argument("--no-plots", action="store_true", help="write maneuver.json only (no figures, no viewer)")
    p.add_argument(
        "--predictions",
        action="store_true",
        help="record the NMPC's predicted trailer path at each row in maneuver.json (the viewer draws it)",
    )
    p.set_defaults(func=_cmd_park)

    p = sub.add_parser(
        "drive",
        help="drive the knob assist live in a browser page",
        description="Serve a page on 127.0.0.1 where you back the scenario's combination with the knob assist: "
        "turn the knob with the mouse wheel, a drag or the arrow keys, hold the up arrow (or W) to back up, Esc to "
        "stop. The page shows the rig at the plant's rate, the curvature asked and got, the hitch against its "
        "limit and each override. When the car stands after Esc, DIR gets maneuver.json, trajectory.csv and "
        "maneuver.html (hitchpark view opens the JSON) and the command ends.",
    )
    p.add_argument(
        "--scenario", required=True, type=Path, metavar="FILE.toml|NAME", help="scenario file or built-in name"
    )
    p.add_argument("--out", required=True, metavar="DIR", help="where the drive is saved")
    p.add_argument("--port", type=int, default=8765, metavar="P", help="port to listen on (default 8765; 0: any)")
    p.add_argument("--host", default="127.0.0.1", metavar="H", help="address to listen on (default 127.0.0.1)")
    p.add_argument(
        "--allow-remote", action="store_true", help="let --host be an address other machines reach (no login!)"
    )
    _add_plant_option(p, "(default: the scenario's [plant], else the realistic car)")
    p.add_argument("--max-time", type=float, default=600.0, metavar="S", help="longest drive [s] (default 600)")
    p.set_defaults(func=_cmd_drive)

    p = sub.add_parser(
        "assist",
        help="back up with the knob assist: a knob profile steers the trailer",
        description="Drive a knob profile (CSV with the header t,knob,speed_request: knob in [-1, 1] the trailer's "
        "path curvature, 1 the tightest steady turn; speed_request the reverse speed [m/s]; values held between "
        "rows) through the knob assist from the scenario's start, among its obstacles, on a simulated car, and "
        "write DIR/maneuver.json (with the knob, the request and the overrides as columns), trajectory.csv, "
        "figures and maneuver.html. Exit status 1 if it jackknifes, collides or breaks a limit.",
    )
    p.add_argument(
        "--scenario", required=True, type=Path, metavar="FILE.toml|NAME", help="scenario file or built-in name"
    )
    p.add_argument("--knob", required=True, type=Path, metavar="PROFILE.csv", help="the knob profile")
    _add_plant_option(p, "(default: the scenario's [plant], else the realistic car)")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder")
    p.add_argument("--no-plots", action="store_true", help="write maneuver.json and trajectory.csv only")
    p.set_defaults(func=_cmd_assist)

    p = sub.add_parser(
        "plot",
        help="re-plot a saved maneuver.json",
        description="Draw the figures and the animation of a saved maneuver without re-running it.",
    )
    p.add_argument("maneuver", type=Path, metavar="MANEUVER.json", help="a maneuver.json written by park/reproduce")
    p.add_argument("--out", metavar="DIR", help="output folder (default: beside the JSON)")
    p.add_argument("--no-animation", action="store_true", help="figures and viewer only")
    p.set_defaults(func=_cmd_plot)

    p = sub.add_parser(
        "view",
        help="write a maneuver's viewer: one HTML page that opens offline",
        description="Write one self-contained HTML page of a saved maneuver (no network, no server: open it from "
        "disk in a browser): the scene to scale, the car and trailer at a cursor you scrub or play, the paths, the "
        "plans, the NMPC's predictions where recorded (park --predictions), and plots of steer, steer rate, speed, "
        "hitch and clearance under it.",
    )
    p.add_argument("maneuver", type=Path, metavar="MANEUVER.json", help="a maneuver.json written by park/reproduce")
    p.add_argument("--out", metavar="FILE.html", help="where to write it (default: maneuver.html beside the JSON)")
    p.add_argument("--force", action="store_true", help="replace the file if it exists")
    p.set_defaults(func=_cmd_view)

    p = sub.add_parser(
        "sweep",
        help="park from many random starts and map where it succeeds",
        description="Park from N starts drawn uniformly from a region of the parking frame (goal at the origin, "
        "heading 0) with a seeded generator, one JSON line per case in --out as each finishes. With --scenario, "
        "the starts come from the scenario's [start_region] (world frame), to its goal among its obstacles, with "
        "its vehicle, settings and plant; starts that do not keep success.min_clearance_m clear of the scene are "
        "drawn again and counted as skipped. Run again with the same --out to resume: finished cases are kept, "
        "only the missing ones run. Exit status 0 when every case ran, parked or not.",
    )
    p.add_argument("--n", required=True, type=int, metavar="N", help="number of starts (cases)")
    p.add_argument("--seed", required=True, type=int, metavar="S", help="seed of the random starts (>= 0)")
    p.add_argument(
        "--scenario",
        type=Path,
        metavar="FILE.toml|NAME",
        help="sweep over a scenario's scene (a file, or a built-in one by name, e.g. bay): starts from its "
        "[start_region]; --settings, --plant and the vehicle options override its own",
    )
    p.add_argument(
        "--region",
        metavar="x=LO:HI,y=LO:HI,yaw=LO:HI,hitch=LO:HI",
        help="ranges of the trailer-axle x, y [m], yaw [deg] and hitch angle [deg]; a key left out keeps its "
        "default (x=4:16,y=-8:8,yaw=-90:90,hitch=-30:30); not with --scenario",
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
    p.add_argument(
        "--html",
        metavar="FILE.html",
        help="write the map as one HTML page that opens offline: hover a start for its outcome, filter by outcome "
        "and reason, histograms of path length, planning time and switches",
    )
    p.add_argument(
        "--assist",
        nargs="+",
        choices=("hold", "slalom", "steps", "noise"),
        metavar="FAMILY",
        help="sweep the knob assist instead of parking: N starts for each knob profile family (hold, slalom, "
        "steps, noise), 60 s each, drawn from the seed; --out gets one record per case (max |hitch|, limit "
        "violations, overrides, curvature error, clearance), --json the summary; not with --map, --html, "
        "--keep-maneuvers",
    )
    p.add_argument(
        "--keep-maneuvers",
        metavar="DIR",
        help="keep each case's maneuver.json and its viewer (maneuver.html) in DIR/case_NNNN/ (the cases run now); "
        "the --html page links each start to its viewer",
    )
    p.add_argument(
        "--exported",
        action="store_true",
        help="drive every case with the exported C controller (export's package, built once into the compile cache, "
        "as sil runs it: the full-model NMPC without a fallback solver); the same sweep in-process with "
        'nmpc.fallback_solver = "none" gives the same records',
    )
    p.set_defaults(func=_cmd_sweep)
    p = sub.add_parser(
        "export",
        help="write the full-model NMPC as a self-contained C99 package",
        description="Write the full-model NMPC (hitchpark's own solver, the OCP's functions generated by CasADi, the "
        "controller's tick around the solve) as a C99 package for an embedded target: include/hitchpark_nmpc.h, src/, "
        "a Makefile and a CMakeLists.txt, examples/main.c (one reverse stage from the scenario's start, as CSV), "
        "README.md and manifest.json. No malloc, no I/O, no global state, libm only.",
    )
    p.add_argument("--out", required=True, metavar="DIR", help="the package's folder (new or empty; see --force)")
    p.add_argument(
        "--scenario",
        type=Path,
        metavar="NAME|FILE",
        help="the example's start, goal and plant, and the vehicle (default: random); its [nmpc] if of kind full",
    )
    p.add_argument(
        "--settings",
        type=Path,
        metavar="FILE.toml",
        help="maneuver settings whose [nmpc] table (kind full) is exported",
    )
    p.add_argument(
        "--obstacles",
        action="store_true",
        help="the obstacle OCP too: it keeps clear of a scene given when it runs (hitchpark_nmpc_keep_clear)",
    )
    p.add_argument("--force", action="store_true", help="replace the package's files in a folder that holds others")
    _add_vehicle_options(p)
    p.set_defaults(func=_cmd_export)

    p = sub.add_parser(
        "sil",
        help="software in the loop: the exported C controller against the in-process one",
        description="Export the full-model NMPC, build it with the system's C compiler (once: into hitchpark's compile "
        "cache, where the next run with the same vehicle and settings loads it), load it, "
        "and park the scenario with it on hitchpark's plant; park it again with the in-process controller; report "
        "both side by side (outcomes, the largest difference in commands and states, the C step's time measured "
        "inside C, the workspace and library size, the in-process routes' step times: the same solver from Python, "
        "and IPOPT's in a third maneuver) in --json. Exit status 0 when the outcomes agree and the commands agree to "
        "1e-9, else 1.",
    )
    p.add_argument("--scenario", required=True, type=Path, metavar="NAME|FILE", help="a scenario file or built-in name")
    p.add_argument(
        "--process",
        choices=("staged", "planned"),
        help="the paper's staged process, or the planned one, the NMPC tracking the planner's path (default: the "
        "scenario's; the paper's scenarios are staged)",
    )
    p.add_argument(
        "--settings",
        type=Path,
        metavar="FILE.toml",
        help="maneuver settings whose [nmpc] table (kind full) both controllers run, as export takes it (default: the "
        "scenario's when of kind full, else the defaults), and whose [estimator] table filters the readings of both "
        "runs; other tables are refused (they are the scenario's)",
    )
    _add_plant_option(p, "(default: the scenario's [plant])")
    p.add_argument("--json", required=True, metavar="FILE", help="where to write the report")
    p.set_defaults(func=_cmd_sil)

    add_speed_commands(sub)
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
