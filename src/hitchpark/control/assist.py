"""Knob assist for backing up: the driver steers the trailer with a knob, the car turns its wheels.

The driver holds a knob ``k`` in [-1, 1] and a reverse speed request (a pedal, m/s, >= 0). The knob commands
the **trailer's path curvature** kappa (1/m, signed on the trailer's own heading: k > 0 bends its path to the
driver's left, k = 0 backs straight). Each tick :meth:`KnobAssist.step` turns the two into a front steer and a
rear-axle speed:

1. **Knob to curvature** (:meth:`KnobAssist.curvature_of`). By default ``kappa = k kappa_max``, linear in
   curvature: each knob step is the same curvature change at every knob position, and ``|k| = 1`` is
   ``kappa_max``, the tightest curvature this combination holds in a steady turn with margin (below).
   Ford's knob (US 9,809,250: spring return to a zero-curvature rest; US 9,505,434: the knob normalised so that
   a step is the same curvature change for any trailer) asks for a fixed gain, which cannot also give
   ``|k| = 1 = kappa_max`` for every trailer, since kappa_max shrinks as the trailer grows. We keep the issue's
   definition (the full knob is always the combination's full capability, nothing of the knob's travel is dead)
   as the default, and offer Ford's fixed gain as ``AssistSettings.curvature_per_knob`` (1/m per unit knob, the
   same for every trailer): the asked curvature is then clipped at ``kappa_max`` and the row says
   ``curvature_limited``.
2. **kappa_max from the model.** A steady turn of curvature kappa has the virtual steer
   ``delta_T = atan(L_T kappa)`` (Eq. 42: the trailer's yaw rate is V_T tan(delta_T) / L_T), the steady hitch
   :func:`~hitchpark.model.inverse.steady_hitch_from_virtual` and the front steer of Eq. (45). ``kappa_max`` is
   the largest kappa whose steady hitch stays ``hitch_margin_deg`` inside the jackknife limit ``max_hitch`` and
   whose steady front steer leaves ``steer_margin`` of ``max_steer`` for the feedback (bisection: both grow with
   kappa).
3. **Curvature followed.** The asked curvature is followed at most at ``curvature_rate`` times kappa_max per
   second (the hitch needs travel to follow; a knob flicked from lock to lock must not ask the wheels for more
   than they can give), and never beyond kappa_max.
4. **Steer, through the virtual steered axle.** ``delta_T = atan(L_T kappa) + hitch_gain (h_ref - h)`` with
   ``h_ref`` the steady hitch of the curvature followed and ``h`` the measured hitch (reversing, a larger
   delta_T raises the hitch rate, Eqs. 42-43), clipped to the steering-feasible range at ``h``
   (:func:`~hitchpark.model.inverse.virtual_steer_bounds`, Eqs. 56-57), then Eq. (45) gives the front steer
   (:func:`~hitchpark.model.inverse.front_steer_from_virtual`), within ``max_steer`` and moved from the last
   command by at most ``max_steer_rate dt``. Reversing under Eq. (45) the car follows the trailer's virtual
   axle, which is stable; the feedback adds damping against a delay, hitch noise and wrong lengths.
5. **Speed.** The request, at most ``max_speed``, is capped by GM's time-to-jackknife: at the hitch rate per
   metre that the actual steer, the steers in flight and the new one give (Eqs. 21, 24), the time to reach
   ``max_hitch - jackknife_margin_deg`` must stay above ``time_to_jackknife_s``, and the hitch's change over the
   stopping travel (the command's lag, then braking at half ``max_accel``) must fit in the room left. Among
   obstacles the :class:`~hitchpark.control.guard.Guard` caps it so that the car can stop before a body comes
   within ``min_clearance_m`` (+ ``margin_m``), rolling the model out over the stopping travel with the steer
   held and checking the bodies exactly; with an estimator in the loop, each configuration also with the
   estimate's doubt either side (``Measurement.doubt``), as the guard of a maneuver checks it. The speed command
   moves by at most ``max_accel dt`` per tick.

Each step says whether and how it overrode the driver (:data:`OVERRIDES`, the one that bound).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..checks import InputError, Integer, Real, build, check_fields, check_instance, check_range, checked
from ..model.inverse import (
    front_steer_from_virtual,
    steady_hitch_from_virtual,
    virtual_steer_bounds,
    virtual_steer_from_front,
)
from ..model.kinematics import full_rates, trailer_speed_from_rear_speed
from ..model.plant import Measurement
from ..model.scene import Scene
from ..model.state import clamp
from ..model.vehicle import VehicleTrailer, check_vehicle
from .guard import Guard, speed_for_travel
from .step import ControlStep

__all__ = ["OVERRIDES", "AssistSettings", "AssistStep", "KnobAssist", "max_curvature"]

#: What a step did to the driver's request, in the order of rank (the first that acts is recorded):
#: ``none``; ``stopped_for_obstacle`` / ``slowed_for_obstacle`` (the guard's speed cap bound, at standstill or
#: not); ``jackknife_prevented`` (the time-to-jackknife cap bound); ``speed_limited`` (the request was above
#: ``max_speed``); ``curvature_limited`` (the curvature followed is not yet, or cannot be, the one asked).
#: A row's ``override`` column is the index in this tuple.
OVERRIDES = (
    "none",
    "curvature_limited",
    "speed_limited",
    "slowed_for_obstacle",
    "jackknife_prevented",
    "stopped_for_obstacle",
)

#: Below this speed cap [m/s] the guard is said to stop the car rather than slow it.
STOP_SPEED = 0.02

#: Once the guard has stopped the car for an obstacle it keeps it stopped (a noisy reading that looks a little
#: clearer must not let it creep on, a centimetre at a time) until the driver lets go of the pedal or turns the
#: knob by this much from where it was at the stop: another request.
RELEASE_KNOB = 0.2

#: The widest virtual steer the steer law asks for [rad] (Eq. 57's bound; the front steer's limit is narrower).
VIRTUAL_LIMIT = math.radians(80.0)


@dataclass(frozen=True)
class AssistSettings:
    """How the knob assist drives (see the module text).

    Parameters
    ----------
    dt : float
        Sample time [s]. Default 0.1.
    max_speed : float
        Reverse speed limit [m/s]; a larger request is cut to it (``speed_limited``). Default 1.
    hitch_margin_deg : float
        The steady hitch of the full knob stays this far inside ``max_hitch`` [deg]. Default 10.
    steer_margin : float
        Fraction of ``max_steer`` the steady steer of the full knob leaves for the feedback. Default 0.15.
    hitch_gain : float
        Virtual steer per radian of hitch error [rad/rad]. Default 1.
    curvature_rate : float
        The curvature followed moves at most this many kappa_max per second. Default 1 (lock to lock in 2 s).
    curvature_per_knob : float
        0 (the default): ``kappa = k kappa_max``. > 0: a fixed gain [1/m per unit knob], the same for every
        trailer (Ford's normalisation), clipped at kappa_max.
    jackknife_margin_deg : float
        The speed cap keeps the hitch this far inside ``max_hitch`` [deg]. Default 4 (hitch sensors are good to
        0.5-1 deg).
    time_to_jackknife_s : float
        GM's threshold: the time to reach that limit at the current hitch rate stays above it [s]. Default 2.
    delay_steps : int
        The command delay the controller knows of [samples]. Default 0.
    min_clearance_m, margin_m : float
        Among obstacles the guard keeps the bodies ``min_clearance_m + margin_m`` from the scene [m].
        Defaults 0.2 and 0.03 (those of the parking maneuver).
    """

    dt: float = checked(0.1, Real(0.0, 1.0, low_open=True, unit="s"))
    max_speed: float = checked(1.0, Real(0.0, 5.0, low_open=True, unit="m/s"))
    hitch_margin_deg: float = checked(10.0, Real(0.0, 45.0, unit="deg"))
    steer_margin: float = checked(0.15, Real(0.0, 0.9))
    hitch_gain: float = checked(1.0, Real(0.0, 10.0))
    curvature_rate: float = checked(1.0, Real(0.0, 100.0, low_open=True, unit="kappa_max/s"))
    curvature_per_knob: float = checked(0.0, Real(0.0, 10.0, unit="1/m"))
    jackknife_margin_deg: float = checked(4.0, Real(0.0, 30.0, unit="deg"))
    time_to_jackknife_s: float = checked(2.0, Real(0.0, 60.0, unit="s"))
    delay_steps: int = checked(0, Integer(0, 50))
    min_clearance_m: float = checked(0.2, Real(0.0, 5.0, unit="m"))
    margin_m: float = checked(0.03, Real(0.0, 5.0, unit="m"))

    def __post_init__(self) -> None:
        check_fields(self, "assist.")

    @classmethod
    def from_dict(cls, data: object, what: str = "assist") -> AssistSettings:
        return build(cls, data, what)


@dataclass(frozen=True, kw_only=True)
class AssistStep(ControlStep):
    """A :class:`ControlStep` with what the assist made of the driver's request: the ``override`` (one of
    :data:`OVERRIDES`), the ``knob`` and ``speed_request`` it was given, the curvature asked and the one followed
    [1/m], the hitch it steers towards [rad] and the speed cap [m/s]."""

    override: str = "none"
    knob: float = 0.0
    speed_request: float = 0.0
    curvature_asked: float = 0.0
    curvature_followed: float = 0.0
    hitch_target: float = 0.0
    speed_cap: float = math.inf

    @property
    def columns(self) -> dict[str, float]:
        """The row's assist columns (``override`` as its index in :data:`OVERRIDES`)."""
        return {
            "knob": self.knob,
            "speed_request": self.speed_request,
            "override": float(OVERRIDES.index(self.override)),
            "curvature_asked": self.curvature_asked,
            "curvature_cmd": self.curvature_followed,
        }


def _steady_front_steer(vehicle: VehicleTrailer, curvature: float) -> tuple[float, float]:
    """(steady hitch, steady front steer) of a turn of the trailer axle of ``curvature`` (Eqs. 42, 43, 45)."""
    virtual = math.atan(vehicle.trailer_length * curvature)
    hitch = steady_hitch_from_virtual(vehicle, virtual)
    return hitch, float(front_steer_from_virtual(vehicle, hitch, virtual))


def max_curvature(vehicle: VehicleTrailer, hitch_margin: float, steer_margin: float) -> float:
    """The tightest curvature [1/m] of the trailer axle this combination holds in a steady turn with its hitch
    ``hitch_margin`` [rad] inside ``max_hitch`` and its front steer within ``(1 - steer_margin) max_steer``."""
    check_vehicle(vehicle).require_hitch_offset()
    hitch_cap = vehicle.max_hitch - hitch_margin
    steer_cap = (1.0 - steer_margin) * vehicle.max_steer
    if hitch_cap <= 0.0 or steer_cap <= 0.0:
        raise InputError(f"the margins leave no steady turn: hitch up to {hitch_cap:.3g} rad, steer {steer_cap:.3g}")
    low, high = 0.0, math.tan(math.radians(89.0)) / vehicle.trailer_length
    for _ in range(60):  # both the steady hitch and the steady steer grow with the curvature
        mid = 0.5 * (low + high)
        hitch, steer = _steady_front_steer(vehicle, mid)
        low, high = (mid, high) if hitch <= hitch_cap and abs(steer) <= steer_cap else (low, mid)
    return low


class KnobAssist:
    """Turns a knob (trailer curvature) and a speed request into a command, each tick (see the module text).

    ``KnobAssist(vehicle, settings, scene).step(measurement, knob, speed_request)`` in any loop that senses and
    applies once per ``settings.dt``; ``scene`` (optional) makes it stop for obstacles. It remembers its last
    command (for the rate limits): call :meth:`reset` when a new drive starts.
    """

    def __init__(self, vehicle: VehicleTrailer, settings: AssistSettings | None = None, scene: Scene | None = None):
        self.vehicle = check_vehicle(vehicle)
        vehicle.require_hitch_offset()
        self.settings = AssistSettings() if settings is None else settings
        check_instance("settings", self.settings, AssistSettings, "hitchpark.assist.AssistSettings(...)")
        s = self.settings
        self.kappa_max = max_curvature(vehicle, math.radians(s.hitch_margin_deg), s.steer_margin)
        self.guard: Guard | None = None
        if scene is not None and not check_instance("scene", scene, Scene).is_empty:
            self.guard = Guard(vehicle, scene, s.min_clearance_m, s.margin_m, s.dt, s.delay_steps)
        self.reset()

    def reset(self, front_steer: float = 0.0, rear_speed: float = 0.0) -> None:
        """Start a drive: the last command is ``(rear_speed, front_steer)``, the curvature followed is 0."""
        self.steer, self.speed = float(front_steer), float(rear_speed)
        self.curvature = 0.0
        self.in_flight: list[float] = [self.steer] * self.settings.delay_steps
        self.stopped_at: float | None = None  # the knob when the guard stopped the car (None: not stopped)

    def curvature_of(self, knob: float) -> float:
        """The curvature [1/m] the knob asks for (before the limit to kappa_max)."""
        gain = self.settings.curvature_per_knob or self.kappa_max
        return knob * gain

    def step(self, measurement: Measurement, knob: float, speed_request: float) -> AssistStep:
        """The command for the next sample, and what it did to the request (see the module text)."""
        check_instance("measurement", measurement, Measurement, "hitchpark.model.Measurement(...)")
        knob = check_range("knob", knob, -1.0, 1.0)
        speed_request = check_range("speed_request", speed_request, 0.0, 30.0, unit="m/s (reverse)")
        state = measurement.state
        for name, value in (("hitch", state.hitch), ("front_steer", measurement.front_steer)):
            check_range(f"measurement {name}", value, -math.pi / 2, math.pi / 2, unit="rad")
        s, v, dt = self.settings, self.vehicle, self.settings.dt
        h = state.hitch

        # 1-3. The curvature asked, limited, followed at a bounded rate.
        asked = self.curvature_of(knob)
        target = clamp(asked, -self.kappa_max, self.kappa_max)
        rate = s.curvature_rate * self.kappa_max * dt
        self.curvature = clamp(target, self.curvature - rate, self.curvature + rate)
        curvature_limited = abs(asked - self.curvature) > 0.02 * self.kappa_max

        # 4. Virtual steer with hitch feedback, Eq. (45), the steer limits.
        virtual0 = math.atan(v.trailer_length * self.curvature)
        h_ref = steady_hitch_from_virtual(v, virtual0)
        low, high = virtual_steer_bounds(v, h, VIRTUAL_LIMIT)
        virtual = clamp(virtual0 + s.hitch_gain * (h_ref - h), low, high)
        steer = float(front_steer_from_virtual(v, h, virtual))
        steer = clamp(steer, -v.max_steer, v.max_steer)
        steer = clamp(steer, self.steer - v.max_steer_rate * dt, self.steer + v.max_steer_rate * dt)

        # 5. Speed: the request, the jackknife cap, the guard's cap.
        want = min(speed_request, s.max_speed)
        steers = (float(measurement.front_steer), *self.in_flight, steer)
        jack_cap = self._jackknife_cap(h, steers)
        if self.stopped_at is not None and (want <= 0.0 or abs(knob - self.stopped_at) >= RELEASE_KNOB):
            self.stopped_at = None  # the driver let go, or asks for another path: the guard looks again
        guard_cap = 0.0 if self.stopped_at is not None else self._guard_cap(measurement, steers, want)
        if guard_cap <= STOP_SPEED and want > 0.0 and self.stopped_at is None:
            self.stopped_at = knob
        speed = min(want, jack_cap, guard_cap)
        rear = clamp(-speed, self.speed - v.max_accel * dt, self.speed + v.max_accel * dt)
        rear = 0.0 if abs(rear) < 1e-9 else rear  # the ramp's rounding: a stop is a stop
        if not (math.isfinite(rear) and math.isfinite(steer)):  # cannot happen with finite checked inputs
            rear, steer = clamp(0.0, self.speed - v.max_accel * dt, self.speed + v.max_accel * dt), self.steer

        if guard_cap < want and guard_cap <= jack_cap:
            override = "stopped_for_obstacle" if guard_cap <= STOP_SPEED else "slowed_for_obstacle"
        elif jack_cap < want:
            override = "jackknife_prevented"
        elif speed_request > s.max_speed:
            override = "speed_limited"
        elif curvature_limited:
            override = "curvature_limited"
        else:
            override = "none"
        self.steer, self.speed = steer, rear
        if self.in_flight:
            self.in_flight = [*self.in_flight[1:], steer]
        return AssistStep(
            trailer_speed=float(trailer_speed_from_rear_speed(v, h, rear, steer)),
            virtual_steer=float(virtual_steer_from_front(v, h, steer)),
            rear_speed=rear,
            front_steer=steer,
            ok=True,
            stop=False,
            status="" if override == "none" else override,
            override=override,
            knob=knob,
            speed_request=speed_request,
            curvature_asked=asked,
            curvature_followed=self.curvature,
            hitch_target=h_ref,
            speed_cap=min(jack_cap, guard_cap),
        )

    def _jackknife_cap(self, hitch: float, steers: tuple[float, ...]) -> float:
        """GM's time-to-jackknife cap [m/s] at the worst of ``steers`` (see the module text)."""
        s, v = self.settings, self.vehicle
        limit = v.max_hitch - math.radians(s.jackknife_margin_deg)
        lag = (s.delay_steps + 1) * s.dt
        cap = math.inf
        for steer in steers:
            yaw_v, yaw_t, _ = full_rates(v, hitch, -1.0, steer)  # per metre reversed
            per_m = yaw_v - yaw_t
            if abs(per_m) < 1e-9:
                continue
            room = limit - math.copysign(1.0, per_m) * hitch  # to the limit the hitch moves towards
            if room <= 0.0:
                return 0.0
            travel = room / abs(per_m)
            time_cap = travel / s.time_to_jackknife_s if s.time_to_jackknife_s > 0 else math.inf
            cap = min(cap, time_cap, speed_for_travel(travel, 0.5 * v.max_accel, lag))
        return cap

    def _guard_cap(self, measurement: Measurement, steers: tuple[float, ...], want: float) -> float:
        """The guard's speed cap [m/s] among obstacles (inf without a scene), the estimate's doubt allowed for as
        the guard allows for it (``Measurement.doubt``: 0 with exact readings)."""
        if self.guard is None or want <= 0.0:
            return math.inf
        g, st = self.guard, measurement.state
        config = np.array([st.x, st.y, st.yaw, st.hitch])
        estimated, doubtful = g.clearances(config[None, :], measurement.doubt)
        g.least = min(g.least, float(estimated[0]))
        now = float(doubtful[0])
        if now < g.need:
            return 0.0
        cap = g.max_speed(now - g.need)
        if want <= cap:
            return math.inf
        free = g.free_travel(config, -1.0, (steers[0], steers[-1]), g.stopping_travel(want), measurement.doubt)
        cap = max(cap, g.speed_for_travel(free))
        return math.inf if want <= cap else cap
