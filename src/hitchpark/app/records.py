"""The sweep's record of one case and its JSONL file.

The schema lives here and only here: :class:`CaseRecord` (one JSON object per line of
the ``--out`` file), :func:`case_record` (the outcome fields measured from a
:class:`~hitchpark.maneuver.ManeuverResult`) and :func:`scan_records` (what an existing
file holds, for a resume); :mod:`.summary` gives the numbers over all cases.
"""

from __future__ import annotations

import json
import math
import numbers
import os
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

from ..checks import InputError
from ..maneuver.result import ManeuverResult
from ..model.state import State

__all__ = [
    "RECORD_FIELDS",
    "CaseRecord",
    "ExistingRecords",
    "RecordWriter",
    "Start",
    "case_record",
    "scan_records",
    "trailer_path_length",
]


def _finite_or_none(value: Any) -> float | None:
    value = float(value)
    return value if math.isfinite(value) else None


def _is_number(value: Any) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


@dataclass(frozen=True)
class Start:
    """A start in the parking frame: trailer-axle position [m], heading and hitch angle [deg].

    Kept in the degrees it was drawn in, so a record read back from JSON compares equal,
    bit for bit, with the start drawn again from the seed.
    """

    x: float
    y: float
    yaw_deg: float
    hitch_deg: float

    def state(self) -> State:
        return State(self.x, self.y, math.radians(self.yaw_deg), math.radians(self.hitch_deg))

    def to_dict(self) -> dict[str, float]:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: Any) -> Start:
        names = tuple(f.name for f in fields(cls))
        if not isinstance(data, Mapping) or set(data) != set(names):
            raise InputError(f"start must be an object with the keys {', '.join(names)}, got {data!r}")
        for name in names:
            if not _is_number(data[name]) or not math.isfinite(data[name]):
                raise InputError(f"start.{name} must be a finite number, got {data[name]!r}")
        return cls(*(float(data[name]) for name in names))


#: The outcome fields of a record, all but ``case`` and ``start``; floats are None when not finite.
_OUTCOME_FLOATS = (
    "distance_error_m",
    "orientation_error_deg",
    "final_hitch_deg",
    "max_abs_hitch_deg",
    "max_abs_steer_deg",
    "max_abs_steer_rate_deg_s",
    "path_length_m",
    "maneuver_time_s",
    "wall_s",
    "min_clearance_m",
    "planning_s",
)

#: Fields that records written before the scenes of obstacles lack: a file holding such records is refused.
_NEW_FIELDS = ("collision", "min_clearance_m", "direction_switches", "planning_s")


@dataclass(frozen=True)
class CaseRecord:
    """One case of a sweep: one line of the JSONL file.

    ``case`` is the index 0..n-1 of the start drawn from the seed, ``start`` that start.
    ``success``, ``reason`` and ``stages`` (how many) are the maneuver's; the errors and the final
    hitch angle are those at the end of the last stage; the maxima are over every row of the
    trajectory; ``path_length_m`` is the length of the trailer-axle path, ``maneuver_time_s`` the
    simulated time and ``wall_s`` the wall-clock time the case took. ``collision``: a body of the real car
    touched an obstacle or left the area; ``min_clearance_m``: the least clearance of its bodies from the scene
    over the motion (None in open space); ``direction_switches``: changes of direction of the car's motion;
    ``planning_s``: all the planning of the maneuver, replans included (0 when it planned nothing). Floats are
    None when not finite.
    """

    case: int
    start: Start
    success: bool
    reason: str
    stages: int
    distance_error_m: float | None
    orientation_error_deg: float | None
    final_hitch_deg: float | None
    max_abs_hitch_deg: float | None
    max_abs_steer_deg: float | None
    max_abs_steer_rate_deg_s: float | None
    path_length_m: float | None
    maneuver_time_s: float | None
    wall_s: float | None
    collision: bool
    min_clearance_m: float | None
    direction_switches: int
    planning_s: float | None

    def to_dict(self) -> dict[str, Any]:
        data = asdict(self)
        data["start"] = self.start.to_dict()
        return data

    def to_line(self) -> str:
        """The record as one line of JSON, newline included."""
        return json.dumps(self.to_dict(), allow_nan=False) + "\n"

    @classmethod
    def from_dict(cls, data: Any) -> CaseRecord:
        """Check and rebuild a record; anything else is an :class:`InputError` saying what is wrong."""
        if not isinstance(data, Mapping):
            raise InputError(f"a record must be a JSON object, got {type(data).__name__}")
        missing = [name for name in RECORD_FIELDS if name not in data]
        extra = sorted(set(data) - set(RECORD_FIELDS))
        if missing and set(missing) == set(_NEW_FIELDS) and not extra:
            raise InputError(
                f"the record is of an older hitchpark (it lacks {', '.join(_NEW_FIELDS)}, and its maneuver was "
                "not planned); run the sweep into a new file"
            )
        if missing or extra:
            what = f"lacks {missing[0]!r}" if missing else f"has the unknown key {extra[0]!r}"
            raise InputError(f"the record {what}")
        for name in ("case", "stages", "direction_switches"):
            value = data[name]
            if not isinstance(value, int) or isinstance(value, bool) or value < 0:
                raise InputError(f"{name} must be an integer >= 0, got {value!r}")
        for name in ("success", "collision"):
            if not isinstance(data[name], bool):
                raise InputError(f"{name} must be true or false, got {data[name]!r}")
        if not isinstance(data["reason"], str):
            raise InputError(f"reason must be a string, got {data['reason']!r}")
        floats: dict[str, float | None] = {}
        for name in _OUTCOME_FLOATS:
            value = data[name]
            if value is not None and not (_is_number(value) and math.isfinite(value)):
                raise InputError(f"{name} must be a finite number or null, got {value!r}")
            floats[name] = None if value is None else float(value)
        return cls(
            case=data["case"],
            start=Start.from_dict(data["start"]),
            success=data["success"],
            reason=data["reason"],
            stages=data["stages"],
            collision=data["collision"],
            direction_switches=data["direction_switches"],
            **floats,
        )


#: Keys of a record, in the order written (``case`` first: a cut line is recognised by its opening).
RECORD_FIELDS = tuple(f.name for f in fields(CaseRecord))

_LINE_OPENING = '{"case": '


def trailer_path_length(result: ManeuverResult) -> float:
    """Length of the trailer-axle path of the true motion [m] (summed over the trajectory's rows)."""
    traj = result.trajectory
    return float(np.sum(np.hypot(np.diff(traj["x_trailer"]), np.diff(traj["y_trailer"]))))


def case_record(result: ManeuverResult, wall_s: float) -> dict[str, Any]:
    """The outcome fields of a sweep record, measured from one maneuver (columns read by name).

    Everything of a :class:`CaseRecord` but ``case`` and ``start``, which the sweep knows and the
    maneuver does not (the start is kept exactly as drawn, in degrees). Non-finite floats become None.
    """
    traj = result.trajectory
    t, steer, hitch = traj["t"], traj["front_steer"], traj["hitch"]
    dt = np.diff(t)
    moving = dt > 0
    rates = np.abs(np.diff(steer)[moving] / dt[moving])
    last = result.stages[-1]
    return {
        "success": bool(result.success),
        "reason": str(result.reason),
        "stages": len(result.stages),
        "distance_error_m": _finite_or_none(last.distance_error_m),
        "orientation_error_deg": _finite_or_none(last.orientation_error_deg),
        "final_hitch_deg": _finite_or_none(last.final_hitch_deg),
        "max_abs_hitch_deg": _finite_or_none(np.degrees(np.max(np.abs(hitch)))),
        "max_abs_steer_deg": _finite_or_none(np.degrees(np.max(np.abs(steer)))),
        # One row (stopped at once): the steer never changed.
        "max_abs_steer_rate_deg_s": _finite_or_none(np.degrees(np.max(rates)) if rates.size else 0.0),
        "path_length_m": _finite_or_none(trailer_path_length(result)),
        "maneuver_time_s": _finite_or_none(result.duration),
        "wall_s": _finite_or_none(wall_s),
        "collision": bool(result.collision),
        "min_clearance_m": None if (clearance := result.min_clearance_m) is None else _finite_or_none(clearance),
        "direction_switches": int(result.direction_switches),
        "planning_s": _finite_or_none(result.planning_s),
    }


# --------------------------------------------------------------------------- the JSONL file


@dataclass(frozen=True)
class ExistingRecords:
    """What an existing ``--out`` file holds: its records by case, and how many bytes of it to keep.

    ``keep_bytes`` is the length of the whole lines; ``cut_bytes`` the length of a last line cut
    off by a kill (0 if none), which a resume drops and runs again.
    """

    records: dict[int, CaseRecord]
    keep_bytes: int
    cut_bytes: int


def _refuse(path: Path, why: str) -> InputError:
    return InputError(f"--out {path} {why}; refusing to add to it (give another --out)")


def scan_records(path: str | Path, starts: Sequence[Start]) -> ExistingRecords:
    """Read the records already in ``path`` for a sweep whose starts are ``starts``.

    A missing or empty file holds none. Every whole line must be a record of this sweep: a case
    index below ``len(starts)``, the start drawn for that index, each case once. Only the last
    line may lack its newline, and only if it is the opening of a record (a write cut off by a
    kill); it is reported in ``cut_bytes``, not read. Anything else is an :class:`InputError`,
    so a file that is not this sweep's is never changed.
    """
    path = Path(path)
    if path.is_dir():
        raise InputError(f"--out {path} is a folder; it must be a JSONL file")
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        return ExistingRecords({}, 0, 0)
    except OSError as exc:
        raise InputError(f"cannot read --out {path}: {exc.strerror or exc}") from None
    keep = data.rfind(b"\n") + 1
    cut = data[keep:]
    if cut:
        try:
            opening = cut.decode("utf-8")
        except UnicodeDecodeError:
            opening = ""
        if not (opening.startswith(_LINE_OPENING) or _LINE_OPENING.startswith(opening)):
            raise _refuse(path, "ends in a line that is not a sweep record")
    records: dict[int, CaseRecord] = {}
    for number, line in enumerate(data[:keep].split(b"\n")[:-1], start=1):
        try:
            record = CaseRecord.from_dict(json.loads(line.decode("utf-8")))
        except (UnicodeDecodeError, json.JSONDecodeError):
            raise _refuse(path, f"line {number} is not JSON") from None
        except InputError as exc:
            raise _refuse(path, f"line {number} is not a sweep record: {exc}") from None
        if record.case >= len(starts):
            raise _refuse(path, f"line {number} holds case {record.case}, beyond this sweep's n = {len(starts)}")
        if record.start != starts[record.case]:
            raise _refuse(
                path,
                f"line {number} holds case {record.case} with start {record.start.to_dict()}, not this sweep's "
                f"{starts[record.case].to_dict()} (another seed or region)",
            )
        if record.case in records:
            raise _refuse(path, f"line {number} repeats case {record.case}")
        records[record.case] = record
    return ExistingRecords(records, keep, len(cut))


class RecordWriter:
    """Appends records to the JSONL file, each in one write as soon as it is known.

    Opening it first drops a cut last line (``existing.cut_bytes``), so the file ends in a
    whole line. Use as a context manager.
    """

    def __init__(self, path: str | Path, existing: ExistingRecords):
        self.path = Path(path)
        self.existing = existing
        self._fh: BinaryIO | None = None

    def __enter__(self) -> RecordWriter:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        if self.existing.cut_bytes:
            os.truncate(self.path, self.existing.keep_bytes)
        self._fh = open(self.path, "ab", buffering=0)  # closed in __exit__
        return self

    def write(self, record: CaseRecord) -> None:
        """Append the record's line whole, or, if interrupted (Ctrl-C) or failing midway, nothing."""
        assert self._fh is not None, "use RecordWriter as a context manager"
        data = memoryview(record.to_line().encode("utf-8"))
        fd = self._fh.fileno()
        end, size = os.fstat(fd).st_size, len(data)
        try:
            while data:  # one write in practice; a short write continues where it stopped
                written = self._fh.write(data)
                data = data[written or 0 :]
            self._fh.flush()
        except BaseException:
            if end < os.fstat(fd).st_size < end + size:  # a part of the line went out: take it back
                os.ftruncate(fd, end)
            raise

    def __exit__(self, *exc: object) -> None:
        if self._fh is not None:
            self._fh.close()
            self._fh = None


# --------------------------------------------------------------------------- the summary
