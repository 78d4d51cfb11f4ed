"""Where to go: Hybrid A* over the exact off-axle car-trailer model, guided among obstacles by a goal tree.

Among obstacles a tree of the reverse runs into the goal is grown once per scene (:mod:`.tree`: driving
out of the goal forward, read backwards); the search shoots along it and heads for it. :func:`plan` first
tries paths with at most one change of direction (:mod:`.opening`: single reverse
runs that bend, the trailer steered by its virtual steer, Eqs. 42 and 45), then searches the trailer-axle
pose and hitch angle with forward and reverse primitives of the full model (Eqs. 19-24), the steer,
steer-rate and jackknife limits enforced at every sample, collisions screened with discs on a distance
grid and the result confirmed by the exact swept clearance. It returns a :class:`Plan`: ``found`` with
the path, or ``no_path`` (also when its budget of expansions is spent: a count, so the same plan on any
machine) / ``planner_timeout`` (a wall-clock safety net). The search stops within the goal tolerance;
:mod:`.refine` then solves the end of the last reverse run again on the full model, to end exactly at the
goal with the hitch and the steer straight.
"""

from .planner import plan
from .prepare import prepare
from .settings import PATH_COLUMNS, STATUSES, Plan, PlannerSettings

__all__ = ["PATH_COLUMNS", "STATUSES", "Plan", "PlannerSettings", "plan", "prepare"]
