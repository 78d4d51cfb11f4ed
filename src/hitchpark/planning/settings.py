"""Settings of the path planner and its result."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ..checks import Choice, InputError, Integer, Real, check_fields, checked
from ..model.collision import MAX_STEP_M
from ..model.state import wrap_angle
from ..solvers.registry import cold_solver_names

__all__ = [
    "NEAR_START_MARGIN_M",
    "NEAR_START_STEP_M",
    "PATH_COLUMNS",
    "REFINEMENTS",
    "START_MARGIN_M",
    "STATUSES",
    "Plan",
    "PlannerSettings",
    "arrived",
    "finer",
]

#: A start within ``start_slack_m`` of ``min_clearance_m`` is planned from keeping its own clearance less this [m]
#: (the exact swept clearance's bound is low by up to half its sub-step, and 5 mm), at least ``min_clearance_m -
#: start_slack_m``.
START_MARGIN_M = MAX_STEP_M / 2 + 0.005

#: From such a start the exact check's sub-steps are this fine [m]: the first motions away from a wall the car
#: stands by keep little more than the start does, and a bound low by 2.5 cm would refuse them all.
NEAR_START_STEP_M = 0.01

#: What a path from a start within the slack keeps less than the start [m]: half the fine sub-step, and 5 mm.
NEAR_START_MARGIN_M = NEAR_START_STEP_M / 2 + 0.005

#: What :attr:`Plan.status` can be: ``planner_timeout`` is the wall-clock safety net (``time_limit_s``), which
#: no shipped scene or sweep reaches; the search's own budget is a count (``max_expansions``) and ends ``no_path``.
STATUSES = ("found", "no_path", "planner_timeout")

#: The columns of :attr:`Plan.path`, one row per sample of the path.
PATH_COLUMNS = ("x_trailer", "y_trailer", "yaw_trailer", "hitch", "front_steer", "direction", "s", "t")

#: How many times a search that exhausts its grid is repeated on a grid twice as fine (:func:`finer`).
REFINEMENTS = 2

_ANGLE = Real(0.0, math.pi, low_open=True, unit="rad")
_WEIGHT = Real(0.0, 1000.0)


@dataclass(frozen=True)
class PlannerSettings:
    """How the Hybrid A* planner searches (:func:`~hitchpark.planning.plan`).

    Parameters
    ----------
    xy_resolution_m : float
        Cell size of the search grid in x and y [m]: one node is kept per cell, heading bin and hitch bin.
    yaw_bins : int
        Heading bins over a full turn.
    hitch_bins : int
        Hitch-angle bins over +-``max_hitch``.
    primitive_length_m : float
        Rear-axle distance one motion primitive drives [m] (at 1 m/s, its duration in seconds).
    sample_step_m : float
        Rear-axle distance between the samples of a primitive [m]; one RK4 step of the full model per
        sample, the hitch limit and the collision approximation checked at each.
    steer_samples : int
        Commands per direction, evenly spread (odd counts include straight ahead): forward, front steers
        over +-the cap of :func:`~hitchpark.control.pure_pursuit.forward_steer_limit` (forward motion
        cannot jackknife); in reverse, virtual steers over +-``virtual_limit``, the front steer following
        from Eq. (45) (:mod:`~hitchpark.planning.motion`). The front steer moves towards the
        command at most ``max_steer_rate``; at a change of direction it is set at standstill.
    forward_length_tolerance : float
        The forward cap assumes L_H and L_T this much (a fraction) longer than the vehicle's, as the tracker's
        cap does (:class:`~hitchpark.control.path_tracking.TrackingSettings`): the planned process sets it to
        the tracker's, so that a forward run planned is one the tracker can steer. 0: the vehicle's own cap.
        The goal tree does not take it (:data:`~hitchpark.planning.prepare.TREE_FIELDS`): read backwards its
        primitives are reverse runs, driven within the vehicle's own steer limit (the tracker's cap is a forward one).
    virtual_limit : float
        Largest virtual steer of the reverse primitives [rad] (the paper's NMPC bound, 0.5 rad: a
        trailer-axle radius of about 5 m on Table 4).
    obstacle_virtual_limit : float
        Among obstacles (a scene that is not empty), when the opening at ``virtual_limit`` finds nothing it
        is tried again with the reverse primitives and end-games at this larger limit [rad] (the search
        that follows keeps ``virtual_limit``): 0.6 rad, a trailer-axle radius of about 3.9 m on Table 4,
        lets the driveway's single reverse run fit its 7 m street (measured: not at 0.5 rad).
    hitch_margin : float
        The hitch stays within ``max_hitch - hitch_margin`` at every sample [rad].
    max_expansions : int
        The search's budget: node expansions of one plan, the opening's short search and the searches on
        finer grids included. Past it the result is ``no_path`` (with where the search got to). A count,
        not a time: the same start, scene and settings give the same plan on any machine and load.
    time_limit_s : float
        Wall-clock safety net for a live loop [s]; past it the result is ``planner_timeout``. Set far above
        what ``max_expansions`` takes, so that it decides nothing in a sweep; a plan it cut short is not
        reproducible.
    shot_length_m : float
        End-game (:mod:`~hitchpark.planning.endgame`): from every node expanded within this
        trailer-axle distance of the goal, behind it and heading within ``shot_max_heading`` of the goal
        heading, reverse runs onto the goal line (pure pursuit of the trailer by its virtual steer,
        look-aheads 2.5, 4 and 6 m) are tried for this length [m], and from every tenth node reverse runs
        along Dubins paths up to this long; one that reaches the goal tolerance ends the search. Before
        searching, the opening tries single reverse runs from the start (up to 60 m), a short search of
        reverse primitives, and forward arcs followed by a Dubins run (0: no end-games, no opening).
    shot_max_heading : float
        See ``shot_length_m`` [rad].
    goal_tolerance_m, goal_tolerance_yaw, goal_tolerance_hitch : float
        The search ends at the first sample within these of the goal: trailer-axle distance [m], heading
        [rad], hitch angle [rad]; ``refine_m`` then takes the path exactly to the goal.
    refine_m : float
        The last this much trailer-axle path [m] of the path's last reverse run (if it ends in reverse) is
        solved again on the full model to end exactly at the goal (or on its line), hitch and steer
        straight (:mod:`~hitchpark.planning.refine`); 0: the path ends where the search stopped.
    refine_solver : str
        The solver of the refined end's NLP: ``fatrop`` (on its stages) or ``ipopt`` (the reference), the
        same optimum (:data:`~hitchpark.solvers.registry.COLD_ROUTES`).
    goal_line_from_m, goal_line_m : float
        The path may end anywhere on the goal line from ``goal_line_from_m`` to ``goal_line_m`` ahead of
        the goal [m] (within the goal tolerance of that segment, heading along it, hitch straight): the
        straight rest is left to the tracking controller. Both 0: at the goal itself.
    min_clearance_m : float
        Least distance [m] of every body from every obstacle and from the area's boundary.
    start_slack_m : float
        A start up to this much [m] nearer the scene than ``min_clearance_m`` is planned from: the search keeps
        the start's own clearance less 3 cm (at least ``min_clearance_m - start_slack_m``) instead, as it does
        for a start less than 3 cm clearer than ``min_clearance_m`` (the goal tree and the refined end keep
        ``min_clearance_m``); 0: such a start is ``no_path``, and the search keeps ``min_clearance_m``.
    collision_cell_m : float
        Cell of the obstacle distance grid [m] (the fast check's error is about 1.5 cells, counted against
        it: a finer cell lets the search pass closer).
    search_margin_m : float
        Without an area, how far beyond the start, the goal and the obstacles the search may go [m].
    weight_forward, weight_reverse : float
        Cost per metre of trailer-axle path driven forward / in reverse.
    weight_switch : float
        Cost of a change of direction [m of path]; the opening takes a single reverse run over a path with
        one change of direction when it is no more than this longer.
    weight_steer : float
        Cost per metre and radian of ``|steer|``.
    weight_steer_change : float
        Cost per radian of steer change between primitives.
    weight_hitch : float
        Cost per metre and radian of ``|hitch|``.
    heuristic_yaw_m : float
        Heuristic cost per radian of heading error [m/rad], added to the trailer-axle distance to the goal.
    heuristic_hitch_m : float
        Heuristic cost per radian of hitch angle [m/rad].
    heuristic_radius_m : float
        Turning radius of the trailer axle in the non-holonomic heuristic's table [m]
        (:mod:`~hitchpark.planning.heuristic`); 0 turns the table off.
    heuristic_weight : float
        Inflation of the heuristic (1: plain A*; larger: greedier, faster, longer paths).
    """

    xy_resolution_m: float = checked(1.0, Real(0.01, 10.0, unit="m"))
    yaw_bins: int = checked(36, Integer(4, 3600))
    hitch_bins: int = checked(14, Integer(1, 3600))
    primitive_length_m: float = checked(1.5, Real(0.05, 20.0, unit="m"))
    sample_step_m: float = checked(0.1, Real(0.01, 1.0, unit="m"))
    steer_samples: int = checked(7, Integer(2, 41))
    forward_length_tolerance: float = checked(0.0, Real(0.0, 1.0, high_open=True))
    virtual_limit: float = checked(0.5, Real(0.0, math.pi / 2, low_open=True, high_open=True, unit="rad"))
    obstacle_virtual_limit: float = checked(0.6, Real(0.0, math.pi / 2, low_open=True, high_open=True, unit="rad"))
    hitch_margin: float = checked(math.radians(5.0), Real(0.0, math.pi / 2, high_open=True, unit="rad"))
    max_expansions: int = checked(4000, Integer(1, 10_000_000))
    time_limit_s: float = checked(120.0, Real(0.0, 3600.0, low_open=True, unit="s"))
    shot_length_m: float = checked(20.0, Real(0.0, 100.0, unit="m"))
    shot_max_heading: float = checked(math.radians(90.0), Real(0.0, math.pi, unit="rad"))
    goal_tolerance_m: float = checked(0.3, Real(0.0, 10.0, low_open=True, unit="m"))
    goal_tolerance_yaw: float = checked(math.radians(3.0), _ANGLE)
    goal_tolerance_hitch: float = checked(math.radians(3.0), _ANGLE)
    refine_m: float = checked(20.0, Real(0.0, 100.0, unit="m"))
    refine_solver: str = checked("fatrop", Choice(cold_solver_names))
    goal_line_from_m: float = checked(0.0, Real(0.0, 100.0, unit="m"))
    goal_line_m: float = checked(0.0, Real(0.0, 100.0, unit="m"))
    min_clearance_m: float = checked(0.2, Real(0.0, 10.0, unit="m"))
    start_slack_m: float = checked(0.0, Real(0.0, 10.0, unit="m"))
    collision_cell_m: float = checked(0.05, Real(0.02, 1.0, unit="m"))
    search_margin_m: float = checked(10.0, Real(0.0, 1000.0, unit="m"))
    weight_forward: float = checked(1.0, Real(0.0, 1000.0, low_open=True))
    weight_reverse: float = checked(1.0, Real(0.0, 1000.0, low_open=True))
    weight_switch: float = checked(22.0, _WEIGHT)
    weight_steer: float = checked(0.2, _WEIGHT)
    weight_steer_change: float = checked(0.5, _WEIGHT)
    weight_hitch: float = checked(0.5, _WEIGHT)
    heuristic_yaw_m: float = checked(2.0, Real(0.0, 1000.0, unit="m/rad"))
    heuristic_hitch_m: float = checked(2.0, Real(0.0, 1000.0, unit="m/rad"))
    heuristic_radius_m: float = checked(5.0, Real(0.0, 100.0, unit="m"))
    heuristic_weight: float = checked(2.5, Real(1.0, 100.0))

    def __post_init__(self) -> None:
        check_fields(self, "planner.")
        if self.goal_line_from_m > self.goal_line_m:
            raise InputError(
                f"planner.goal_line_from_m must be <= planner.goal_line_m ({self.goal_line_m:g} m), "
                f"got {self.goal_line_from_m:g}"
            )
        if self.sample_step_m > self.primitive_length_m:
            raise InputError(
                f"planner.sample_step_m must be <= planner.primitive_length_m ({self.primitive_length_m:g} m), "
                f"got {self.sample_step_m:g}"
            )
        if self.primitive_length_m / self.sample_step_m > 1000:
            raise InputError("planner.primitive_length_m / planner.sample_step_m must be at most 1000 samples")

    @property
    def samples(self) -> int:
        """Samples (RK4 steps) per primitive."""
        return max(1, round(self.primitive_length_m / self.sample_step_m))


def finer(settings: PlannerSettings) -> PlannerSettings:
    """``settings`` on a grid twice as fine: every cell halved, in place, heading and hitch."""
    return replace(
        settings,
        xy_resolution_m=settings.xy_resolution_m / 2,
        yaw_bins=min(3600, settings.yaw_bins * 2),
        hitch_bins=min(3600, settings.hitch_bins * 2),
    )


def arrived(settings: PlannerSettings, gx: Any, gy: Any, gyaw: Any, hitch: Any) -> Any:
    """Goal-frame configurations within the goal tolerance of the goal (or of its line, ``goal_line_m``).

    ``gyaw`` may be a function of no arguments that gives the yaws: it is called only when some
    configuration is near enough (most of the planner's questions have none, and wrapping angles is the
    costly part of the answer; a function's yaws have the shape of the other inputs broadcast).
    """
    along = np.minimum(np.maximum(gx, settings.goal_line_from_m), settings.goal_line_m)  # np.clip, cheaper
    near = np.hypot(np.asarray(gx) - along, gy) <= settings.goal_tolerance_m
    if not near.any():
        if near.shape == np.shape(hitch) and (callable(gyaw) or near.shape == np.shape(gyaw)):
            return near  # the answer's shape already (the usual case: np.broadcast_to costs microseconds)
        return np.broadcast_to(
            near, np.broadcast_shapes(near.shape, np.shape(hitch), np.shape(0.0 if callable(gyaw) else gyaw))
        )
    yaw = gyaw() if callable(gyaw) else gyaw
    return (
        near
        & (np.abs(wrap_angle(yaw)) <= settings.goal_tolerance_yaw)
        & (np.abs(hitch) <= settings.goal_tolerance_hitch)
    )


@dataclass(frozen=True)
class Plan:
    """What :func:`~hitchpark.planning.plan` found.

    ``status``: ``"found"`` (``path`` ends within the goal tolerance and passed the exact swept clearance
    check), ``"no_path"`` (nothing reaches the goal: the search space was exhausted, its budget of expansions
    spent, or the goal or start is blocked), ``"planner_timeout"`` (the wall-clock safety net passed first).
    ``path`` maps :data:`PATH_COLUMNS` to
    equal-length arrays (empty unless found), world frame, SI units, radians: the trailer-axle pose, the
    hitch angle, the front steer at that sample, the direction of the motion into it (+1 forward, -1
    reverse; the first row takes the first motion's), ``s`` the trailer-axle arc length [m] and ``t`` the
    time at 1 m/s of the rear axle [s] (steering at standstill at a change of direction takes none).
    ``direction_switches``: changes of direction along the path; ``length_m``: trailer-axle path length;
    ``planning_s``: wall-clock time (the only field that depends on the machine); ``expanded``: nodes
    expanded; ``detail``: why, in words; ``closest``: for a search that found nothing, the configuration (x,
    y, yaw, hitch of the trailer axle) it reached nearest the goal, where it got stuck (``detail`` says what is
    nearest there), else None.
    """

    status: str
    path: dict[str, np.ndarray] = field(default_factory=dict)
    direction_switches: int = 0
    length_m: float = 0.0
    planning_s: float = 0.0
    expanded: int = 0
    detail: str = ""
    closest: np.ndarray | None = None

    @property
    def found(self) -> bool:
        return self.status == "found"

    @property
    def states(self) -> np.ndarray:
        """The path's configurations, rows (x_trailer, y_trailer, yaw_trailer, hitch)."""
        if not self.path:
            return np.zeros((0, 4))
        return np.column_stack([self.path[k] for k in PATH_COLUMNS[:4]])

    def summary(self) -> dict[str, Any]:
        return {
            "status": self.status,
            "direction_switches": self.direction_switches,
            "length_m": self.length_m,
            "planning_s": self.planning_s,
            "expanded": self.expanded,
            "detail": self.detail,
        }
