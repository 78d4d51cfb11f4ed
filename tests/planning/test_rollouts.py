"""The pursuits of a reference on the full model (hitchpark.planning.rollouts): runs held where they
first ended, compiled chunks, the pure-pursuit law, stopping once settled."""

import math

import numpy as np
import pytest

from hitchpark.model import VehicleTrailer, front_steer_from_virtual, full_rhs
from hitchpark.planning import PlannerSettings
from hitchpark.planning.rollouts import PathPursuit, _pursuit_step_function

VEHICLE = VehicleTrailer()
SETTINGS = PlannerSettings(max_expansions=50_000)  # generous: tests assert behaviour, never timings


def test_a_pursuit_run_is_held_where_it_first_ended_whether_asked_each_sample_or_in_blocks(monkeypatch):
    """PathPursuit asks ``ended`` about blocks of samples: the runs must be those of asking every sample."""
    runs, step = 5, 0.1
    pursuit = PathPursuit(VEHICLE, step, runs)
    # Straight references behind the start (reverse along -x), offsets across so the runs differ.
    xs = -np.arange(0.0, 12.0, step)
    references = np.stack([np.column_stack([xs, np.full(len(xs), 0.3 * (r - 2))]) for r in range(runs)])
    stops = np.array([-1.0, -3.37, -6.0, -0.55, -20.0])  # the last never stops: its reference ends first
    asked: list[int] = []

    def run() -> np.ndarray:
        start = np.array([0.0, 0.0, 0.0, 0.05, 0.0])
        return pursuit.run(start, references, np.full(runs, 2.0), 0.5, ended_rows)

    def ended_rows(states: np.ndarray, deviation: np.ndarray) -> np.ndarray:
        asked.append(len(states))  # rows: the samples of run 0, then of run 1, ...
        per_run = len(states) // runs
        which = np.repeat(np.arange(runs), per_run)
        return states[:, 0] <= stops[which]

    blocks = run()
    assert max(asked) > runs  # asked about several samples of each run at once
    monkeypatch.setattr(PathPursuit, "CHECK_EVERY", 1)
    asked.clear()
    each = run()
    assert max(asked) == runs
    np.testing.assert_array_equal(blocks, each)
    for r in range(4):  # each stopping run: held from the first sample past its stop on
        first = int(np.argmax(blocks[r, :, 0] <= stops[r]))
        assert first > 0 and np.all(blocks[r, :first, 0] > stops[r])
        np.testing.assert_array_equal(
            blocks[r, first:], np.repeat(blocks[r, first : first + 1], blocks.shape[1] - first, 0)
        )
    assert blocks.shape[1] == len(xs) + PathPursuit.WINDOW + 1  # the last run never ended: to the end of the references


@pytest.mark.parametrize("compiled", [False, True], ids=["casadi", "compiled"])
def test_a_compiled_pursuit_chunk_follows_the_nearest_point_search_done_sample_by_sample(compiled, request):
    """The chunks, compiled to C or in CasADi's virtual machine (the nearest point searched at computed
    indices), give the runs of a plain loop: the nearest of the next WINDOW points in NumPy (the first of
    equals), one RK4 step towards the point ``ahead`` samples past it, indices clipped to the end."""
    if compiled:
        request.getfixturevalue("jit_cache")
    runs, step = 3, 0.1
    rng = np.random.default_rng(5)
    pursuit = PathPursuit(VEHICLE, step, runs)
    # Curved references behind the start, of different bends, one shorter than the others (padded).
    t = np.arange(0.0, 9.0, step)
    references = np.stack([np.column_stack([-t, 0.15 * r * t + 0.02 * (r - 1) * t**2]) for r in range(runs)])
    references[2, 60:] = references[2, 59]  # padded with its last point
    lookaheads = np.array([1.0, 2.0, 3.3])
    start = np.array([0.2, -0.1, rng.uniform(-0.1, 0.1), 0.05, 0.0])
    never = lambda states, deviation: np.zeros(len(states), dtype=bool)  # noqa: E731
    compiled = pursuit.run(start, references, lookaheads, 0.5, never)

    one = _pursuit_step_function(VEHICLE, step)
    m = references.shape[1]
    for r in range(runs):
        ahead = max(1, round(lookaheads[r] / step))
        x, nearest, rows = start.copy(), 0, [start.copy()]
        for _ in range(m + PathPursuit.WINDOW):
            candidates = np.minimum(nearest + np.arange(PathPursuit.WINDOW), m - 1)
            distance = np.hypot(*(references[r, candidates] - x[:2]).T)
            nearest = int(candidates[np.argmin(distance)])
            target = references[r, min(nearest + ahead, m - 1)]
            x = np.asarray(one(x, target, 0.5)).ravel()
            rows.append(x)
        np.testing.assert_allclose(compiled[r], np.array(rows), rtol=0, atol=1e-9)


def test_the_pursuit_steers_as_pure_pursuit_written_with_angles():
    """The runs' right-hand side takes the virtual steer's tangent from the bearing's sine (no angle): one RK4
    step of it is one of pure pursuit written with angles, the bearing an arctangent wrapped to +-pi, the
    virtual steer the arctangent of L_T times the curvature 2 sin(alpha) / l_d clipped to +-limit, then Eq.
    (45), on random states and points in every direction (many at the limit, some straight ahead)."""
    step, limit, v = 0.1, 0.5, VEHICLE
    one = _pursuit_step_function(v, step)

    def rhs(x: np.ndarray, point: np.ndarray) -> np.ndarray:
        dx, dy = point[0] - x[0], point[1] - x[1]
        bearing = math.atan2(dy, dx) - (x[2] + math.pi)
        alpha = math.atan2(math.sin(bearing), math.cos(bearing))
        virtual = math.atan(-2.0 * v.trailer_length * math.sin(alpha) / max(math.hypot(dx, dy), 1e-6))
        virtual = min(max(virtual, -limit), limit)
        front = min(max(front_steer_from_virtual(v, x[3], virtual), -v.max_steer), v.max_steer)  # Eq. (45)
        rate = min(max((front - x[4]) / step, -v.max_steer_rate), v.max_steer_rate)
        return np.append(full_rhs(v, x[:4], np.array([-1.0, x[4]])), rate)

    rng = np.random.default_rng(12)
    clipped = 0
    for _ in range(300):
        x = np.array([*rng.uniform(-5.0, 5.0, 2), rng.uniform(-math.pi, math.pi), *rng.uniform(-0.8, 0.8, 2)])
        heading = x[2] + math.pi + rng.choice([rng.uniform(-math.pi, math.pi), 0.0])  # some dead astern
        point = x[:2] + rng.uniform(0.3, 8.0) * np.array([math.cos(heading), math.sin(heading)])
        k1 = rhs(x, point)
        k2 = rhs(x + 0.5 * step * k1, point)
        k3 = rhs(x + 0.5 * step * k2, point)
        k4 = rhs(x + step * k3, point)
        expected = x + step / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        np.testing.assert_allclose(np.asarray(one(x, point, limit)).ravel(), expected, rtol=0, atol=1e-12)
        dx, dy = point - x[:2]
        clipped += abs(2.0 * v.trailer_length * (dx * math.sin(x[2]) - dy * math.cos(x[2]))) > math.tan(limit) * (
            dx * dx + dy * dy
        )
    assert 30 < clipped < 270  # both sides of the limit were tried


def test_a_pursuit_stopped_once_settled_is_the_start_of_the_whole_one():
    """``settles`` stops every run at the check where it says True of a run that ended, ``within`` after as
    many samples: either way the runs so far are those of the whole pursuit, sample for sample."""
    runs, step = 5, 0.1
    pursuit = PathPursuit(VEHICLE, step, runs)
    xs = -np.arange(0.0, 12.0, step)
    references = np.stack([np.column_stack([xs, np.full(len(xs), 0.3 * (r - 2))]) for r in range(runs)])
    stops = np.array([-1.0, -3.37, -6.0, -0.55, -20.0])
    start = np.array([0.0, 0.0, 0.0, 0.05, 0.0])

    def ended_rows(states: np.ndarray, deviation: np.ndarray) -> np.ndarray:
        which = np.repeat(np.arange(runs), len(states) // runs)
        return states[:, 0] <= stops[which]

    asked: list[np.ndarray] = []

    def settles(run: np.ndarray) -> bool:  # True of the second run to end (run 0, past -1 m)
        asked.append(run)
        return len(asked) == 2

    whole = pursuit.run(start, references, np.full(runs, 2.0), 0.5, ended_rows)
    early = pursuit.run(start, references, np.full(runs, 2.0), 0.5, ended_rows, settles)
    n = early.shape[1]
    assert n < whole.shape[1] // 4
    np.testing.assert_array_equal(early, whole[:, :n])
    # Asked about each run that ended, once, with its samples up to where it ended: run 3, then run 0.
    assert len(asked) == 2
    for run, r in zip(asked, (3, 0), strict=True):
        assert run[-1, 0] <= stops[r] and np.all(run[:-1, 0] > stops[r])
        np.testing.assert_array_equal(run, whole[r, : len(run)])
    within = pursuit.run(start, references, np.full(runs, 2.0), 0.5, ended_rows, within=25)
    np.testing.assert_array_equal(within, whole[:, :26])  # 25 samples asked about, and the state after
