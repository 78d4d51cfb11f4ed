"""Path planning among obstacles (issue 9): Hybrid A* over the exact off-axle car-trailer model.

:func:`plan` first tries paths with at most one change of direction (:mod:`.opening`: single reverse
runs that bend, the trailer steered by its virtual steer, Eqs. 42 and 45), then searches the trailer-axle
pose and hitch angle with forward and reverse primitives of the full model (Eqs. 19-24), the steer,
steer-rate and jackknife limits enforced at every sample, collisions screened with discs on a distance
grid and the result confirmed by the exact swept clearance. It returns a :class:`Plan`: ``found`` with
the path, or ``no_path`` / ``timeout``. The search stops within the goal tolerance; :mod:`.refine` then
solves the end of the last reverse run again on the full model, to end exactly at the goal with the hitch
and the steer straight.
"""

from .search import plan
from .settings import PATH_COLUMNS, STATUSES, Plan, PlannerSettings

__all__ = ["PATH_COLUMNS", "STATUSES", "Plan", "PlannerSettings", "plan"]
