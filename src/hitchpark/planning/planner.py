"""The planner's entry: :func:`plan` checks its arguments, prepares the scene's structures, and searches
(:class:`~.search.Search`), on a grid twice as fine when a search exhausts a coarse one."""

from __future__ import annotations

import math
import time

from ..checks import InputError, check_instance
from ..model.collision import swept_clearance
from ..model.scene import Scene
from ..model.state import Pose, State, check_goal, check_state
from ..model.vehicle import VehicleTrailer, check_vehicle
from .prepare import prepare
from .reach import GoalReach
from .refine import refine_plan
from .search import Search
from .settings import REFINEMENTS, START_MARGIN_M, Plan, PlannerSettings, finer

__all__ = ["REFINEMENTS", "plan"]


def plan(
    vehicle: VehicleTrailer,
    start: State,
    goal: Pose | None = None,
    scene: Scene | None = None,
    settings: PlannerSettings | None = None,
) -> Plan:
    """A path from ``start`` to within the goal tolerance of ``goal`` that keeps clear of ``scene``.

    Hybrid A* in (x, y, yaw) of the trailer axle and the hitch angle; each expansion integrates
    forward and reverse primitives of the full model (Eqs. 19-24) with the steer within ``max_steer``
    (forward: within :func:`~hitchpark.control.pure_pursuit.forward_steer_limit`, so forward motion
    cannot jackknife), ramping at ``max_steer_rate`` within a direction, and the hitch within
    ``max_hitch - hitch_margin`` at every sample. Collisions are screened with discs on a distance grid
    of the scene; the path found is confirmed by the exact
    :func:`~hitchpark.model.collision.swept_clearance` (a path that fails it is dropped and the search
    goes on). The search stops within the goal tolerance; the end of the path's last reverse run is
    then solved again to end exactly at the goal, settled (``refine_m``,
    :mod:`~hitchpark.planning.refine`), where that keeps clear. Never raises for a hard problem:
    ``status`` says ``no_path`` (or ``planner_timeout``, the wall-clock safety net). Bad arguments raise
    :class:`~hitchpark.checks.InputError`.
    """
    vehicle = check_vehicle(vehicle)
    check_state(vehicle, start)
    goal = check_goal(goal)
    scene = Scene() if scene is None else check_instance("scene", scene, Scene, "hitchpark.model.Scene(...)")
    settings = PlannerSettings() if settings is None else settings
    check_instance("settings", settings, PlannerSettings, "hitchpark.planning.PlannerSettings(...)")
    if settings.hitch_margin >= vehicle.max_hitch:
        raise InputError(
            f"planner.hitch_margin must be < max_hitch ({vehicle.max_hitch:g} rad), got {settings.hitch_margin:g}"
        )
    tree, reach = prepare(vehicle, goal, scene, settings)
    began = time.perf_counter()
    if reach is not None and reach.closed and not reach.holds(start.as_array()):
        exact, _ = swept_clearance(vehicle, scene, start.as_array()[None, :])
        if exact >= settings.min_clearance_m + START_MARGIN_M:  # the search would keep the flood's clearance
            return _closed_in(vehicle, goal, scene, settings, reach, began)
    expanded = 0
    for refinement in range(REFINEMENTS + 1):
        search = Search(vehicle, start, goal, scene, settings, began, tree)
        search.expanded = expanded
        result = search.run()
        expanded = result.expanded
        if not search.exhausted or refinement == REFINEMENTS:
            return refine_plan(vehicle, goal, scene, settings, result) if result.found else result
        settings = finer(settings)  # the grid was too coarse to hold a way through: halve every cell
    return result  # pragma: no cover (the loop returns)


def _closed_in(
    vehicle: VehicleTrailer, goal: Pose, scene: Scene, settings: PlannerSettings, reach: GoalReach, began: float
) -> Plan:
    """``no_path`` for a start outside a closed goal's reach (:mod:`.reach`): how far out the combination gets."""
    far = reach.farthest(goal)
    out = math.hypot(far[0] - goal.x, far[1] - goal.y)
    detail = (
        f"the goal is closed in: driving out of it, forward and in reverse, the combination gets no farther than "
        f"{out:.2f} m (trailer axle) keeping {settings.min_clearance_m:g} m from the scene, on grids down to "
        f"{reach.settings.xy_resolution_m:g} m ({reach.expanded} expansions); no start outside that has a path"
    )
    return Plan(
        status="no_path",
        path={},
        direction_switches=0,
        length_m=0.0,
        planning_s=time.perf_counter() - began,
        expanded=0,
        detail=detail,
        closest=far[:4].copy(),
    )
