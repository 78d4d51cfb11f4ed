"""Parsing the command line: poses, options shared by several commands, the parser's own errors."""

from __future__ import annotations

import argparse
import math
import re
import signal
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn

from ..checks import InputError
from ..model.plant import PlantSettings, load_plant
from ..model.state import Pose, State, check_pose
from ..model.vehicle import VehicleTrailer, load_vehicle, vehicle_from_dict

if TYPE_CHECKING:
    from ..maneuver.scenario import Scenario

_VEHICLE_OVERRIDES = ("wheelbase", "hitch_offset", "trailer_length", "length_tolerance")

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
    g.add_argument(
        "--length-tolerance",
        type=float,
        metavar="F",
        help="how far the real L_H and L_T may be from these, a fraction in [0, 0.5]: the planner and the guard "
        "keep their clearance for all of them (default 0); overrides the file",
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


def parse_goal(text: str) -> Pose:
    """``X,Y,YAW_DEG`` -> goal :class:`Pose` of the trailer axle."""
    x, y, yaw = _floats(text, 3, "--goal", "X,Y,YAW_DEG")
    return Pose(x, y, math.radians(yaw))


def scenario_from_arg(path: Path) -> Scenario:
    """``--scenario``: a scenario file, or the name of one built in (``driveway``, ``parallel``, ...).

    A name is a bare word that is not an existing file; anything else is read as a file.
    """
    from ..maneuver.scenario import BUILTIN_ORDER, PLACES_SUITE, builtin_scenario, load_scenario

    text = str(path)
    if path.exists() or path.suffix or len(path.parts) != 1:
        return load_scenario(path)
    if text not in (*BUILTIN_ORDER, *PLACES_SUITE):
        raise UsageError(
            f"--scenario {text}: no such file, nor a built-in scenario (built in: "
            f"{', '.join((*BUILTIN_ORDER, *PLACES_SUITE))})"
        )
    return builtin_scenario(text)


def _plant(args: argparse.Namespace) -> PlantSettings | None:
    return load_plant(args.plant) if args.plant is not None else None
