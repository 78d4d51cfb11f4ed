"""The exported controller where the maneuver takes a :class:`~hitchpark.control.nmpc.FullNMPC` (``hitchpark sil``).

:func:`build_package` compiles a package (:mod:`.export`) in a scratch folder with the system's C compiler into a
shared library (:func:`cached_package_library`: once, into hitchpark's compile cache); :class:`ExportedNMPC` drives
that library through :mod:`ctypes`: parking, tracking the planner's path, keeping clear of a scene, every call going
to the C.
"""

from __future__ import annotations

import ctypes
import hashlib
import json
import math
import os
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
from ..maneuver.result import ManeuverSettings
from ..model.inverse import virtual_steer_from_front
from ..model.kinematics import trailer_speed_from_rear_speed
from ..model.plant import Command, Measurement, PlantSettings
from ..model.scene import Scene
from ..model.state import Pose, check_goal
from ..model.vehicle import VehicleTrailer
from ..native import cached_library, resolved_compiler
from ..ocp.obstacles import convex_pieces
from ..ocp.reference import PathReference
from ..ocp.settings import NMPCSettings
from .export import MAX_PIECES, MAX_VERTICES, ExportSpec, library_sources, package_files
from .export_folder import copy_package

__all__ = [
    "BUILD_FLAGS",
    "ExportedNMPC",
    "build_package",
    "cached_package_library",
    "exported_controller_library",
    "sil_settings",
]

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
_REFUSED = (3, 4)  # the measurement not finite, the hitch past its limit: refused before any solve


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


def cached_package_library(files: dict[str, str]) -> Path | None:
    """The library of the package ``files`` from hitchpark's compile cache (:mod:`hitchpark.native`): built once by
    :func:`build_package` for these sources (those of ``src/`` and ``include/``: not the example's start), this
    compiler and :data:`BUILD_FLAGS`, then loaded from there by every run and process. None where nothing is cached
    (compilation switched off, no compiler) or the package does not compile (:func:`build_package` says why)."""
    compiled = {name: text for name, text in sorted(files.items()) if name.startswith(("src/", "include/"))}
    described = json.dumps([compiled, BUILD_FLAGS, resolved_compiler()], sort_keys=True)
    key = hashlib.sha256(described.encode()).hexdigest()[:24]

    def build(compiler: str, home: Path, library: Path) -> bool:
        with tempfile.TemporaryDirectory(dir=home) as scratch:
            try:
                built = build_package(files, Path(scratch) / "package", compiler)
            except InputError:
                return False
            os.replace(built, library)
        return True

    return cached_library("hitchpark_nmpc", key, build)


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


def exported_controller_library(
    vehicle: VehicleTrailer, settings: ManeuverSettings, goal: Pose, plant: PlantSettings | None, scene: Scene
) -> tuple[ManeuverSettings, Path]:
    """The settings and the library with which the exported controller drives maneuvers of ``settings``
    (``hitchpark sweep --exported``): the full-model NMPC as ``hitchpark sil`` runs it, without a fallback solver
    (:func:`sil_settings`), its package built once into the compile cache, with the
    obstacle OCP where there is a scene. Raises :class:`InputError` where it cannot be: settings of another NMPC
    than the full model's, or nothing compiles here (no C compiler, compilation switched off)."""
    if settings.nmpc.kind != "full":
        kind = settings.nmpc.kind
        raise InputError(f"--exported drives the full-model NMPC (nmpc.kind 'full'), got nmpc.kind {kind!r}")
    settings = sil_settings(settings)
    nmpc = settings.nmpc
    obstacles = not scene.is_empty and nmpc.obstacle_planes > 0
    plant = plant or PlantSettings()
    spec = ExportSpec(vehicle, nmpc, goal=goal, plant=plant, scenario="sweep", obstacles=obstacles)
    library = cached_package_library(package_files(spec))
    if library is None:
        raise InputError(
            "--exported builds the exported package into hitchpark's compile cache: no C compiler here ($CC, else "
            "gcc), compilation switched off (HITCHPARK_JIT=0), or the package did not compile"
        )
    return settings, library


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
        lib.hitchpark_nmpc_hold_clearance.argtypes = (ctypes.c_void_p, _REAL)
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

    def hold_clearance(self, clearance_m: float) -> None:
        check_range("clearance_m", clearance_m, 0.0, 10.0, unit="m")
        self._lib.hitchpark_nmpc_hold_clearance(self._handle, float(clearance_m))
        self._clearance_m = float(clearance_m)

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
        if code in _REFUSED:  # no solve: no plan, no cost, no time (as FullNMPC's refusal)
            states, inputs, cost, ms = np.full_like(states, np.nan), np.full_like(inputs, np.nan), math.nan, 0.0
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
