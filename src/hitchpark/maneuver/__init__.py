"""The parking maneuver: the closed loop (plant, stages, outcome), its result, and scenarios."""

from .planned import prepare_scene
from .process import park
from .result import MANEUVER_COLUMNS, ManeuverResult, Outcome, PlanRecord, StageResult
from .scenario import Scenario, builtin_scenarios, load_scenario
from .settings import ManeuverSettings, ProcessSettings, SuccessCriteria
from .stages import PROCESSES, Stage, make_stages

__all__ = [
    "MANEUVER_COLUMNS",
    "PROCESSES",
    "ManeuverResult",
    "ManeuverSettings",
    "Outcome",
    "PlanRecord",
    "ProcessSettings",
    "Scenario",
    "Stage",
    "StageResult",
    "SuccessCriteria",
    "builtin_scenarios",
    "load_scenario",
    "make_stages",
    "park",
    "prepare_scene",
]
