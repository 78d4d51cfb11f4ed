"""A guard between a stage's controller and the car: it keeps the bodies clear of the scene.

Every command a controller asks is checked, before it is issued, against the obstacles and the area
(:class:`~hitchpark.model.collision.SceneChecker`, exact geometry) at the measured configuration and,
when the controller predicts (the NMPC's horizon), at every predicted one. Too close means a body
within ``min_clearance_m + margin_m`` of the scene: the guard then stops the car (``ok`` False, the
stage ends, the process plans again from where the car stands). Otherwise it slows the car so that it
could stop before it gets that close: the rear axle's speed v satisfies
``k (v (delay + 1) dt + v^2 / (2 a)) <= clearance - min_clearance_m - margin_m``, with ``a`` half the
acceleration limit (the loop's braking) and ``k`` = :data:`BODY_SPEED_RATIO` (a corner of a body moves
faster than the rear axle when the car turns): a bound whatever way the bodies move. Where they move along
the scene or away from it, that bound would hold the car to a crawl it need not keep. For a controller that
predicts nothing (the path tracker, pure pursuit, the knob assist) the guard also drives the model
(Eqs. 19-24) on from the measured configuration, the steer held at what the car has and at what is asked,
over the rear axle's stopping travel at the asked speed, and allows the speed whose stopping travel keeps
``min_clearance_m + margin_m`` on both (each sample that and half a body's travel between samples); the larger
of the two caps holds. The NMPC's own horizon is checked instead, and its speed keeps the bound: with the
roll-out under the NMPC too, it came faster into a tight garage and stopped off the goal more often
(``alley_garage``, measured on its failing starts).

A stage that begins nearer the scene than ``min_clearance_m + margin_m`` (:meth:`Guard.begin`: a stop's
overshoot, a noisy reading) would be stopped at its first command, and the car could never leave; one that
begins just clear of it, at its first wobble. Such a stage (less than :data:`ESCAPE_MARGIN_M` clear of that)
keeps what it begins with less :data:`ESCAPE_MARGIN_M`, never less than ``min_clearance_m``. Its plan keeps
about as much (the planner's start slack), so the car moves away along it.

The configuration the guard checks is an estimate (:class:`~hitchpark.control.estimator.Estimator`), and the
truth may be as far from it as the estimate's doubt (``Measurement.doubt``: the sensors' noise, the model's
lengths). So each configuration, measured or predicted, is checked also with each doubtful component moved by
its doubt either side, and the least of these is the clearance the rules above keep: a hitch 1 deg off moves the
car's front corners 8-9 cm. The estimate itself still keeps ``min_clearance_m``, and a stage that begins with
its doubtful clearance below that (after a stop's overshoot, or the doubt grown while it stood) keeps what it
begins with less :data:`ESCAPE_MARGIN_M`: the car may move away, not nearer. With exact readings (no estimator,
the default) the doubt is 0 and the rules are as above.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from ..model.checker import SceneChecker
from ..model.integrate import rk4
from ..model.kinematics import full_rhs
from ..model.plant import Measurement
from ..model.scene import Scene
from ..model.state import Pose, from_goal_frame
from ..model.vehicle import VehicleTrailer
from .step import ControlStep

__all__ = [
    "BODY_SPEED_RATIO",
    "CLEARANCE_SPARE_M",
    "ESCAPE_MARGIN_M",
    "NO_DOUBT",
    "ROLLOUT_STEP_M",
    "Guard",
    "speed_for_travel",
]

#: How much faster than the rear axle a point of a body can move, at most, in a parking maneuver:
#: the car's front corners sweep about 1.6 times the axle's speed at full lock (Table 4's lengths).
BODY_SPEED_RATIO = 2.0

#: The rear axle's travel between the samples of the guard's roll-out of a stop [m]; a body's point moves at
#: most :data:`BODY_SPEED_RATIO` times as far, so the clearance between two samples is at most half that lower
#: than at the nearer one, and each sample must keep that much more.
ROLLOUT_STEP_M = 0.01


#: The NMPC's predictions keep this much more than the guard asks [m]: the guard then never stops a plan
#: the solver kept clear to its tolerance.
CLEARANCE_SPARE_M = 0.01

#: A stage that begins nearer than the guard's clearance keeps what it begins with less this [m] (the planner's
#: path from there keeps its start's clearance less 1 cm; this leaves the tracking another centimetre).
ESCAPE_MARGIN_M = 0.02

#: The doubt of a configuration taken as exact (x_t, y_t, yaw_t, hitch).
NO_DOUBT = (0.0, 0.0, 0.0, 0.0)


def speed_for_travel(travel: float, decel: float, lag: float) -> float:
    """Largest speed [m/s] that travels at most ``travel`` [m] to standstill: ``lag`` seconds at that speed, then
    braking at ``decel`` [m/s^2] (``lag v + v^2 / (2 decel) <= travel``); 0 for no room."""
    if travel <= 0.0:
        return 0.0
    return -decel * lag + math.sqrt((decel * lag) ** 2 + 2.0 * decel * travel)


class Guard:
    """Checks and slows commands near the scene (see the module text)."""

    def __init__(
        self, vehicle: VehicleTrailer, scene: Scene, min_clearance_m: float, margin_m: float, dt: float, delay: int
    ):
        self.vehicle, self.dt, self.delay = vehicle, dt, delay
        self.need = min_clearance_m + margin_m
        self.floor = min_clearance_m
        self.stage_need = self.need  # what the stage under way keeps (:meth:`begin`)
        self.checker = SceneChecker(vehicle, scene)
        self.least = math.inf  # least clearance seen, for the record

    def clearances(self, configs: np.ndarray, doubt: Sequence[float] = NO_DOUBT) -> tuple[np.ndarray, np.ndarray]:
        """Each configuration's (rows x_t, y_t, yaw_t, hitch) clearance [m], and the least of it and of it with each
        component moved by ``doubt`` (a measurement's) either side (the module text)."""
        configs = np.asarray(configs, dtype=float)
        moved = [configs]
        for i, d in enumerate(doubt):
            if d == 0.0:
                continue
            for sign in (-1.0, 1.0):
                shifted = configs.copy()
                shifted[:, i] += sign * d
                moved.append(shifted)
        clear = self.checker.clearances(np.vstack(moved)).reshape(len(moved), len(configs))
        return clear[0], clear.min(axis=0)

    def doubt_gap(self, measurement: Measurement) -> tuple[float, float]:
        """The measured configuration's clearance as estimated [m], and how much less it is with its doubt allowed
        for (0 without a doubt)."""
        s = measurement.state
        estimated, doubtful = self.clearances(np.array([[s.x, s.y, s.yaw, s.hitch]]), measurement.doubt)
        return float(estimated[0]), float(estimated[0] - doubtful[0])

    def begin(self, measurement: Measurement) -> float:
        """A stage begins at ``measurement``: from here on it keeps the guard's clearance, or, when it begins less
        than :data:`ESCAPE_MARGIN_M` clearer than that, what it begins with less that margin (at least
        ``min_clearance_m``; a start whose doubtful clearance is below that, what it begins with less the margin).
        Returns what the doubtful clearance keeps [m]."""
        s = measurement.state
        now = float(self.clearances(np.array([[s.x, s.y, s.yaw, s.hitch]]), measurement.doubt)[1][0])
        self.stage_need = max(self.floor, min(self.need, now - ESCAPE_MARGIN_M))
        if now < self.floor and any(measurement.doubt):  # the estimate itself still keeps the floor (:meth:`check`)
            self.stage_need = now - ESCAPE_MARGIN_M
        return self.stage_need

    def max_speed(self, room: float) -> float:
        """Largest rear-axle speed [m/s] that can stop within ``room`` metres of body travel."""
        return self.speed_for_travel(room / BODY_SPEED_RATIO)

    def stopping_travel(self, speed: float) -> float:
        """The rear axle's travel [m] from the command at ``speed`` to standstill: the lag, then braking at a/2."""
        speed = abs(speed)
        return (self.delay + 1) * self.dt * speed + speed * speed / self.vehicle.max_accel

    def free_travel(
        self,
        state: np.ndarray,
        direction: float,
        steers: tuple[float, ...],
        travel: float,
        doubt: Sequence[float] = NO_DOUBT,
    ) -> float:
        """How far [m] the rear axle can travel from ``state`` (x_t, y_t, yaw_t, hitch) in ``direction`` with each
        front steer of ``steers`` held, up to ``travel``, while every body keeps the guard's clearance (and the
        step's margin), ``state``'s ``doubt`` allowed for: ``travel`` if it keeps it all the way, 0 if not even the
        first step does."""
        n = max(1, math.ceil(travel / ROLLOUT_STEP_M))
        ds = travel / n
        inputs = np.array([[math.copysign(1.0, direction)] * len(steers), list(steers)])
        x = np.repeat(np.asarray(state, dtype=float)[:, None], len(steers), axis=1)
        samples = []
        for _ in range(n):  # RK4 over the rear axle's travel (unit speed), every steer at once
            x = rk4(lambda y: full_rhs(self.vehicle, y, inputs), x, ds, substeps=1)
            samples.append(x.T)
        clear = self.clearances(np.vstack(samples), doubt)[1].reshape(n, len(steers)).min(axis=1)
        short = np.flatnonzero(clear < self.stage_need + BODY_SPEED_RATIO * ds / 2.0)
        return travel if not len(short) else float(short[0]) * ds

    def speed_for_travel(self, travel: float) -> float:
        """Largest rear-axle speed [m/s] whose :meth:`stopping_travel` is at most ``travel``."""
        return speed_for_travel(travel, 0.5 * self.vehicle.max_accel, (self.delay + 1) * self.dt)

    def clear(self, configs: np.ndarray) -> bool:
        """Whether every configuration (rows x_t, y_t, yaw_t, hitch) of a plan keeps ``min_clearance_m +
        margin_m`` (as planned: no measurement's doubt)."""
        return bool(np.all(self.checker.clearances(np.asarray(configs, dtype=float)) >= self.need))

    def check(self, measurement: Measurement, goal: Pose, step: ControlStep) -> ControlStep:
        """``step`` as is, slowed, or turned into a stop when it would bring a body too close."""
        if not step.ok or step.stop:
            return step
        s = measurement.state
        configs = [np.array([s.x, s.y, s.yaw, s.hitch])]
        predicted = step.predicted_states
        if predicted.ndim == 2 and predicted.shape[0] > 1 and predicted.shape[1] >= 4:
            x, y, yaw = from_goal_frame(goal, predicted[1:, 0], predicted[1:, 1], predicted[1:, 2])
            configs.append(np.column_stack([x, y, yaw, predicted[1:, 3]]))
        estimated, doubtful = self.clearances(np.vstack(configs), measurement.doubt)
        self.least = min(self.least, float(estimated[0]))
        for clearance, keep in ((doubtful, self.stage_need), (estimated, self.floor)):
            now, ahead = float(clearance[0]), float(clearance.min())
            if ahead < keep:
                return replace(
                    step,
                    rear_speed=0.0,
                    trailer_speed=0.0,
                    ok=False,
                    stop=True,
                    status=f"guard: too close to the scene: {ahead:.2f} m {'now' if now < keep else 'ahead'}",
                )
        now = float(doubtful[0])
        cap = self.max_speed(now - self.stage_need)
        if abs(step.rear_speed) <= cap:
            return step
        if len(configs) == 1:  # a controller that predicts nothing: the roll-out (see the module text)
            # The bound holds whatever way the bodies move; along the scene or away from it they may go faster.
            state = np.array([s.x, s.y, s.yaw, s.hitch])
            steers = (float(measurement.front_steer), float(step.front_steer))
            travel = self.stopping_travel(step.rear_speed)
            free = self.free_travel(state, step.rear_speed, steers, travel, measurement.doubt)
            cap = max(cap, self.speed_for_travel(free))
            if abs(step.rear_speed) <= cap:
                return step
        scale = cap / abs(step.rear_speed)
        return replace(step, rear_speed=step.rear_speed * scale, trailer_speed=step.trailer_speed * scale)
