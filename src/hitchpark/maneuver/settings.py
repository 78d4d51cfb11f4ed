"""The settings that shape a maneuver: its controllers, its process, and what counts as success.

:class:`ManeuverSettings` gathers them, one table each in a file (``[nmpc]``, ``[forward]``,
``[success]``, ``[process]``, ``[tracking]``, ``[planner]``, ``[estimator]``); :meth:`ManeuverSettings.from_dict` is
the one reader of those tables.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any

from ..checks import Choice, Flag, Integer, Real, build, check_fields, check_keys, check_mapping, checked
from ..control.estimator import EstimatorSettings
from ..control.path_tracking import TrackingSettings
from ..control.pure_pursuit import PurePursuitSettings
from ..ocp.settings import NMPCSettings
from ..planning import PlannerSettings
from ..planning.settings import START_MARGIN_M

__all__ = [
    "MAX_MANEUVER_TIME",
    "PROCESS_KINDS",
    "SETTINGS_TABLES",
    "ManeuverSettings",
    "ProcessSettings",
    "SuccessCriteria",
]

#: What ``process.kind`` can be: ``"staged"`` reverses, repositions forward and reverses again (Fig. 7);
#: ``"planned"`` plans a path among the obstacles and tracks it (:mod:`~hitchpark.maneuver.planned`);
#: ``"auto"`` plans with the full-model NMPC and stages with the paper's.
PROCESS_KINDS = ("auto", "staged", "planned")


#: Longest maneuver time accepted [s]: a day; a parking maneuver takes a minute.
MAX_MANEUVER_TIME = 86_400.0


@dataclass(frozen=True)
class SuccessCriteria:
    """Success, defined once: final errors within these, limits never exceeded, within stages and time.

    distance [m] (trailer axle to goal), orientation [rad] (trailer yaw error),
    hitch [rad] (final |hitch|), max_stages, max_time [s] of maneuver time, min_clearance_m [m]: the
    least clearance between the bodies and the scene's obstacles and area boundary over the whole motion
    (swept, :func:`~hitchpark.model.collision.swept_clearance`); it does not apply to an empty scene.
    """

    distance: float = checked(0.05, Real(0.0, 100.0, low_open=True, unit="m"))
    orientation: float = checked(math.radians(0.5), Real(0.0, math.pi, low_open=True, unit="rad"))
    hitch: float = checked(math.radians(3.0), Real(0.0, math.pi / 2, low_open=True, unit="rad"))
    max_stages: int = checked(7, Integer(1, 1000))
    max_time: float = checked(300.0, Real(0.0, MAX_MANEUVER_TIME, low_open=True, unit="s (a day)"))
    min_clearance_m: float = checked(0.2, Real(0.0, 5.0, unit="m"))

    def __post_init__(self) -> None:
        check_fields(self, "success.")


@dataclass(frozen=True)
class ProcessSettings:
    """How the stages of a maneuver are chosen.

    Parameters
    ----------
    kind : str
        One of :data:`PROCESS_KINDS`.
    max_replans : int
        A planned maneuver plans again (from where the car stopped) at most this many times after the first
        plan: when the car strays from the path, comes too close to an obstacle, or ends a path unparked.
    approach_m : float
        The path is planned to end on the goal line between ``handover_m`` and this far out [m], heading
        along it, the hitch straight; a straight reverse along the line follows, to the goal (halved until
        it keeps clear of the scene). The NMPC parks best from a straight approach, as after the paper's
        forward stage.
    handover_m : float
        Without ``nmpc_tracking``, the last reverse segment is tracked by pure pursuit until this much of
        it is left to the goal [m]; the NMPC parks the rest.
    nmpc_tracking : bool
        The full NMPC tracks the whole last reverse segment to the goal (its tracking OCP, the plan as
        reference, :class:`~hitchpark.ocp.reference.PathReference`).
    plan_margin_m : float
        The planner keeps ``success.min_clearance_m`` plus this [m]: room for the tracking error.
    guard_margin_m : float
        The guard stops the car when a body is within ``success.min_clearance_m`` plus this of the scene,
        now or over the NMPC's prediction, and slows it so that it can stop before [m].
    """

    kind: str = checked("auto", Choice(PROCESS_KINDS))
    max_replans: int = checked(4, Integer(0, 100))
    approach_m: float = checked(8.0, Real(0.0, 100.0, unit="m"))
    handover_m: float = checked(4.0, Real(0.0, 100.0, unit="m"))
    nmpc_tracking: bool = checked(True, Flag())
    plan_margin_m: float = checked(0.1, Real(0.0, 5.0, unit="m"))
    guard_margin_m: float = checked(0.03, Real(0.0, 5.0, unit="m"))

    def __post_init__(self) -> None:
        check_fields(self, "process.")

    def resolved(self, nmpc_kind: str) -> str:
        """``"staged"`` or ``"planned"``: ``auto`` plans with the full-model NMPC, stages with the paper's."""
        if self.kind != "auto":
            return self.kind
        return "planned" if nmpc_kind == "full" else "staged"


@dataclass(frozen=True)
class ManeuverSettings:
    """Everything that shapes a maneuver besides the vehicle, start and goal."""

    nmpc: NMPCSettings = field(default_factory=NMPCSettings)
    forward: PurePursuitSettings = field(default_factory=PurePursuitSettings)
    success: SuccessCriteria = field(default_factory=SuccessCriteria)
    process: ProcessSettings = field(default_factory=ProcessSettings)
    tracking: TrackingSettings = field(default_factory=TrackingSettings)
    planner: PlannerSettings = field(default_factory=PlannerSettings)
    estimator: EstimatorSettings = field(default_factory=EstimatorSettings)

    @property
    def guard_clearance_m(self) -> float:
        """Nearer the scene than this [m] the guard stops the car: ``success.min_clearance_m +
        process.guard_margin_m``. A planned path keeps at least this (from a start nearer than the planner's
        clearance, what the start keeps)."""
        return self.success.min_clearance_m + self.process.guard_margin_m

    @property
    def start_clearance_m(self) -> float:
        """How far [m] a start among obstacles must be from them to move away: :attr:`guard_clearance_m` and the
        planner's margin for a start (:data:`~hitchpark.planning.settings.START_MARGIN_M`). A sweep's starts keep
        this much."""
        return self.guard_clearance_m + START_MARGIN_M

    def to_dict(self) -> dict[str, Any]:
        return {name: asdict(getattr(self, name)) for name in SETTINGS_TABLES}

    @classmethod
    def from_dict(cls, data: Any) -> ManeuverSettings:
        """From the tables of :data:`SETTINGS_TABLES` (each optional; unknown keys refused)."""
        tables = check_keys("settings", data, SETTINGS_TABLES, "table [{}]")
        nmpc = tables.get("nmpc", {})
        if "solver_options" in check_mapping("[nmpc]", nmpc):
            nmpc = {**nmpc, "solver_options": dict(check_mapping("nmpc.solver_options", nmpc["solver_options"]))}
        return cls(
            nmpc=build(NMPCSettings, nmpc, "nmpc", convert={k: _listed for k in ("Q", "R", "P")}),
            forward=build(PurePursuitSettings, tables.get("forward", {}), "forward"),
            success=build(SuccessCriteria, tables.get("success", {}), "success"),
            process=build(ProcessSettings, tables.get("process", {}), "process"),
            tracking=build(TrackingSettings, tables.get("tracking", {}), "tracking"),
            planner=build(PlannerSettings, tables.get("planner", {}), "planner"),
            estimator=build(EstimatorSettings, tables.get("estimator", {}), "estimator"),
        )


def _listed(value: Any) -> Any:
    """A TOML or JSON list as the tuple a settings field holds."""
    return tuple(value) if isinstance(value, list) else value


#: The tables of maneuver settings in a file.
SETTINGS_TABLES = ("nmpc", "forward", "success", "process", "tracking", "planner", "estimator")
