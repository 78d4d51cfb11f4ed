"""The planner's end-games (hitchpark.planning.endgame, hitchpark.planning.dubins): Dubins words, the runs
stopped once a landing is settled, the goal-line shots."""

import math

import numpy as np
import pytest

from hitchpark.model import Pose, VehicleTrailer
from hitchpark.model.scene import Scene
from hitchpark.model.state import State
from hitchpark.planning import PlannerSettings, plan
from hitchpark.planning.dubins import dubins_words, sample_word
from hitchpark.planning.endgame import EndGame
from hitchpark.planning.rollouts import PathPursuit

VEHICLE = VehicleTrailer()
SETTINGS = PlannerSettings(max_expansions=50_000)  # generous: tests assert behaviour, never timings


@pytest.mark.parametrize("seed", [0, 1])
def test_dubins_words_end_at_their_goal(seed):
    rng = np.random.default_rng(seed)
    for _ in range(200):
        start, end, radius = tuple(rng.uniform(-10, 10, 3)), tuple(rng.uniform(-10, 10, 3)), rng.uniform(1, 6)
        words = dubins_words(start, end, radius)
        assert words, "some Dubins word always exists"
        assert [sum(w[1]) for w in words] == sorted(sum(w[1]) for w in words)
        for word, lengths in words:
            last = sample_word(start, word, lengths, radius, 0.1)[-1]
            assert last[:2] == pytest.approx(end[:2], abs=1e-6)
            assert math.remainder(last[2] - end[2], 2 * math.pi) == pytest.approx(0.0, abs=1e-6)


def test_the_dubins_runs_stopped_once_the_landing_is_settled_plan_the_same_paths(monkeypatch):
    """In open space the Dubins runs stop once no landing still to come is shorter than one taken (or
    than a goal-line landing taken): the planner finds the very paths it finds integrating them all."""
    starts = [
        State(12.0, 4.0, math.radians(30.0), math.radians(10.0)),  # a single bending reverse run
        State(7.2, 6.1, math.radians(2.0), math.radians(20.0)),  # forward, then reverse
        # A goal-line shot lands in 135 samples, a Dubins run in 129 (start 110 of the sweep of seed 7).
        State(11.118740718227746, -4.444849836363771, -0.9564604615747418, 0.3965641671682158),
    ]
    integrated: list[int] = []
    run = PathPursuit.run

    def counted(self, *args, **kwargs):  # type: ignore[no-untyped-def]
        path = run(self, *args, **kwargs)
        integrated.append(path.shape[1])
        return path

    monkeypatch.setattr(PathPursuit, "run", counted)
    early = [plan(VEHICLE, s, Pose(), Scene(), SETTINGS) for s in starts]
    early_samples = sum(integrated)
    integrated.clear()
    shots = EndGame.dubins_shots
    monkeypatch.setattr(
        EndGame, "dubins_shots", lambda self, state, steer, max_length, *rest: shots(self, state, steer, max_length)
    )
    whole = [plan(VEHICLE, s, Pose(), Scene(), SETTINGS) for s in starts]
    assert early_samples < sum(integrated)
    for a, b in zip(early, whole, strict=True):
        assert a.status == b.status == "found"
        assert a.path.keys() == b.path.keys()
        for name in a.path:
            np.testing.assert_array_equal(a.path[name], b.path[name])


def test_the_goal_line_shots_ended_test_judges_each_sample_once_as_if_all_were_judged_again():
    """The goal-line shots are asked whether they ended as they grow by chunks; judging only the new
    samples gives what judging the whole runs again gives: each run arrived (after its start) or past the
    hitch limit at some sample, or lost at its last."""
    endgame = EndGame(VEHICLE, Pose(), SETTINGS)
    rng = np.random.default_rng(3)
    answers = set()
    for _ in range(40):
        runs = np.zeros((3, 121, 5))
        runs[:, :, 0] = np.linspace(rng.uniform(2.0, 8.0), rng.uniform(-1.0, 1.0), 121)
        runs[:, :, 3] = rng.normal(0.0, 0.5, (3, 121)) * (rng.random((3, 1)) < 0.5)  # some pass the limit
        arrive = rng.integers(0, 121, 3)
        runs[np.arange(3), arrive] = 0.0  # a sample at the goal (the start's does not count)
        ended = endgame._lines_ended()
        for k in (41, 81, 121):
            part = runs[:, :k]
            over = (np.abs(part[:, :, 3]) > endgame.hitch_limit).any(axis=1) | endgame._lost(part[:, -1])
            expected = bool((over | endgame.at_goal(part[:, 1:]).any(axis=1)).all())
            assert ended(part) == expected
            answers.add(expected)
    assert answers == {False, True}
