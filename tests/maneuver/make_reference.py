"""Regenerate ``reference.json`` beside this file: the four built-in scenarios' outcomes.

Run ``python tests/maneuver/make_reference.py`` after a deliberate change of the
controller or the process, look at the diff, and commit it with the change. The
regression tests (``test_regression.py``) compare fresh runs against this file
with tolerances meant to survive another CasADi/NumPy build.

The tests import :func:`builtin_results` and :func:`record` from here, so the
reference and the comparison describe a run the same way, and every test module
shares one run of each scenario.
"""

from __future__ import annotations

import functools
import sys
from pathlib import Path
from typing import Any

import casadi
import numpy

from hitchpark.app.report import run_scenario
from hitchpark.io import write_json
from hitchpark.maneuver import ManeuverResult, builtin_scenarios

REFERENCE_PATH = Path(__file__).with_name("reference.json")

STAGE_FIELDS = ("kind", "steps", "distance_error_m", "orientation_error_deg", "final_hitch_deg")


@functools.cache
def builtin_results() -> dict[str, ManeuverResult]:
    """The four built-in scenarios parked once per process, by name, in the paper's order."""
    return {sc.name: run_scenario(sc) for sc in builtin_scenarios()}


def record(result: ManeuverResult) -> dict[str, Any]:
    """What the reference keeps of one maneuver."""
    return {
        "success": result.success,
        "reason": result.reason,
        "duration_s": result.duration,
        "stages": [{k: getattr(st, k) for k in STAGE_FIELDS} for st in result.stages],
    }


def main() -> int:
    data = {
        "generated_with": {"casadi": casadi.__version__, "numpy": numpy.__version__},
        "scenarios": {name: record(r) for name, r in builtin_results().items()},
    }
    write_json(REFERENCE_PATH, data)
    for name, entry in data["scenarios"].items():
        last = entry["stages"][-1]
        print(
            f"{name}: {entry['reason']}, {len(entry['stages'])} stages, {entry['duration_s']:.1f} s, "
            f"final {1e3 * last['distance_error_m']:.3f} mm / {last['orientation_error_deg']:.4f} deg"
        )
    print(f"wrote {REFERENCE_PATH}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
