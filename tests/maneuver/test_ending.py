"""The rule that ends a maneuver (hitchpark.maneuver.judge states it), on a scripted process.

The stages here drive straight back at a fixed speed for a given number of steps, then stop or fail; the
process hands out a script of stages and records every time it is asked for the next one (a planned process
would plan then). What ends the maneuver, and whether the process was asked, is then known exactly.
"""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from hitchpark.control.step import ControlStep
from hitchpark.maneuver import ManeuverSettings, Outcome
from hitchpark.maneuver import process as process_module
from hitchpark.maneuver.process import park
from hitchpark.maneuver.stages import Ending
from hitchpark.model import State, VehicleTrailer
from hitchpark.model.plant import PlantSettings
from hitchpark.model.state import Pose

VEHICLE = VehicleTrailer()
IDEAL = PlantSettings(kind="ideal")


class Scripted:
    """A stage: ``steps`` samples at ``speed`` (steer 0), then a stop (``fails``: a failure instead)."""

    rate_limited = True
    max_steps = 10_000

    def __init__(self, kind: str, steps: int, speed: float, fails: bool = False):
        self.kind, self.controller = kind, "tracking"
        self.steps, self.speed, self.fails = steps, speed, fails
        self.done = 0

    def begin(self, measurement, goal):
        self.done = 0
        return None

    def act(self, measurement, goal, in_flight):
        if self.done >= self.steps:
            return ControlStep(
                trailer_speed=0.0,
                virtual_steer=0.0,
                rear_speed=0.0,
                front_steer=0.0,
                ok=not self.fails,
                stop=True,
                status="scripted failure" if self.fails else "",
            )
        self.done += 1
        return ControlStep(
            trailer_speed=self.speed, virtual_steer=0.0, rear_speed=self.speed, front_steer=0.0, ok=True, stop=False
        )


class Script:
    """A process handing out ``stages`` in order, then ``ending``; ``asked`` counts the calls of ``next``."""

    def __init__(self, stages, ending=None):
        self.stages, self.ending = list(stages), ending or Ending(Outcome.NO_PATH, "the script ran out")
        self.plans: list = []
        self.asked = 0

    def first(self, measurement, goal):
        return self.stages.pop(0) if self.stages else self.ending

    def next(self, measurement, goal, ended):
        self.asked += 1
        return self.stages.pop(0) if self.stages else self.ending


def run(monkeypatch, script, start, settings=None):
    monkeypatch.setattr(process_module, "make_process", lambda *args, **kwargs: script)
    return park(VEHICLE, start, Pose(), settings or ManeuverSettings(), plant=IDEAL)


AT_GOAL = State(0.05, 0.0, 0.0, 0.0)  # 5 cm ahead of the goal: parked already
AWAY = State(3.0, 0.0, 0.0, 0.0)  # 3 m ahead of it


def test_a_failed_reverse_stage_that_leaves_the_car_parked_ends_parked_without_asking_the_process(monkeypatch):
    # The replan-then-parked case: the planned process would plan again after a failed stage; the car
    # stands parked, so the maneuver ends parked and no plan is made (none counts in planning_s).
    script = Script([Scripted("reverse", steps=2, speed=-0.05, fails=True)])
    result = run(monkeypatch, script, AT_GOAL)
    assert result.reason == Outcome.PARKED.value and result.success
    assert script.asked == 0
    assert result.stages[-1].reason.endswith("scripted failure")


def test_a_forward_stage_that_ends_within_the_tolerances_is_not_parked(monkeypatch):
    # Parked is judged after a reverse stage only (Fig. 7): the process is asked, and here it ends the maneuver.
    script = Script([Scripted("forward", steps=1, speed=0.05)])
    result = run(monkeypatch, script, AT_GOAL)
    assert script.asked == 1
    assert result.reason == Outcome.NO_PATH.value and result.detail == "the script ran out"


def test_an_unparked_stage_asks_the_process_and_its_ending_ends_the_maneuver(monkeypatch):
    script = Script([Scripted("reverse", steps=5, speed=-0.5)])
    result = run(monkeypatch, script, AWAY)
    assert script.asked == 1 and not result.success
    assert result.reason == Outcome.NO_PATH.value


def test_a_reverse_stage_that_stops_parked_ends_the_maneuver_parked(monkeypatch):
    script = Script([Scripted("reverse", steps=3, speed=-0.05), Scripted("forward", 3, 0.5)])
    result = run(monkeypatch, script, AT_GOAL)
    assert result.success and result.reason == Outcome.PARKED.value
    assert script.asked == 0 and len(script.stages) == 1  # the forward stage was never asked for


def test_the_limit_of_direction_segments_ends_before_a_new_direction_starts(monkeypatch):
    settings = ManeuverSettings.from_dict({"success": {"max_stages": 2}})
    stages = [Scripted("reverse", 3, -0.5), Scripted("forward", 3, 0.5), Scripted("reverse", 3, -0.5)]
    script = Script(stages)
    result = run(monkeypatch, script, AWAY, settings)
    assert result.reason == Outcome.MAX_STAGES.value
    assert [s.kind for s in result.stages] == ["reverse", "forward"]
    assert len(script.stages) == 0  # the third was handed out, and not driven


def test_the_loops_own_outcome_outranks_parked(monkeypatch):
    # A maneuver out of time ends on the time limit even where the car then stands parked.
    settings = ManeuverSettings.from_dict({"success": {"max_time": 0.5}})
    script = Script([Scripted("reverse", steps=10_000, speed=-0.01)])
    result = run(monkeypatch, script, AT_GOAL, settings)
    assert result.reason == Outcome.TIMEOUT.value and not result.success
    assert script.asked == 0


@pytest.mark.parametrize("kind", ["reverse", "forward"])
def test_a_process_that_ends_before_any_stage_leaves_one_standing_row(monkeypatch, kind):
    script = Script([], Ending(Outcome.NO_PATH, "no path from the start"))
    result = run(monkeypatch, script, AWAY)
    assert result.reason == Outcome.NO_PATH.value and result.detail == "no path from the start"
    assert len(result.stages) == 1 and result.stages[0].reason == "not started"
    assert math.isclose(result.stages[0].distance_error_m, 3.0)


class Crawling(Scripted):
    """A scripted stage of 150 steps' budget that reverses at ``speed`` for ``moving`` steps, then stands (speed
    0, never stopping) until ``steps``."""

    max_steps = 150

    def __init__(self, steps: int, moving: int, speed: float):
        super().__init__("reverse", steps, speed)
        self.moving = moving

    def act(self, measurement, goal, in_flight):
        step = super().act(measurement, goal, in_flight)
        if self.done > self.moving and not step.stop:
            return replace(step, trailer_speed=0.0, rear_speed=0.0)  # standing, not stopped
        return step


def test_a_stage_past_its_steps_goes_on_while_it_makes_its_way_and_stalls_once_it_does_not(monkeypatch):
    """A stage that has used its steps goes on while the trailer moved STALL_TRAVEL_M or more in the last
    STALL_WINDOW_S (a car the guard holds to a crawl finishes); one that stands ends stalled a window later."""
    from hitchpark.maneuver.loop import STALL_TRAVEL_M, STALL_WINDOW_S

    window = round(STALL_WINDOW_S / 0.1)
    slow = STALL_TRAVEL_M / STALL_WINDOW_S * 1.5  # half again the least way a window
    crawling = run(monkeypatch, Script([Crawling(steps=400, moving=400, speed=-slow)]), State(40.0, 0.0, 0.0, 0.0))
    assert crawling.stages[0].reason == "stopped" and crawling.stages[0].steps == 400  # 250 past its 150
    standing = run(monkeypatch, Script([Crawling(steps=400, moving=200, speed=-slow)]), State(40.0, 0.0, 0.0, 0.0))
    assert standing.reason == Outcome.STALLED.value
    # It stands from step 200 on (the speed ramps down over a sample or two): stalled once the last window's way
    # is less than the least, when less than 1 / 1.5 of the window was still moving.
    expected = 200 + window * (1.0 - 1.0 / 1.5)
    assert expected - 3 < standing.stages[0].steps < expected + 3
    too_slow = run(monkeypatch, Script([Crawling(steps=400, moving=400, speed=-slow / 2)]), State(40.0, 0.0, 0.0, 0.0))
    assert too_slow.reason == Outcome.STALLED.value and too_slow.stages[0].steps == 150  # at its steps
