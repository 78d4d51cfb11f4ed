"""``hitchpark sil``: the exported C controller in the loop, beside the in-process one.

:func:`run_sil` builds the exported package and drives it where the maneuver expects a
:class:`~hitchpark.control.nmpc.FullNMPC` (:class:`~.exported.ExportedNMPC`): it parks the same scenario twice,
with the exported controller and with the in-process one, on hitchpark's plant, and compares them row by row
(:class:`SilReport`). Both run the scenario's process (the paper's scenarios the staged one, the others the
planned one); what is not the NMPC (the planner, the forward stages, the guard) is the same Python in both.
"""

from __future__ import annotations

import math
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..checks import InputError
from ..control.nmpc import FullNMPC
from ..maneuver.process import park
from ..maneuver.result import ManeuverResult
from ..maneuver.scenario import Scenario
from ..model.plant import PlantSettings
from ..ocp.settings import NMPCSettings
from ..solvers.registry import takes_free_initial
from .export import ExportSpec, package_files
from .exported import ExportedNMPC, build_package, cached_package_library, sil_settings

__all__ = ["ExportedNMPC", "SilReport", "build_package", "run_sil", "sil_settings"]


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
    ``controller``: a ready in-process controller of those settings to reuse. The package is built once into
    hitchpark's compile cache (:func:`cached_package_library`), where one is; else in ``scratch`` (default: a
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
        built = library or cached_package_library(files) or build_package(files, Path(folder) / "package")
        exported = ExportedNMPC(built, scenario.vehicle, settings.nmpc)
        library_bytes = built.stat().st_size
        c_result = park(scenario.vehicle, scenario.start, scenario.goal, settings, scenario.name, exported, plant,
                        scenario.scene)  # fmt: skip
    py_result = park(scenario.vehicle, scenario.start, scenario.goal, settings, scenario.name, in_process, plant,
                     scenario.scene)  # fmt: skip
    ipopt_ms = None
    if ipopt:
        # IPOPT with its own options: the package's solver options (riccati_c's) are not IPOPT's.
        reference = replace(settings, nmpc=replace(settings.nmpc, solver="ipopt", solver_options={}))
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
