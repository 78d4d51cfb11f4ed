"""A live knob-assisted drive, one tick at a time, for a person at a page (``hitchpark drive``).

:class:`LiveDrive` is the same closed loop as :func:`~.assisted.drive_assisted` (``plant.sense ->
assist.step -> plant.apply``, recorded row by row with the assist's columns), driven by whatever the person's
knob and speed key say at each tick instead of a profile. :meth:`LiveDrive.stop` (Esc) sets the request to zero
from the next tick on: the car brakes at its acceleration limit and the drive ends, ``stopped_by_driver``, once
it stands. :meth:`LiveDrive.result` is the drive as a :class:`~.result.ManeuverResult` (``maneuver.json``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..checks import check_range
from ..control.assist import AssistSettings, KnobAssist
from ..model.geometry import body_outlines
from ..model.kinematics import full_rates
from .assisted import AssistStage, KnobProfile, assisted_loop, assisted_result
from .judge import stage_result
from .result import ManeuverResult, Outcome
from .scenario import Scenario
from .stages import StageEnd

__all__ = ["LiveDrive"]


class LiveDrive:
    """A drive from a scenario's start among its obstacles, ticked by the caller (see the module text)."""

    def __init__(self, scenario: Scenario, max_time: float = 600.0):
        self.scenario = sc = scenario
        self.max_time = check_range("max_time", max_time, 0.0, 3600.0, low_open=True, unit="s")
        s = sc.settings
        self.settings = AssistSettings(
            dt=s.nmpc.dt,
            delay_steps=sc.plant.delay_steps,
            min_clearance_m=s.success.min_clearance_m,
            margin_m=s.process.guard_margin_m,
        )
        self.loop = assisted_loop(sc.vehicle, sc.start, sc.goal, sc.plant, self.settings.dt, self.max_time, s.estimator)
        self.assist = KnobAssist(sc.vehicle, self.settings, sc.scene)
        # The profile is a placeholder: the stage is used for its record (kind, controller), the knob comes live.
        self.stage = AssistStage(self.assist, KnobProfile(np.zeros(1), np.zeros(1), np.zeros(1)))
        self.stopping = False
        self.knob = 0.0
        self.ending: Outcome | None = None
        self._result: ManeuverResult | None = None

    @property
    def dt(self) -> float:
        return self.settings.dt

    @property
    def done(self) -> bool:
        return self.ending is not None

    def stop(self) -> None:
        """The driver's stop (Esc): no more speed from the next tick; the drive ends when the car stands."""
        self.stopping = True

    def tick(self, knob: float, speed_request: float) -> dict[str, Any]:
        """One sample with the person's knob and request; what the page shows of it."""
        if self.done:
            return self.view(None)
        loop, plant = self.loop, self.loop.plant
        if self.stopping and loop.last.rear_speed == 0.0 and plant.stopped():
            self.ending = Outcome.STOPPED_BY_DRIVER
            return self.view(None)
        if loop.out_of_time():
            self.ending = Outcome.TIMEOUT
            return self.view(None)
        m = loop.sense()
        self.knob = knob
        step = self.assist.step(m, knob, 0.0 if self.stopping else speed_request)
        if not loop.step(0, m, loop.limited(step.command), step):
            self.ending = Outcome.JACKKNIFE
        return self.view(step)

    def view(self, step: Any) -> dict[str, Any]:
        """The car now, and what the last step made of the request (a JSON object for the page)."""
        plant, v = self.loop.plant, self.loop.plant.vehicle
        x = plant.configuration
        bodies = body_outlines(v, *(float(c) for c in x))
        _, yaw_rate_t, v_t = full_rates(v, float(x[3]), plant.rear_speed, plant.front_steer)
        curvature = yaw_rate_t / v_t if abs(v_t) > 0.05 else None
        out: dict[str, Any] = {
            "t": plant.t,
            "state": [float(c) for c in x],
            "vehicle": bodies["vehicle"][:-1].round(4).tolist(),
            "trailer": bodies["trailer"][:-1].round(4).tolist(),
            "hitch_deg": math.degrees(x[3]),
            "front_steer_deg": math.degrees(plant.front_steer),
            "speed": plant.rear_speed,
            "curvature": curvature,
            "stopping": self.stopping,
            "done": self.ending.value if self.ending else None,
        }
        if step is not None:
            out.update(
                knob=step.knob,
                speed_request=step.speed_request,
                curvature_asked=step.curvature_asked,
                curvature_cmd=step.curvature_followed,
                override=step.override,
            )
        return out

    def result(self) -> ManeuverResult:
        """The drive so far as a maneuver (ending it: a drive still rolling is stopped first, as by Esc)."""
        if self._result is None:
            loop = self.loop
            self.stop()
            while not self.done:  # a drive left rolling brakes within the limits, as after Esc
                self.tick(self.knob, 0.0)
            assert self.ending is not None
            loop.outcome = loop.outcome or self.ending
            end = StageEnd("reverse", "assist", self.ending.value)
            record = stage_result(self.stage, end, loop, 0)
            sc = self.scenario
            self._result = assisted_result(
                loop, record, sc.vehicle, sc.start, sc.settings, sc.plant, sc.scene, f"drive {sc.name}"
            )
        return self._result
