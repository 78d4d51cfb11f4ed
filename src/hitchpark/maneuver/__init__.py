"""The parking maneuver: the 3-stage process (Fig. 7), scenarios (Section 6.1) and their reports."""

from .process import (
    MANEUVER_COLUMNS,
    ManeuverResult,
    ManeuverSettings,
    StageResult,
    SuccessCriteria,
    park,
)
from .report import reproduce, run_scenario, save_maneuver, table5
from .scenario import Scenario, builtin_scenarios, load_scenario

__all__ = [
    "MANEUVER_COLUMNS",
    "ManeuverResult",
    "ManeuverSettings",
    "Scenario",
    "StageResult",
    "SuccessCriteria",
    "builtin_scenarios",
    "load_scenario",
    "park",
    "reproduce",
    "run_scenario",
    "save_maneuver",
    "table5",
]
