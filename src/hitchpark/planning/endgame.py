"""The planner's end-games: single reverse runs from a configuration into the goal tolerance.

Three kinds, all the trailer axle driven backwards by pure pursuit of its virtual steer (Eq. 42), the
front steer from Eq. (45), rate-limited (:mod:`~hitchpark.planning.motion`):

- **Goal-line shots**: the axle pursues the goal line y = 0 (goal frame) with a few look-aheads. Cheap
  (one CasADi call per 40 samples); they land from configurations behind the goal roughly facing it.
- **Dubins shots**: the axle pursues a reverse Dubins path (:mod:`~hitchpark.planning.dubins`)
  to a point on the goal line, then the line itself: the words of a few radii above the trailer's
  least radius ``L_T / tan(virtual_limit)`` (Eq. 42), so that pure pursuit, the hitch's transient and the
  steer-rate ramp fit in the margin. They land from almost anywhere in open space with a single
  reverse run that bends; tried from the start before searching and from some expanded nodes.
- **Tree shots**: among obstacles, the axle pursues the paths of the nearest nodes of the scene's goal tree
  (:mod:`~hitchpark.planning.tree`), and a run that comes onto its path is handed off to it there, the rest
  of the landing the tree's own path, exact to the goal.

A run counts when a sample reaches the goal tolerance (or, a tree shot, its tree path) with the hitch
within ``max_hitch - hitch_margin`` at every sample before it; the caller screens collisions and confirms
the swept clearance.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from ..model.inverse import virtual_steer_from_front
from ..model.state import Pose, to_goal_frame, wrap_angle
from ..model.vehicle import VehicleTrailer
from .dubins import dubins_words, sample_word
from .grid import Screen
from .rollouts import GoalShot, PathPursuit
from .settings import PlannerSettings, arrived
from .tree import GoalTree

__all__ = ["EndGame", "Landing", "TreeLanding"]

#: Look-aheads of the goal-line shots [m].
SHOT_LOOKAHEADS = (2.5, 4.0, 6.0)

#: Radii of the Dubins shots, in multiples of the trailer's least radius ``L_T / tan(virtual_limit)``.
DUBINS_RADII = (1.0, 1.15, 1.4)

#: Lengths of the straight approach along the goal line that ends each Dubins reference [m], beyond
#: ``goal_line_from_m``.
DUBINS_APPROACHES = (1.5, 4.0)

#: Words tried per radius and approach (the shortest ones).
DUBINS_WORDS = 3

#: Look-ahead of the pursuit along a Dubins reference [m].
DUBINS_LOOKAHEAD_M = 2.0

#: Look-aheads of the pursuit along a goal tree's paths [m]: each near node's path with each (a longer one
#: cuts the tree path's bends, a shorter one swings the hitch further).
TREE_LOOKAHEADS = (2.0, 3.0, 4.5)

#: A tree shot's reference is its tree node's path moved onto the run's start, the offset taken out over this
#: much of it [m] (at most half of it).
TREE_BLEND_M = 6.0

#: A tree shot is handed off to its tree path where it comes this near one of the path's samples [m] ...
HANDOFF_M = 0.05

#: ... with its heading and hitch this near the sample's [rad] ...
HANDOFF_ANGLE = math.radians(1.0)

#: ... and its front steer within what the steer rate turns in this many samples at 1 m/s.
HANDOFF_STEER_SAMPLES = 1.0

#: A Dubins run farther than this from its reference is given up [m].
DUBINS_MAX_DEVIATION_M = 2.0

#: Landing: world-frame samples (k, 4) after the run's start and the front steer at them (k,).
Landing = tuple[np.ndarray, np.ndarray]

#: A tree shot's landing, and how many of its first samples were pursued (the rest, a tree path's, keeps clear
#: by the tree's making: only those, and the first of the rest, need screening).
TreeLanding = tuple[np.ndarray, np.ndarray, int]


class EndGame:
    """Single reverse runs into the goal tolerance for one vehicle, goal and settings."""

    def __init__(self, vehicle: VehicleTrailer, goal: Pose, settings: PlannerSettings):
        self.vehicle, self.goal, self.settings = vehicle, goal, settings
        self.hitch_limit = vehicle.max_hitch - settings.hitch_margin
        self.rate_step = vehicle.max_steer_rate * settings.sample_step_m * HANDOFF_STEER_SAMPLES  # [rad]
        self.line = GoalShot(vehicle, settings.sample_step_m, SHOT_LOOKAHEADS)
        self.least_radius = vehicle.trailer_length / math.tan(settings.virtual_limit)  # Eq. (42)
        self.approaches = tuple(a + settings.goal_line_from_m for a in DUBINS_APPROACHES)
        runs = len(DUBINS_RADII) * len(DUBINS_APPROACHES) * DUBINS_WORDS
        self.pursuit = PathPursuit(vehicle, settings.sample_step_m, runs)

    def in_goal_frame(self, state: np.ndarray) -> tuple[float, float, float]:
        # As floats: to_goal_frame's scalar arithmetic, no NumPy (the same numbers).
        return to_goal_frame(self.goal, float(state[0]), float(state[1]), float(state[2]))

    def line_shots(self, state: np.ndarray, steer: float) -> list[Landing]:
        """Goal-line shots from ``state`` (x, y, yaw, hitch) with the front steer ``steer``, shortest first."""
        s = self.settings
        gx, gy, gyaw = self.in_goal_frame(state)
        if gx <= 0.0 or abs(gyaw) > s.shot_max_heading or math.hypot(gx, gy) > s.shot_length_m:
            return []
        start = np.array([gx, gy, gyaw, state[3], steer])
        return self._landings(self.line.run(start, s.virtual_limit, s.shot_length_m, self._lines_ended()))

    def dubins_shots(
        self,
        state: np.ndarray,
        steer: float,
        max_length: float,
        takes: Callable[[Landing], bool] | None = None,
        within: int | None = None,
        screen: Screen | None = None,
    ) -> list[Landing]:
        """Dubins shots from ``state`` with the front steer ``steer``, shortest first; ``screen``: see
        :meth:`tree_shots`.

        Only references up to ``max_length`` (trailer axle, to the goal) are pursued. A caller that takes
        the shortest landing it accepts can say which it accepts (``takes``) and how long a landing it has
        already (``within``, in samples): the pursuit then stops once no landing still to come can be
        shorter (:meth:`~.rollouts.PathPursuit.run`), and every landing up to there is in the answer.
        """
        s = self.settings
        gx, gy, gyaw = self.in_goal_frame(state)
        step = s.sample_step_m
        if math.hypot(gx, gy) > max_length:
            return []
        references = []
        tail = DUBINS_LOOKAHEAD_M + s.goal_tolerance_m + step
        for factor in DUBINS_RADII:
            radius = factor * self.least_radius
            for approach in self.approaches:
                words = dubins_words((gx, gy, gyaw + math.pi), (approach, 0.0, math.pi), radius)[:DUBINS_WORDS]
                for word, lengths in words:
                    if sum(lengths) + approach > max_length:
                        continue
                    points = sample_word((gx, gy, gyaw + math.pi), word, lengths, radius, step)[:, :2]
                    line = np.arange(approach - step, -tail, -step)
                    points = np.vstack([points, np.column_stack([line, np.zeros(len(line))])])
                    references.append(points)
        start = np.array([gx, gy, gyaw, state[3], steer])
        return self._pursue(start, references, s.virtual_limit, takes, within, screen=screen)

    def tree_shots(
        self,
        state: np.ndarray,
        steer: float,
        tree: GoalTree,
        tried: set[tuple[int, ...]] | None = None,
        screen: Screen | None = None,
    ) -> list[TreeLanding]:
        """Reverse runs from ``state`` along the paths of the nearest nodes of ``tree`` into the goal (the
        trailer axle pursuing each, as a Dubins shot pursues its word, its virtual steer within
        ``obstacle_virtual_limit``), shortest first. ``tried``: the sets of tree nodes shots were taken along
        before (from a neighbouring configuration); one of them is not tried again, and a new one is added.
        ``screen``: runs that come surely too near the scene (:meth:`.grid.Screen.blocked`) are stopped there and
        give no landing (the screen would refuse it).

        A run that comes onto its tree path (within :data:`HANDOFF_M`, :data:`HANDOFF_ANGLE` of heading and
        hitch, and a sample's steer change at the steer rate, of one of its samples past the blend) is handed
        off there: the rest is the tree's own path, exact to the goal. Pure pursuit cuts the corners of a path
        by up to decimetres; the tree's path keeps its clearance where a place is tight.
        """
        near = tree.near(state, self.pursuit.runs // len(TREE_LOOKAHEADS))
        if len(near) == 0:
            return []
        if tried is not None:
            if (key := tuple(int(i) for i in near)) in tried:
                return []
            tried.add(key)
        s = self.settings
        step = s.sample_step_m
        tail = np.arange(-step, -(DUBINS_LOOKAHEAD_M + s.goal_tolerance_m + step), -step)  # on along the goal line
        references, exact = [], []
        gx, gy, gyaw = self.in_goal_frame(state)
        for node in near:
            path = tree.path(int(node))
            px, py, pyaw = to_goal_frame(self.goal, path[:, 0], path[:, 1], path[:, 2])
            tree_path = np.column_stack([px, py, np.unwrap(pyaw), path[:, 3], path[:, 4]])
            # The node's path moved to start where the run starts, the offset taken out over its first
            # TREE_BLEND_M (a smoothstep): the pursuit starts on its reference instead of catching it up.
            along = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(px), np.diff(py)))])
            blend = np.clip(1.0 - along / min(TREE_BLEND_M, 0.5 * along[-1] + 1e-9), 0.0, 1.0)
            weight = blend * blend * (3.0 - 2.0 * blend)
            px, py = px + weight * (gx - px[0]), py + weight * (gy - py[0])
            reference = np.vstack([np.column_stack([px, py]), np.column_stack([tail, np.zeros(len(tail))])])
            references += [reference] * len(TREE_LOOKAHEADS)
            # Hand-offs only where the rest of the path holds the virtual steer (Eq. 56) the runs hold: a tree
            # path may turn tighter (forward, out of the goal), and a tracker would drive that nearer a jackknife.
            virtual = np.abs(virtual_steer_from_front(self.vehicle, path[:-1, 3], path[:-1, 4]))
            tight = np.flatnonzero(virtual > s.obstacle_virtual_limit)
            first = max(int(np.argmax(weight == 0.0)), int(tight[-1]) + 1 if len(tight) else 0)
            exact += [(tree_path, first)] * len(TREE_LOOKAHEADS)
        lookaheads = np.resize(TREE_LOOKAHEADS, self.pursuit.runs)
        lookaheads[len(references) :] = lookaheads[len(references) - 1]
        while len(references) < self.pursuit.runs:  # fewer references than runs: repeat the last
            references.append(references[-1])
            exact.append(exact[-1])
        handoff = _HandOff(exact, self.rate_step)
        start = np.array([gx, gy, gyaw, state[3], steer])

        stopped = self._stopped(screen)

        def ended(states: np.ndarray, deviation: np.ndarray) -> np.ndarray:
            return stopped(states, deviation) | handoff.onto(states, deviation)[0]

        longest = max(len(r) for r in references)
        padded = np.stack([np.vstack([r, np.repeat(r[-1:], longest - len(r), axis=0)]) for r in references])
        runs = self.pursuit.run(start, padded, lookaheads, s.obstacle_virtual_limit, ended)
        found: list[tuple[np.ndarray, int]] = []
        for r, run in enumerate(runs):
            # A run that ended is padded with its last sample: its end is the last sample unlike the one before.
            moved = np.flatnonzero(np.any(run[1:] != run[:-1], axis=1))
            last = int(moved[-1]) + 1 if len(moved) else 0
            onto, at = handoff.onto_run(r, run[last][None, :])
            if last > 0 and onto[0]:
                rest = exact[r][0][int(at[0]) + 1 :].copy()
                turns = np.round((run[last, 2] - rest[0, 2]) / (2 * math.pi))
                rest[:, 2] += 2 * math.pi * turns  # the tree's heading on the run's branch: one continuous yaw
                part, pursued = np.vstack([run[1 : last + 1], rest]), last
            else:
                hits = self.at_goal(run[1 : last + 1])
                if not hits.any():
                    continue
                part = run[1 : int(np.argmax(hits)) + 2]
                pursued = len(part)
            if np.any(np.abs(part[:, 3]) > self.hitch_limit) or not np.all(np.isfinite(part)):
                continue
            if any(len(other) == len(part) and np.array_equal(other, part) for other, _ in found):
                continue
            found.append((part, pursued))
        found.sort(key=lambda landing: len(landing[0]))
        return [(*self._world(part), pursued) for part, pursued in found]

    def _pursue(
        self,
        start: np.ndarray,
        references: list[np.ndarray],
        limit: float,
        takes: Callable[[Landing], bool] | None = None,
        within: int | None = None,
        lookaheads: np.ndarray | None = None,
        screen: Screen | None = None,
    ) -> list[Landing]:
        """The landings of reverse runs from ``start`` (goal frame) pursuing ``references`` (goal frame, (m, 2)
        each, at most the pursuit's runs) at the virtual steer ``limit``, each with its look-ahead [m] (default
        :data:`DUBINS_LOOKAHEAD_M`); ``takes`` and ``within``: see :meth:`dubins_shots`."""
        if not references:
            return []
        references = list(references)
        while len(references) < self.pursuit.runs:  # fewer references than runs: repeat the last
            references.append(references[-1])
        longest = max(len(r) for r in references)
        padded = np.stack([np.vstack([r, np.repeat(r[-1:], longest - len(r), axis=0)]) for r in references])
        runs = self.pursuit.runs
        ahead = np.full(runs, DUBINS_LOOKAHEAD_M)
        if lookaheads is not None:
            ahead[: len(lookaheads)] = lookaheads
            ahead[len(lookaheads) :] = lookaheads[-1]  # the repeated last reference's
        settles = None
        if takes is not None:

            def settles(run: np.ndarray) -> bool:  # a run that ended: a landing the caller takes?
                return bool(self.at_goal(run[-1])) and takes(self._world(run[1:]))

        found = self.pursuit.run(start, padded, ahead, limit, self._stopped(screen), settles, within)
        return self._landings(found)

    def dubins_estimate(self, state: np.ndarray) -> float:
        """Length [m] of the shortest Dubins reference from ``state`` with the longest approach (trailer axle).

        The longest approach and the middle radius: a reference a pursuit follows into the tolerance.
        """
        gx, gy, gyaw = self.in_goal_frame(state)
        approach, radius = self.approaches[-1], DUBINS_RADII[len(DUBINS_RADII) // 2] * self.least_radius
        words = dubins_words((gx, gy, gyaw + math.pi), (approach, 0.0, math.pi), radius)
        return sum(words[0][1]) + approach if words else math.inf

    # --- goal-frame tests -----------------------------------------------------------------------------

    def at_goal(self, states: np.ndarray) -> np.ndarray:
        """Goal-frame states (..., >=4) within the goal tolerance."""
        return arrived(self.settings, states[..., 0], states[..., 1], states[..., 2], states[..., 3])

    def _lost(self, states: np.ndarray) -> np.ndarray:
        """Goal-frame states (n, 5) that cannot still arrive: past the goal, over the hitch limit, non-finite."""
        return (
            (states[:, 0] < -self.settings.goal_tolerance_m)
            | (np.abs(states[:, 3]) > self.hitch_limit)
            | ~np.all(np.isfinite(states), axis=1)
        )

    def _lines_ended(self) -> Callable[[np.ndarray], bool]:
        """``ended`` of one goal-line shot (:meth:`.rollouts.GoalShot.run`), asked about its runs as they grow:
        no run can still arrive, each has arrived (after its start) or passed the hitch limit at some sample,
        or is lost at its last. Each sample is judged once."""
        judged = 0  # samples of the runs judged so far
        done = np.zeros(len(self.line.lookaheads), dtype=bool)  # per run: arrived or past the hitch limit

        def ended(runs: np.ndarray) -> bool:
            nonlocal judged
            new = runs[:, judged:]
            done[:] |= (np.abs(new[:, :, 3]) > self.hitch_limit).any(axis=1)
            done[:] |= self.at_goal(new[:, 1:] if judged == 0 else new).any(axis=1)
            judged = runs.shape[1]
            return bool((done | self._lost(runs[:, -1, :])).all())

        return ended

    def _stopped(self, screen: Screen | None) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
        """``ended`` of the pursuits (:meth:`.rollouts.PathPursuit.run`): :meth:`_dubins_ended`, and with a
        ``screen``, a body surely too near the scene (:meth:`.grid.Screen.blocked`)."""
        if screen is None:
            return self._dubins_ended

        def ended(states: np.ndarray, deviation: np.ndarray) -> np.ndarray:
            return self._dubins_ended(states, deviation) | screen.blocked(self._world(states)[0])

        return ended

    def _dubins_ended(self, states: np.ndarray, deviation: np.ndarray) -> np.ndarray:
        return self.at_goal(states) | self._lost(states) | (deviation > DUBINS_MAX_DEVIATION_M)

    def _landings(self, runs: np.ndarray) -> list[Landing]:
        """The runs (goal frame, (n, samples + 1, 5)) that arrive within the limits, in the world frame; runs that
        are the same to the last sample (a reference repeated to fill the pursuit's runs) once."""
        arrived = self.at_goal(runs[:, 1:])
        found: list[np.ndarray] = []
        for run, hits in zip(runs, arrived, strict=True):
            if not hits.any():
                continue
            part = run[1 : int(np.argmax(hits)) + 2]
            if np.any(np.abs(part[:, 3]) > self.hitch_limit) or not np.all(np.isfinite(part)):
                continue
            if any(len(other) == len(part) and np.array_equal(other, part) for other in found):
                continue
            found.append(part)
        found.sort(key=len)
        return [self._world(part) for part in found]

    def _world(self, part: np.ndarray) -> Landing:
        """A landing's samples (goal frame, (k, 5)) in the world frame, and its front steer."""
        goal = self.goal
        c, sn = math.cos(goal.yaw), math.sin(goal.yaw)
        world = part[:, :4].copy()
        world[:, 0] = goal.x + c * part[:, 0] - sn * part[:, 1]
        world[:, 1] = goal.y + sn * part[:, 0] + c * part[:, 1]
        world[:, 2] = part[:, 2] + goal.yaw
        return world, part[:, 4]


class _HandOff:
    """Where tree shots come onto their tree paths (:meth:`EndGame.tree_shots`): ``exact``, per run, its tree
    path (goal frame, (m, 5)) and the first sample a run may be handed to (past the blend, and past every sample
    whose virtual steer is beyond the runs')."""

    def __init__(self, exact: list[tuple[np.ndarray, int]], steer_step: float):
        self.exact, self.steer_step = exact, steer_step
        longest = max(len(path) for path, _ in exact)
        # Every run's path padded to one length, and the samples a run may be handed to (not the goal itself:
        # that is a landing as any other).
        self.paths = np.stack([np.vstack([p, np.repeat(p[-1:], longest - len(p), axis=0)]) for p, _ in exact])
        index = np.arange(longest)[None, :]
        self.firsts = np.array([first for _, first in exact])[:, None]
        self.valid = (index >= self.firsts) & (index < np.array([len(p) - 1 for p, _ in exact])[:, None])

    def onto(self, states: np.ndarray, deviation: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Rows (run-major, as :meth:`.rollouts.PathPursuit.run` asks) on their tree paths, and the sample each is
        on (-1 where none)."""
        per = len(states) // len(self.exact)
        rows = np.flatnonzero(deviation <= HANDOFF_M)  # the deviation is from the reference: the path past the blend
        onto = np.zeros(len(states), dtype=bool)
        at = np.full(len(states), -1)
        if len(rows):
            onto[rows], at[rows] = self._onto(rows // per, states[rows])
        return onto, at

    def onto_run(self, run: int, states: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """As :meth:`onto`, for ``states`` (n, 5) of run ``run``."""
        return self._onto(np.full(len(states), run), states)

    def _onto(self, runs: np.ndarray, states: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        paths = self.paths[runs]  # (n, m, 5)
        d2 = (states[:, None, 0] - paths[:, :, 0]) ** 2 + (states[:, None, 1] - paths[:, :, 1]) ** 2
        d2 = np.where(self.valid[runs], d2, np.inf)
        j = np.argmin(d2, axis=1)
        rows = np.arange(len(states))
        p, after = paths[rows, j], paths[rows, j + 1]  # the sample the run is on, and the landing's next
        ok = (
            (d2[rows, j] <= HANDOFF_M**2)
            & (np.abs(wrap_angle(states[:, 2] - p[:, 2])) <= HANDOFF_ANGLE)
            & (np.abs(states[:, 3] - p[:, 3]) <= HANDOFF_ANGLE)
            & (np.abs(states[:, 4] - after[:, 4]) <= self.steer_step)
        )
        return ok, np.where(ok, j, -1)
