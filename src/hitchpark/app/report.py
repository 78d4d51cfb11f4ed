"""Running scenarios and reporting them: Table 5, ``summary.json``, saved maneuvers, figures on request.

Figures are drawn by a renderer the caller gives (the command line gives
:func:`hitchpark.viz.maneuver.render_maneuver`): this layer draws nothing.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..checks import InputError, check_choice
from ..io import StagedFolder, write_json
from ..maneuver.process import park
from ..maneuver.result import ManeuverResult
from ..maneuver.scenario import (
    BUILTIN_ORDER,
    OBSTACLE_SUITE,
    PLACES_SUITE,
    Scenario,
    builtin_scenario,
    builtin_scenarios,
)
from ..model.plant import PlantSettings
from .records import trailer_path_length
from .workers import WorkerPool

__all__ = [
    "ANIMATION_FILE",
    "FIGURE_FILES",
    "MANEUVER_FILES",
    "PAPER_TABLE5",
    "SUITES",
    "VIEWER_FILE",
    "Render",
    "reproduce",
    "run_scenario",
    "save_maneuver",
    "suite_scenarios",
    "suite_table",
    "summary_entry",
    "table5",
]

#: The files of one maneuver: the figures (``plot_maneuver``), the animation, and all a saved maneuver
#: may hold. A command owns these names in its output folder: it replaces them, and removes those it
#: does not write this time (figures of an earlier run with figures).
FIGURE_FILES = ("motion.png", "inputs.png", "nmpc.png")
ANIMATION_FILE = "maneuver.gif"
VIEWER_FILE = "maneuver.html"  # the viewer (hitchpark.viz.viewer): one page that opens offline
MANEUVER_FILES = ("maneuver.json", "trajectory.csv", *FIGURE_FILES, ANIMATION_FILE, VIEWER_FILE)

#: Frames of a maneuver's GIF (a ~40 s maneuver plays at about 2.5x real time at 10 fps).
ANIMATION_FRAMES = 150

#: The paper's Table 5: stage 1 and stage 3 (distance [m], orientation [deg], final hitch [deg]).
PAPER_TABLE5 = {
    "parallel": ((0.0525, 0.4976, 11.0584), (0.0033, 0.0319, 0.6667)),
    "parallel_hitch": ((0.9201, -8.6355, -33.0678), (4.4619e-4, 0.0044, 0.0964)),
    "perpendicular": ((0.4134, 4.1443, 30.2587), (0.0011, 0.0114, 0.2324)),
    "random": ((0.0846, -0.6137, -15.2986), (0.0049, -0.0495, -0.9789)),
}


#: The suites ``reproduce --suite`` runs, by name: the paper's four, the scenes of obstacles, and the places.
SUITES = {"paper": BUILTIN_ORDER, "obstacles": OBSTACLE_SUITE, "places": PLACES_SUITE}


def suite_scenarios(name: str, what: str = "suite") -> list[Scenario]:
    """The built-in scenarios of the suite ``name`` (a key of :data:`SUITES`), in order."""
    check_choice(what, name, SUITES)
    if name == "paper":
        return builtin_scenarios()
    return [builtin_scenario(scene) for scene in SUITES[name]]


def run_scenario(scenario: Scenario, plant: PlantSettings | None = None) -> ManeuverResult:
    """Park from the scenario's start with its vehicle, settings and plant (or ``plant`` instead)."""
    return park(
        scenario.vehicle,
        scenario.start,
        scenario.goal,
        scenario.settings,
        name=scenario.name,
        plant=plant or scenario.plant,
        scene=scenario.scene,
    )


#: Draws a maneuver's figures into a folder and returns their paths by name
#: (:func:`hitchpark.viz.maneuver.render_maneuver`, given the switches it needs).
Render = Callable[[ManeuverResult, Path], dict[str, Path]]


def save_maneuver(result: ManeuverResult, folder: Path, render: Render | None = None) -> dict[str, Path]:
    """Write ``maneuver.json`` and ``trajectory.csv`` into ``folder``, and what ``render`` draws if given.

    Returns the paths by name. The CSV holds the trajectory columns alone, for tools that read tables.
    """
    folder.mkdir(parents=True, exist_ok=True)
    files = {"maneuver": write_json(folder / "maneuver.json", result.to_dict())}
    result.trajectory.to_csv(folder / "trajectory.csv")
    files["trajectory"] = folder / "trajectory.csv"
    if render is not None:
        files.update(render(result, folder))
    return files


def summary_entry(result: ManeuverResult, file: str) -> dict[str, Any]:
    """One scenario's record in ``summary.json``."""
    solve = result.trajectory["solve_ms"]
    solve = solve[np.isfinite(solve)]
    return {
        "name": result.name,
        "file": file,
        "success": result.success,
        "reason": result.reason,
        "duration_s": result.duration,
        "stages": [
            {
                "kind": s.kind,
                "steps": s.steps,
                "distance_error_m": s.distance_error_m,
                "orientation_error_deg": s.orientation_error_deg,
                "final_hitch_deg": s.final_hitch_deg,
            }
            for s in result.stages
        ],
        "max_abs_front_steer_deg": result.max_abs_front_steer_deg,
        "max_abs_hitch_deg": result.max_abs_hitch_deg,
        "path_length_m": trailer_path_length(result),
        "direction_switches": result.direction_switches,
        "min_clearance_m": result.min_clearance_m,
        "collision": result.collision,
        "planning_s": result.planning_s,
        "solve_ms_mean": float(np.mean(solve)) if solve.size else None,
        "solve_ms_max": float(np.max(solve)) if solve.size else None,
    }


def table5(results: Sequence[ManeuverResult]) -> str:
    """Table 5's rows: stage 1 and the last reverse stage (stage 3 in the paper), the paper's beneath."""
    w = (16, 11, 13, 12)

    def cells(dist: float | None, orient: float | None, hitch: float | None) -> str:
        if dist is None or orient is None or hitch is None:
            return f"{'-':>{w[1]}}{'-':>{w[2]}}{'-':>{w[3]}}"
        return f"{dist:>{w[1]}.4g}{orient:>{w[2]}.4f}{hitch:>{w[3]}.4f}"

    sub = f"{'dist [m]':>{w[1]}}{'orient [deg]':>{w[2]}}{'hitch [deg]':>{w[3]}}"
    lines = [
        f"{'':<{w[0]}}{'stage 1':^{w[1] + w[2] + w[3]}} | {'stage 3 (last reverse)':^{w[1] + w[2] + w[3]}} |",
        f"{'scenario':<{w[0]}}{sub[: w[1] + w[2] + w[3]]} | {sub[: w[1] + w[2] + w[3]]} | stages  result",
    ]
    lines.append("-" * len(lines[1]))
    for r in results:
        reverse = [s for s in r.stages if s.kind == "reverse"]
        row = [f"{r.name:<{w[0]}}"]
        for st in (reverse[0] if reverse else None, reverse[-1] if len(reverse) > 1 else None):
            row.append(
                cells(*(st.distance_error_m, st.orientation_error_deg, st.final_hitch_deg) if st else (None,) * 3)
            )
        lines.append(f"{row[0]}{row[1]} | {row[2]} | {len(r.stages):>6}  {'parked' if r.success else r.reason}")
        if r.name in PAPER_TABLE5:
            p1, p3 = PAPER_TABLE5[r.name]
            lines.append(f"{'  (paper)':<{w[0]}}{cells(*p1)} | {cells(*p3)} |")
    return "\n".join(lines)


def _cell(value: float | None, fmt: str, width: int) -> str:
    return f"{'-' if value is None else format(value, fmt):>{width}}"


def suite_table(results: Sequence[ManeuverResult]) -> str:
    """One row per scene: parked, trailer-axle path length, direction switches, least clearance, planning and
    maneuver time. A failure's reason follows its row; ``-`` where there is nothing to measure (no scene)."""
    head = (
        f"{'scene':<16}{'parked':>8}{'path [m]':>10}{'switches':>10}{'min clear [m]':>15}{'planning [s]':>14}"
        f"{'maneuver [s]':>14}"
    )
    lines = [head, "-" * len(head)]
    for r in results:
        row = (
            f"{r.name:<16}{'yes' if r.success else 'no':>8}{_cell(trailer_path_length(r), '.2f', 10)}"
            f"{r.direction_switches:>10}{_cell(r.min_clearance_m, '.3f', 15)}{_cell(r.planning_s, '.2f', 14)}"
            f"{_cell(r.duration, '.1f', 14)}"
        )
        if not r.success:
            row += f"  {r.reason}" + (f" ({r.detail})" if r.detail else "")
        lines.append(row)
    return "\n".join(lines)


def reproduce(
    out: str | Path,
    scenarios: Sequence[Scenario] | None = None,
    render: Render | None = None,
    progress: Callable[[str], None] | None = None,
    workers: int | None = None,
    plant: PlantSettings | None = None,
) -> tuple[list[ManeuverResult], Path]:
    """Run the scenarios (default: the paper's four), save each, and write ``out/summary.json``.

    Returns the results and the path of the summary. Each scenario's files go to
    ``out/<name>/``, beside ``summary.json``. Everything is built in a staging folder and
    published at the end, so an error leaves ``out`` as it was. What ``render`` draws (figures
    and animations, the slow part; it must pickle) is drawn in ``workers`` processes (default: one per
    core, at most one per scenario). ``plant`` replaces the scenarios' own plant (the paper's: ideal).
    """
    out = Path(out)
    scenarios = list(scenarios) if scenarios is not None else builtin_scenarios()
    names = [sc.name for sc in scenarios]
    if len(set(names)) != len(names):
        raise InputError(f"scenario names must differ (each gets a folder), got {names}")
    # Publishing replaces these (removing those not written this time); all else in ``out`` stays.
    owns = ["summary.json", *(f"{name}/{file}" for name in names for file in MANEUVER_FILES)]
    staged = StagedFolder(out, owns)  # an --out that is a file fails here, before any work
    results, entries = [], []
    for sc in scenarios:
        result = run_scenario(sc, plant)
        results.append(result)
        entries.append(summary_entry(result, f"{sc.name}/maneuver.json"))
        if progress:
            final = result.stages[-1]
            progress(
                f"{sc.name}: {'parked' if result.success else 'FAILED (' + result.reason + ')'} in "
                f"{len(result.stages)} stages, {result.duration:.1f} s; "
                f"final error {1e3 * final.distance_error_m:.2f} mm, "
                f"{final.orientation_error_deg:.4f} deg, hitch {final.final_hitch_deg:.3f} deg; "
                f"max |steer| {result.max_abs_front_steer_deg:.2f} deg (limit "
                f"{math.degrees(result.vehicle.max_steer):.2f})"
            )
    with staged as stage:
        folders = [stage / r.name for r in results]
        for r, folder in zip(results, folders, strict=True):
            save_maneuver(r, folder)
        n = max(1, min(workers or os.cpu_count() or 1, len(results)))
        if render is not None and n == 1:
            for r, folder in zip(results, folders, strict=True):
                render(r, folder)
        elif render is not None:
            # Quiet workers: on Ctrl-C or an error they are terminated, not awaited, before the stage goes.
            with WorkerPool(n) as pool:
                jobs = [pool.submit(render, r, f) for r, f in zip(results, folders, strict=True)]
                for job in jobs:
                    job.result()
        write_json(stage / "summary.json", {"scenarios": entries})
    return results, out / "summary.json"
