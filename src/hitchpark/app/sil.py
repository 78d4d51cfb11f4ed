"""``hitchpark sil``: the exported C controller in the loop, beside the in-process one.

:func:`build_package` compiles a package (:mod:`.export`) in a scratch folder with the system's C compiler into
a shared library; :class:`ExportedNMPC` drives that library through :mod:`ctypes` where the maneuver expects a
:class:`~hitchpark.control.nmpc.FullNMPC` (parking, tracking the planner's path, keeping clear of a scene: every
call goes to the C); :func:`run_sil` parks the same scenario twice, with the exported controller and with the
in-process one, on hitchpark's plant, and compares them row by row (:class:`SilReport`). Both run the scenario's
process (the paper's scenarios the staged one, the others the planned one); what is not the NMPC (the planner,
the forward stages, the guard) is the same Python in both.
"""

from __future__ import annotations

import ctypes
import math
import subprocess
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..checks import InputError, check_choice, check_instance, check_range
from ..control.nmpc import FullNMPC
from ..control.step import ControlStep
from ..maneuver.process import park
from ..maneuver.result import ManeuverResult
from ..maneuver.scenario import Scenario
from ..maneuver.settings import ManeuverSettings
from ..model.inverse import virtual_steer_from_front
from ..model.kinematics import trailer_speed_from_rear_speed
from ..model.plant import Command, Measurement, PlantSettings
from ..model.scene import Scene
from ..model.state import Pose, check_goal
from ..model.vehicle import VehicleTrailer
from ..native import resolved_compiler
from ..ocp.obstacles import convex_pieces
from ..ocp.reference import PathReference
from ..ocp.settings import NMPCSettings
from ..solvers.registry import takes_free_initial
from .export import MAX_PIECES, MAX_VERTICES, ExportSpec, copy_package, library_sources, package_files

__all__ = ["ExportedNMPC", "SilReport", "build_package", "run_sil", "sil_settings"]

_REAL = ctypes.c_double


class _Measurement(ctypes.Structure):
    _fields_ = [(name, _REAL) for name in ("x", "y", "yaw", "hitch", "front_steer", "rear_speed")]


class _Pose(ctypes.Structure):
    _fields_ = [(name, _REAL) for name in ("x", "y", "yaw")]


class _Command(ctypes.Structure):
    _fields_ = [("rear_speed", _REAL), ("front_steer", _REAL)]


class _Status(ctypes.Structure):
    _fields_ = [
        ("ok", ctypes.c_int),
        ("stop", ctypes.c_int),
        ("converged", ctypes.c_int),
        ("iterations", ctypes.c_int),
        ("solver_code", ctypes.c_int),
        ("error", ctypes.c_int),
        ("message", ctypes.c_char_p),
        ("solve_time_ns", ctypes.c_longlong),
        ("cost", _REAL),
    ]


#: The error codes of the C API whose message is the in-process controller's status word for word.
_E_SOLVER = 5


#: Compiler flags of the SIL build: the package's Makefile's, with a shared library.
BUILD_FLAGS = ("-std=c99", "-O2", "-Wall", "-Wextra", "-pedantic", "-ffp-contract=off", "-fPIC", "-shared")


def build_package(files: dict[str, str], folder: Path, compiler: str | None = None) -> Path:
    """Write the package ``files`` into ``folder`` and compile its library there; the library's path.

    Raises :class:`InputError` where there is no C compiler or it refuses (its first error line).
    """
    compiler = compiler or resolved_compiler()
    if compiler is None:
        raise InputError("no C compiler found ($CC, else gcc): sil builds the exported package with one")
    copy_package(files, folder)
    library = folder / "libhitchpark_nmpc.so"
    sources = [str(folder / name) for name in library_sources(files)]
    command = [compiler, *BUILD_FLAGS, f"-I{folder / 'include'}", *sources, "-lm", "-o", str(library)]
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    if done.returncode != 0 or not library.is_file():
        first = next((line for line in done.stderr.splitlines() if "error" in line), done.stderr.strip()[:200])
        raise InputError(f"the exported package did not compile: {first}")
    return library


@dataclass
class _Timing:
    """The C step's own times [ns], one per call of ``hitchpark_nmpc_step`` that solved."""

    step_ns: list[int] = field(default_factory=list)
    iterations: list[int] = field(default_factory=list)


class ExportedNMPC(FullNMPC):
    """The exported controller (a compiled package) where the maneuver takes a :class:`FullNMPC`.

    It builds nothing of the in-process controller (no OCP, no solver): each call goes to the C. It parks at
    the goal or tracks a path to it (:meth:`follow`), and keeps clear of a scene (:meth:`keep_clear`) where the
    package has the obstacle OCP (``export --obstacles``).
    """

    def __init__(self, library: Path, vehicle: VehicleTrailer, settings: NMPCSettings):  # no super(): nothing built
        self.vehicle, self.settings = vehicle, settings
        self._lib = ctypes.CDLL(str(library))
        lib = self._lib
        lib.hitchpark_nmpc_workspace_size.restype = ctypes.c_size_t
        lib.hitchpark_nmpc_init.restype = ctypes.c_void_p
        lib.hitchpark_nmpc_init.argtypes = (ctypes.c_void_p, ctypes.c_size_t)
        lib.hitchpark_nmpc_reset.argtypes = (ctypes.c_void_p, _REAL)
        lib.hitchpark_nmpc_step.argtypes = (
            ctypes.c_void_p,
            ctypes.POINTER(_Measurement),
            ctypes.POINTER(_Pose),
            ctypes.POINTER(_Command),
            ctypes.c_int,
            ctypes.POINTER(_Command),
            ctypes.POINTER(_Status),
        )
        lib.hitchpark_nmpc_initial_steer.argtypes = (
            ctypes.c_void_p,
            ctypes.POINTER(_Measurement),
            ctypes.POINTER(_Pose),
            ctypes.POINTER(_REAL),
            ctypes.POINTER(_Status),
        )
        lib.hitchpark_nmpc_prediction.argtypes = (ctypes.c_void_p, ctypes.POINTER(_REAL), ctypes.POINTER(_REAL))
        lib.hitchpark_nmpc_state.argtypes = (ctypes.c_void_p, ctypes.POINTER(_REAL))
        lib.hitchpark_nmpc_follow.argtypes = (ctypes.c_void_p, ctypes.POINTER(_REAL), ctypes.c_int, _REAL, _REAL)
        lib.hitchpark_nmpc_keep_clear.argtypes = (
            ctypes.c_void_p, ctypes.POINTER(_REAL), ctypes.POINTER(ctypes.c_int), ctypes.c_int, _REAL,
        )  # fmt: skip
        lib.hitchpark_nmpc_ease_clearance.argtypes = (ctypes.c_void_p, _REAL)
        lib.hitchpark_nmpc_path_progress.argtypes = (ctypes.c_void_p, ctypes.POINTER(_REAL), ctypes.POINTER(_REAL))
        lib.hitchpark_nmpc_workspace_bound.restype = ctypes.c_size_t
        self.workspace_bytes = int(lib.hitchpark_nmpc_workspace_size())
        self.workspace_bound_bytes = int(lib.hitchpark_nmpc_workspace_bound())
        self._memory = (ctypes.c_double * (self.workspace_bytes // 8 + 1))()
        self._handle = lib.hitchpark_nmpc_init(self._memory, ctypes.sizeof(self._memory))
        if not self._handle:
            raise RuntimeError("hitchpark_nmpc_init refused the workspace")
        assert settings.horizon is not None
        self._n = settings.horizon
        self._states = (_REAL * ((self._n + 1) * 6))()
        self._plan_u = (_REAL * (self._n * 2))()
        self._x0 = (_REAL * 6)()
        self._last_steer = 0.0
        self._clearance_m = self._base_clearance_m = 0.0
        self._reference: PathReference | None = None
        self.paths_followed = 0  # the paths the C was given to track
        self.timing = _Timing()
        self.recorder = None

    def reset(self, front_steer: float = 0.0) -> None:
        self._lib.hitchpark_nmpc_reset(self._handle, float(front_steer))
        self._last_steer = float(front_steer)

    @property
    def reference(self) -> PathReference | None:
        return self._reference

    def follow(self, reference: PathReference | None) -> None:
        """Track ``reference`` (its points, cruise speed and braking) in the C from now on; None: park at the goal."""
        points = np.zeros((0, 5))
        if reference is not None:
            check_instance("reference", reference, PathReference, "hitchpark.control.PathReference(...)")
            if reference.horizon != self._n or reference.dt != float(self.settings.prediction_dt or self.settings.dt):
                raise InputError("the reference's horizon and step are not the exported controller's")
            points = np.ascontiguousarray(reference.points, dtype=float)
            reference.reset()
        flat = (_REAL * max(1, points.size))(*points.ravel())
        code = self._lib.hitchpark_nmpc_follow(self._handle, flat, len(points), reference.speed if reference else 0.0,
                                               2.0 * reference.brake if reference else 0.0)  # fmt: skip
        if code != 0:
            raise InputError(f"the exported controller refused the path ({len(points)} points): code {code}")
        self._reference = reference
        self.paths_followed += reference is not None

    def _progress(self) -> None:
        """The C's nearest point on the path and the axle's distance from it, onto the Python reference (the stage
        gives up on a path strayed from)."""
        if self._reference is not None:
            progress, deviation = _REAL(), _REAL()
            self._lib.hitchpark_nmpc_path_progress(self._handle, ctypes.byref(progress), ctypes.byref(deviation))
            self._reference.progress, self._reference.deviation = float(progress.value), float(deviation.value)

    def keep_clear(self, scene: Scene, clearance_m: float) -> None:
        """Keep ``clearance_m`` from ``scene`` in the C from now on (its convex pieces, as the in-process OCP cuts
        it); a package exported without the obstacle OCP refuses a scene."""
        check_range("clearance_m", clearance_m, 0.0, 10.0, unit="m")
        pieces = convex_pieces(scene) if self.settings.obstacle_planes > 0 else []
        counts = (ctypes.c_int * max(1, len(pieces)))(*[len(p) for p in pieces])
        flat = np.concatenate([np.asarray(p, dtype=float).ravel() for p in pieces]) if pieces else np.zeros(1)
        vertices = (_REAL * len(flat))(*flat)
        code = self._lib.hitchpark_nmpc_keep_clear(self._handle, vertices, counts, len(pieces), float(clearance_m))
        if code != 0:
            largest = max((len(p) for p in pieces), default=0)
            too_large = len(pieces) > MAX_PIECES or largest > MAX_VERTICES  # else: a package without the OCP
            why = (
                f"it takes at most {MAX_PIECES} convex pieces of at most {MAX_VERTICES} vertices each, this scene "
                f"has {len(pieces)}, the largest of {largest}"
                if too_large
                else "it was exported without the obstacle OCP (export --obstacles)"
            )
            raise InputError(f"the exported controller refused the scene: {why}")
        self._clearance_m = self._base_clearance_m = float(clearance_m)

    def ease_clearance(self, clearance_m: float) -> None:
        self._lib.hitchpark_nmpc_ease_clearance(self._handle, float(clearance_m))
        self._clearance_m = min(self._base_clearance_m, float(clearance_m))

    @staticmethod
    def _inputs(measurement: Measurement, goal: Pose) -> tuple[_Measurement, _Pose]:
        s = measurement.state
        m = _Measurement(s.x, s.y, s.yaw, s.hitch, measurement.front_steer, measurement.rear_speed)
        return m, _Pose(goal.x, goal.y, goal.yaw)

    def _plan(self, x0: Any = None, free_steer: bool = False) -> ControlStep:  # the C plans
        raise NotImplementedError

    def _prediction(self) -> tuple[np.ndarray, np.ndarray]:
        self._lib.hitchpark_nmpc_prediction(self._handle, self._states, self._plan_u)
        states = np.array(self._states[:], dtype=float).reshape(self._n + 1, 6)
        return states, np.array(self._plan_u[:], dtype=float).reshape(self._n, 2)

    def initial_steer(self, measurement: Measurement, goal: Pose) -> float | None:
        m, g = self._inputs(measurement, check_goal(goal))
        steer, status = _REAL(), _Status()
        code = self._lib.hitchpark_nmpc_initial_steer(self._handle, m, g, ctypes.byref(steer), ctypes.byref(status))
        self._progress()
        if code in (0, _E_SOLVER, 6, 7, 8):  # it solved, well or not: the controller was reset to the steer
            self._last_steer = float(measurement.front_steer)
        return float(steer.value) if code == 0 else None

    def act(self, measurement: Measurement, goal: Pose, in_flight: Sequence[Command] = ()) -> ControlStep:
        m, g = self._inputs(measurement, check_goal(goal))
        commands = (_Command * max(1, len(in_flight)))(*[_Command(c.rear_speed, c.front_steer) for c in in_flight])
        out, status = _Command(), _Status()
        code = self._lib.hitchpark_nmpc_step(self._handle, m, g, commands, len(in_flight), out, ctypes.byref(status))
        if code in (1, 2, 9):  # a misuse of the API, not a controller's answer
            raise RuntimeError(f"hitchpark_nmpc_step: {status.message.decode()}")
        self._progress()
        states, inputs = self._prediction()
        self._last_steer = float(out.front_steer)
        cost, ms = float(status.cost), status.solve_time_ns / 1e6
        if code == 0:
            self.timing.step_ns.append(int(status.solve_time_ns))
            self.timing.iterations.append(int(status.iterations))
            self._lib.hitchpark_nmpc_state(self._handle, self._x0)
            hitch, speed, steer = float(self._x0[3]), float(out.rear_speed), float(out.front_steer)
            return ControlStep(
                trailer_speed=float(trailer_speed_from_rear_speed(self.vehicle, hitch, speed, steer)),
                virtual_steer=float(virtual_steer_from_front(self.vehicle, hitch, steer)),
                rear_speed=speed,
                front_steer=steer,
                ok=True,
                stop=bool(status.stop),
                status="Solve_Succeeded",
                cost=cost,
                solve_ms=ms,
                predicted_states=states,
                predicted_inputs=inputs,
            )
        why = f"not converged (code {status.solver_code})" if code == _E_SOLVER else status.message.decode()
        return ControlStep(
            trailer_speed=0.0,
            virtual_steer=0.0,
            rear_speed=0.0,
            front_steer=float(out.front_steer),
            ok=False,
            stop=True,
            status=why,
            cost=cost,
            solve_ms=ms,
            predicted_states=states,
            predicted_inputs=inputs,
        )


def sil_settings(
    settings: ManeuverSettings, nmpc: NMPCSettings | None = None, process: str | None = None
) -> ManeuverSettings:
    """A scenario's maneuver settings as SIL runs them: the full-model NMPC (``nmpc``, else the scenario's when it
    is of the full kind, else the defaults) as the package holds it, without a fallback solver (the package has
    no IPOPT: where its solver fails it retries from the cold start, and so does the in-process controller
    without one). ``process``: ``"staged"`` or ``"planned"``; default the scenario's, which for the paper's
    scenarios (their NMPC the paper's) is the paper's staged process."""
    if process is None:
        process = settings.process.resolved(settings.nmpc.kind)
    check_choice("process", process, ("staged", "planned"))
    if nmpc is None:
        nmpc = settings.nmpc if settings.nmpc.kind == "full" else NMPCSettings()
    nmpc = replace(nmpc, fallback_solver=None)
    return replace(settings, nmpc=nmpc, process=replace(settings.process, kind=process))


#: The columns compared: the commands, and the true state.
COMMAND_COLUMNS = ("rear_speed_cmd", "front_steer_cmd")
STATE_COLUMNS = ("x_trailer", "y_trailer", "yaw_trailer", "hitch", "front_steer", "rear_speed")


@dataclass(frozen=True)
class SilReport:
    """One scenario driven by both controllers, side by side (:meth:`to_dict` is ``hitchpark sil``'s JSON)."""

    scenario: str
    plant: dict[str, Any]
    exported: dict[str, Any]
    in_process: dict[str, Any]
    same_outcome: bool
    rows: tuple[int, int]
    max_command_difference: float
    max_state_difference: float
    step_time_ns: dict[str, float]
    python_step_ms: dict[str, float]
    ipopt_step_ms: dict[str, float] | None
    workspace_bytes: int
    workspace_bound_bytes: int
    library_bytes: int
    steps: int
    paths_followed: int

    def ratios(self) -> dict[str, float]:
        """The in-process routes' median step time over the C step's: the Python route (the same solver, driven
        from Python) and IPOPT (the reference solver, in-process)."""
        c_ms = self.step_time_ns["median"] / 1e6
        out = {"python_over_c": self.python_step_ms["median"] / c_ms}
        if self.ipopt_step_ms is not None:
            out["ipopt_over_c"] = self.ipopt_step_ms["median"] / c_ms
        return out

    def to_dict(self) -> dict[str, Any]:
        return {
            "format": "hitchpark-sil/1",
            "scenario": self.scenario,
            "plant": self.plant,
            "exported": self.exported,
            "in_process": self.in_process,
            "same_outcome": self.same_outcome,
            "rows": {"exported": self.rows[0], "in_process": self.rows[1]},
            "max_command_difference": self.max_command_difference,
            "max_state_difference": self.max_state_difference,
            "c_step_time_ns": self.step_time_ns,
            "python_step_ms": self.python_step_ms,
            "ipopt_step_ms": self.ipopt_step_ms,
            "step_time_ratios": self.ratios(),
            "c_steps": self.steps,
            "paths_followed": self.paths_followed,
            "workspace_bytes": self.workspace_bytes,
            "workspace_bound_bytes": self.workspace_bound_bytes,
            "library_bytes": self.library_bytes,
        }


def _summary(result: ManeuverResult) -> dict[str, Any]:
    x, y = _column(result, "x_trailer")[-1], _column(result, "y_trailer")[-1]
    return {
        "outcome": result.reason,
        "success": bool(result.success),
        "stages": len(result.stages),
        "stage_ends": [st.reason for st in result.stages],
        "final_error_m": float(math.hypot(x - result.goal.x, y - result.goal.y)),
        "duration_s": float(result.duration),
    }


def _column(result: ManeuverResult, name: str) -> np.ndarray:
    return np.asarray(result.trajectory[name], dtype=float)


def _solve_ms(result: ManeuverResult) -> np.ndarray:
    """The NMPC's time of each step it solved [ms] (its rows of ``solve_ms``)."""
    ms = _column(result, "solve_ms")
    return ms[np.isfinite(ms)]


def _largest(a: ManeuverResult, b: ManeuverResult, columns: Sequence[str]) -> float:
    """The largest difference over the rows both have (inf where one has a NaN the other has not)."""
    worst = 0.0
    for name in columns:
        x, y = _column(a, name), _column(b, name)
        n = min(len(x), len(y))
        x, y = x[:n], y[:n]
        same_nan = np.isnan(x) & np.isnan(y)
        diff = np.where(same_nan, 0.0, np.abs(x - y))
        if n:
            worst = max(worst, float(np.nanmax(np.where(np.isnan(diff), np.inf, diff))))
    return worst


def _percentiles(values: Sequence[float]) -> dict[str, float]:
    if not values:
        return {"median": math.nan, "p99": math.nan, "max": math.nan}
    v = np.asarray(values, dtype=float)
    return {"median": float(np.median(v)), "p99": float(np.percentile(v, 99)), "max": float(v.max())}


def run_sil(
    scenario: Scenario,
    plant: PlantSettings | None = None,
    nmpc: NMPCSettings | None = None,
    controller: FullNMPC | None = None,
    scratch: Path | None = None,
    library: Path | None = None,
    ipopt: bool = True,
    process: str | None = None,
) -> SilReport:
    """Park ``scenario`` with the exported controller and with the in-process one, and compare.

    ``plant``: the car driven (default: the scenario's). ``nmpc``: the NMPC settings (default: :func:`sil_settings`'s).
    ``controller``: a ready in-process controller of those settings to reuse. ``scratch``: where to build (default: a
    temporary folder, removed after). ``library``: a build of this vehicle's and these settings' package to use
    (:func:`build_package`; among obstacles, one exported with them) instead of building one. A scene of obstacles
    is driven with the obstacle OCP (the package built ``--obstacles``). ``ipopt``: park a third time with IPOPT
    in-process, for its step time (the reference the project's speed is measured against). ``process``: ``"staged"`` or
    ``"planned"`` (default: :func:`sil_settings`'s); planned, the NMPC tracks the planner's path (the tracking OCP).

    Raises :class:`InputError` where the in-process controller would not run hitchpark's compiled solver
    (``HITCHPARK_JIT=0``, no compiler): there is then nothing to compare the C with.
    """
    settings = sil_settings(scenario.settings, nmpc, process)
    plant = plant or scenario.plant
    obstacles = not scenario.scene.is_empty and settings.nmpc.obstacle_planes > 0
    spec = ExportSpec(
        scenario.vehicle, settings.nmpc, scenario.start, scenario.goal, plant, scenario.name, obstacles=obstacles
    )
    files = package_files(spec)
    in_process = controller or FullNMPC(scenario.vehicle, settings.nmpc)
    if not takes_free_initial(in_process.solver):
        raise InputError("the in-process controller does not run the compiled riccati_c here (HITCHPARK_JIT=0?)")
    with tempfile.TemporaryDirectory(dir=scratch) as folder:
        built = library or build_package(files, Path(folder) / "package")
        exported = ExportedNMPC(built, scenario.vehicle, settings.nmpc)
        library_bytes = built.stat().st_size
        c_result = park(scenario.vehicle, scenario.start, scenario.goal, settings, scenario.name, exported, plant,
                        scenario.scene)  # fmt: skip
    py_result = park(scenario.vehicle, scenario.start, scenario.goal, settings, scenario.name, in_process, plant,
                     scenario.scene)  # fmt: skip
    ipopt_ms = None
    if ipopt:
        reference = replace(settings, nmpc=replace(settings.nmpc, solver="ipopt"))
        ipopt_result = park(scenario.vehicle, scenario.start, scenario.goal, reference, scenario.name, plant=plant,
                            scene=scenario.scene)  # fmt: skip
        ipopt_ms = _percentiles(list(_solve_ms(ipopt_result)))
    return SilReport(
        scenario=scenario.name,
        plant=plant.to_dict(),
        exported=_summary(c_result),
        in_process=_summary(py_result),
        same_outcome=c_result.reason == py_result.reason and len(c_result.stages) == len(py_result.stages),
        rows=(len(_column(c_result, "t")), len(_column(py_result, "t"))),
        max_command_difference=_largest(c_result, py_result, COMMAND_COLUMNS),
        max_state_difference=_largest(c_result, py_result, STATE_COLUMNS),
        step_time_ns=_percentiles(exported.timing.step_ns),
        python_step_ms=_percentiles(list(_solve_ms(py_result))),
        ipopt_step_ms=ipopt_ms,
        workspace_bytes=exported.workspace_bytes,
        workspace_bound_bytes=exported.workspace_bound_bytes,
        library_bytes=library_bytes,
        steps=len(exported.timing.step_ns),
        paths_followed=exported.paths_followed,
    )
