"""What a plan builds before its clock starts: the compiled rollouts and pursuits, the scene's distance grid
and goal tree, the refinement's solver (:func:`prepare`), and where a search may go (:func:`scene_bounds`).

Each is built once per vehicle, scene and settings and kept (in the process, and the compiled code and the
tree on disk): that set-up is not planning, and must not be counted in a plan's time, nor change its answer.
"""

from __future__ import annotations

import numpy as np

from ..model.checker import prepare_distances
from ..model.scene import Scene
from ..model.state import Pose
from ..model.vehicle import VehicleTrailer
from ..ocp.obstacles import prepare_clearance
from .discs import prepare_discs
from .endgame import EndGame
from .motion import PrimitiveBatch
from .opening import OPENING_FORWARD_M
from .raster import distance_grid
from .reach import GoalReach, goal_reach, needs_reach
from .refine import REFINE_PLANES, refine_solver
from .settings import PlannerSettings
from .tree import GoalTree, goal_tree

__all__ = ["REACH_FIELDS", "TREE_FIELDS", "prepare", "reach_settings", "scene_bounds", "tree_settings", "uses_tree"]


def prepare(
    vehicle: VehicleTrailer, goal: Pose, scene: Scene, settings: PlannerSettings
) -> tuple[GoalTree | None, GoalReach | None]:
    """Build the batch rollouts and pursuits a search uses before its clock starts, the goal tree among
    obstacles (:mod:`.tree`; the searches on finer grids use it as it is) and, where the tree reaches little
    of the scene, the goal's reach (:mod:`.reach`): both returned.

    They are compiled to C once per machine (cached on disk, :func:`~hitchpark.native.native`) and loaded
    once per process; that set-up is not planning, and is not counted in a plan's time (nor in its safety
    net's).
    """
    PrimitiveBatch(
        vehicle, OPENING_FORWARD_M, round(OPENING_FORWARD_M / settings.sample_step_m), settings.steer_samples
    )
    for size in (2 * settings.steer_samples, settings.steer_samples):  # all primitives, the reverse ones
        PrimitiveBatch(vehicle, settings.primitive_length_m, settings.samples, size)
    if settings.shot_length_m:
        EndGame(vehicle, goal, settings).pursuit.prepare()
    if not scene.is_empty:
        prepare_discs()  # the compiled fast check and exact distances
        prepare_distances()
    if scene.area is not None:  # a search's distance grid (its bounds are the area's, whatever the start)
        distance_grid(scene, scene_bounds(vehicle, goal, scene, settings), settings.collision_cell_m)
    tree, reach = None, None
    if uses_tree(scene, settings):
        bounds = scene_bounds(vehicle, goal, scene, settings)
        tree = goal_tree(vehicle, goal, scene, tree_settings(settings), bounds)
        if needs_reach(tree):
            reach = goal_reach(vehicle, goal, scene, reach_settings(settings), bounds)
    if settings.refine_m:
        planes = 0 if scene.is_empty else REFINE_PLANES
        refine_solver(vehicle, vehicle.max_hitch - settings.hitch_margin, planes, settings.refine_solver)
        if planes:
            prepare_clearance()  # the refinement's lines around the scene
    return tree, reach


def uses_tree(scene: Scene, settings: PlannerSettings) -> bool:
    """Whether a plan uses a goal tree (:mod:`.tree`): among obstacles, with end-games."""
    return not scene.is_empty and settings.shot_length_m > 0


#: The settings a goal tree depends on (the others are reset, so that one tree serves every plan to its goal).
TREE_FIELDS = (
    "xy_resolution_m",
    "yaw_bins",
    "hitch_bins",
    "primitive_length_m",
    "sample_step_m",
    "steer_samples",
    "obstacle_virtual_limit",
    "hitch_margin",
    "min_clearance_m",
    "collision_cell_m",
    "search_margin_m",
    "weight_steer_change",
)


#: The settings the goal's reach depends on (:mod:`.reach`): the tree's but its cost, and the forward cap's
#: tolerance (read backwards, its reverse motions are forward runs the tracker steers).
REACH_FIELDS = (*(name for name in TREE_FIELDS if name != "weight_steer_change"), "forward_length_tolerance")


def tree_settings(settings: PlannerSettings) -> PlannerSettings:
    return PlannerSettings(**{name: getattr(settings, name) for name in TREE_FIELDS})


def reach_settings(settings: PlannerSettings) -> PlannerSettings:
    return PlannerSettings(**{name: getattr(settings, name) for name in REACH_FIELDS})


def scene_bounds(
    vehicle: VehicleTrailer, goal: Pose, scene: Scene, settings: PlannerSettings, start: np.ndarray | None = None
) -> tuple[float, float, float, float]:
    """Where the search may go: the area's box, or the goal, the obstacles (and the start) with a margin."""
    if scene.area is not None:
        lo, hi = scene.area.boundary.min(axis=0), scene.area.boundary.max(axis=0)
        return float(lo[0]) - 1.0, float(lo[1]) - 1.0, float(hi[0]) + 1.0, float(hi[1]) + 1.0
    points = [np.array([[goal.x, goal.y]])] + [o.polygon for o in scene.obstacles]
    if start is not None:
        points.append(np.asarray(start, dtype=float)[None, :2])
    allp = np.vstack(points)
    m = settings.search_margin_m + vehicle.trailer_length + vehicle.wheelbase
    lo, hi = allp.min(axis=0) - m, allp.max(axis=0) + m
    return float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])
