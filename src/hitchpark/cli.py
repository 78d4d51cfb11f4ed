"""The ``hitchpark`` command: parses, calls the library, prints. No logic of its own."""

from __future__ import annotations

import argparse
import math
import re
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NoReturn

from .model.vehicle import VehicleTrailer, load_vehicle, vehicle_from_dict
from .sim import State

EXIT_BAD_INPUT = 2


class UsageError(Exception):
    """Bad command-line input: reported on one line, exit status 2."""


class _Parser(argparse.ArgumentParser):
    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        # Let "--start -5,2,0,0" pass a negative comma list as a value, not an option.
        self._negative_number_matcher = re.compile(r"^-\.?\d[\d.,eE+-]*$")

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {message} (see --help)\n")


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
    g.add_argument("--trailer-length", type=float, metavar="M", help="L_T, hitch to trailer axle [m]; overrides the file")


def vehicle_from_args(args: argparse.Namespace) -> VehicleTrailer:
    base = load_vehicle(args.vehicle) if args.vehicle is not None else VehicleTrailer()
    overrides = {
        name: getattr(args, name)
        for name in ("wheelbase", "hitch_offset", "trailer_length")
        if getattr(args, name) is not None
    }
    return vehicle_from_dict(overrides, base) if overrides else base


def _cmd_simulate(args: argparse.Namespace) -> int:
    from .io import write_json
    from .sim import simulate

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
    write_json(args.json, result.to_dict())
    tr = result.trajectory
    print(
        f"simulated {tr['t'][-1]:.3f} s ({result.reason}): trailer axle at "
        f"({tr['x_trailer'][-1]:.4f}, {tr['y_trailer'][-1]:.4f}) m, yaw {math.degrees(tr['yaw_trailer'][-1]):.3f} deg, "
        f"hitch {math.degrees(tr['hitch'][-1]):.3f} deg -> {args.json}"
    )
    return 0


def _cmd_ik_study(args: argparse.Namespace) -> int:
    from .io import write_json
    from .studies import TABLE2_VEHICLE, inverse_kinematics_study

    result = inverse_kinematics_study(TABLE2_VEHICLE, rear_speed=_finite("--speed", args.speed))
    out: Path = args.out
    write_json(out / "ik_study.json", result.to_dict())
    print(
        f"inverse kinematics study (Table 2): max |actual - desired virtual steer| = {result.max_steer_error:.3e} rad, "
        f"max trailer gap full vs trailer-only model = {result.max_pose_error:.3e} m"
    )
    if not args.no_plots:
        from .viz.ik import plot_ik_study

        print(f"figure: {plot_ik_study(result, out / 'ik_study.png')}")
    print(f"data: {out / 'ik_study.json'}")
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
    p.add_argument("--json", required=True, type=Path, metavar="FILE", help="where to write the trajectory")
    p.set_defaults(func=_cmd_simulate)

    p = sub.add_parser(
        "ik-study",
        help="the inverse-kinematics validation study (Figs. 3-4)",
        description="Feed a desired virtual-steer profile through Eq. (45) into the full model (Table 2 vehicle), "
        "read it back with Eq. (46), and compare the trailer with the trailer-only model.",
    )
    p.add_argument("--out", required=True, type=Path, metavar="DIR", help="folder for ik_study.json and .png")
    p.add_argument("--speed", type=float, default=-1.0, metavar="V", help="rear-axle speed [m/s] (default -1)")
    p.add_argument("--no-plots", action="store_true", help="write the JSON only")
    p.set_defaults(func=_cmd_ik_study)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args))
    except (UsageError, ValueError) as exc:
        print(f"hitchpark {args.command}: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT


if __name__ == "__main__":
    sys.exit(main())
