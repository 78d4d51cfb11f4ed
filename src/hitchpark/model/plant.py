"""The plant: the real car with its trailer, steering and speed actuators and sensors, apart from any controller.

The controller has a model (a :class:`~.vehicle.VehicleTrailer` it believes in); the plant
is what it drives: its own vehicle (lengths that may differ from the model's), a steering
actuator with a rate limit and a first-order lag, a speed actuator with an acceleration
limit, a command delay of whole samples, and sensors with seeded noise and a bias. Faults
and mismatch are settings of :class:`PlantSettings`, not forks of the loop.

The closed loop reads ``plant.sense() -> controller.step() -> plant.apply()``.

Actuators, within one sample of length dt with the command held (exact solutions, so the
steer rate can never exceed its limit):

- steer: d(delta)/dt = clip((delta_cmd - delta) / tau, -r, r): at the rate limit r until the
  error is r tau, then exponentially with time constant tau (tau = 0: a pure rate limit);
- speed: V_R moves towards the command at the acceleration limit and holds it.

The kinematics (Eqs. 19-24) are integrated with RK4 under these input profiles. The
``"ideal"`` kind is the paper's plant: the command acts at once and is held over the sample.
"""

from __future__ import annotations

import functools
import math
from collections import deque
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np

from ..checks import Choice, InputError, Integer, Real, build, check_fields, checked
from ..io import read_toml
from ..native import native
from .integrate import PLANT_SUBSTEPS, plant_function, rk4_timed
from .kinematics import full_rhs
from .state import State, check_state, clamp
from .vehicle import VehicleTrailer, vehicle_from_dict

__all__ = ["IDEAL", "PLANT_KINDS", "Command", "Measurement", "Plant", "PlantSettings", "case_seed", "load_plant"]

#: The kinds of plant: ``"realistic"`` (actuator dynamics) and ``"ideal"`` (the paper's: commands act at once).
PLANT_KINDS = ("realistic", "ideal")


@dataclass(frozen=True)
class PlantSettings:
    """What the simulated car is. Defaults: a realistic car (electric power steering moves the road wheels at
    30-40 deg/s in parking assists and lags about 0.1 s), no delay, perfect sensors.

    Parameters
    ----------
    kind : str
        ``"realistic"`` (actuator dynamics below) or ``"ideal"`` (the paper's plant: the command
        acts at once and is held over the sample; delay and sensor settings still apply).
    vehicle : mapping
        The real vehicle's :class:`VehicleTrailer` fields that differ from the controller's
        (e.g. ``{"hitch_offset": 1.27}``); fields not given are the controller's.
    steer_rate_max : float
        Road-wheel steer rate limit of the steering actuator [rad/s], > 0. Default 0.6 (34 deg/s).
    steer_time_constant : float
        First-order lag of the steering actuator [s], >= 0. Default 0.1.
    accel_max : float
        Acceleration limit of the speed actuator [m/s^2], > 0. Default 1.
    delay_steps : int
        Samples between a command being issued and acted on, >= 0. Default 0.
    hitch_noise_std_deg, yaw_noise_std_deg : float
        Standard deviation of the Gaussian noise on the measured hitch angle / trailer yaw [deg].
    position_noise_std_m : float
        Standard deviation of the Gaussian noise on the measured trailer-axle x and y [m].
    hitch_bias_deg : float
        Constant offset of the hitch-angle sensor [deg].
    seed : int
        Noise seed; each maneuver draws from a stream seeded by this and its start (:func:`case_seed`).
    """

    kind: str = checked("realistic", Choice(PLANT_KINDS))
    vehicle: Mapping[str, float] = field(default_factory=dict, hash=False)
    steer_rate_max: float = checked(0.6, Real(0.0, 10.0, low_open=True, unit="rad/s"))
    steer_time_constant: float = checked(0.1, Real(0.0, 2.0, unit="s"))
    accel_max: float = checked(1.0, Real(0.0, 20.0, low_open=True, unit="m/s^2"))
    delay_steps: int = checked(0, Integer(0, 50))
    hitch_noise_std_deg: float = checked(0.0, Real(0.0, 10.0, unit="deg"))
    position_noise_std_m: float = checked(0.0, Real(0.0, 5.0, unit="m"))
    yaw_noise_std_deg: float = checked(0.0, Real(0.0, 10.0, unit="deg"))
    hitch_bias_deg: float = checked(0.0, Real(-20.0, 20.0, unit="deg"))
    seed: int = checked(0, Integer(0, 2**63 - 1))

    def __post_init__(self) -> None:
        check_fields(self, "plant.")
        vehicle_from_dict(self.vehicle, what="plant.vehicle")  # unknown or bad fields fail here, not mid-maneuver
        object.__setattr__(self, "vehicle", dict(self.vehicle))

    def resolve_vehicle(self, model: VehicleTrailer) -> VehicleTrailer:
        """The real vehicle: the controller's ``model`` with this plant's vehicle fields on top, its lengths exact
        (``length_tolerance`` 0: the tolerance is the controller's doubt, not the car's)."""
        real = vehicle_from_dict(dict(self.vehicle), model) if self.vehicle else model
        return replace(real, length_tolerance=0.0) if real.length_tolerance else real

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], what: str = "plant") -> PlantSettings:
        """From a ``[plant]`` table (``vehicle`` a nested table); unknown keys are refused."""
        return build(cls, data, what)


#: The paper's plant: commands act at once, no delay, perfect sensors.
IDEAL = PlantSettings(kind="ideal")


def load_plant(path: str | Path) -> PlantSettings:
    """Read plant settings from a TOML file: the keys at the top level or under ``[plant]``."""
    path = Path(path)
    data = read_toml(path, "plant")
    if set(data) == {"plant"} and isinstance(data["plant"], dict):
        data = data["plant"]
    try:
        return PlantSettings.from_dict(data)
    except ValueError as exc:
        raise InputError(f"plant file {path}: {exc}") from None


def case_seed(seed: int, start: State) -> np.random.SeedSequence:
    """The noise stream of one maneuver: from the plant's seed and the start's exact bits.

    The same start gives the same noise alone, in a sweep on a process pool or on Dask.
    """
    bits = np.frombuffer(start.as_array().tobytes(), dtype=np.uint32)
    return np.random.SeedSequence([int(seed), *(int(b) for b in bits)])


@dataclass(frozen=True)
class Command:
    """What a controller asks of the car for the next sample: rear-axle speed [m/s] and front steer [rad]."""

    rear_speed: float
    front_steer: float


@dataclass(frozen=True)
class Measurement:
    """What the controller sees: the sensed configuration and the actuators' actual state.

    ``state`` carries the sensor noise and bias; ``front_steer`` (the steering angle sensor)
    and ``rear_speed`` (the wheel speeds) are exact. ``doubt`` is how far each of the configuration's x_t, y_t
    [m], yaw_t and hitch [rad] may be from the truth (an estimator's bound,
    :class:`~hitchpark.control.estimator.Estimator`); a reading as it comes is taken as exact (0).
    """

    t: float
    state: State
    front_steer: float
    rear_speed: float
    doubt: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)


def _steer_profile(delta0: Any, target: Any, tau: Any, rate: Any, t: Any) -> Any:
    """Road-wheel angle t after the start of a sample: rate-limited first-order lag (see the module text)."""
    e0 = target - delta0
    sign = ca.sign(e0)
    tau = ca.fmax(tau, 1e-9)  # tau = 0: the exponential phase vanishes, a pure rate limit remains
    band = rate * tau  # below this error the lag is slower than the rate limit
    t1 = ca.fmax(ca.fabs(e0) - band, 0.0) / rate  # end of the rate-limited phase
    ramp = delta0 + sign * rate * ca.fmin(t, t1)
    decay = target - sign * ca.fmin(ca.fabs(e0), band) * ca.exp(-ca.fmax(t - t1, 0.0) / tau)
    return ca.if_else(t <= t1, ramp, decay)


def _speed_profile(v0: Any, target: Any, accel: Any, t: Any) -> Any:
    """Rear-axle speed t after the start of a sample: towards the command at the acceleration limit."""
    return v0 + ca.fmax(ca.fmin(target - v0, accel * t), -accel * t)


@functools.lru_cache(maxsize=64)
def actuated_plant_function(vehicle: VehicleTrailer, substeps: int = PLANT_SUBSTEPS) -> ca.Function:
    """``F(x, act, cmd, par) -> (x_next, act_next)``: one sample of the realistic plant.

    ``x`` the full-model state (4), ``act`` the actual (steer, speed), ``cmd`` the commanded
    (speed, steer), ``par`` = (tau, steer rate limit, acceleration limit, dt).
    """
    x, act, cmd, par = ca.SX.sym("x", 4), ca.SX.sym("act", 2), ca.SX.sym("cmd", 2), ca.SX.sym("par", 4)
    tau, rate, accel, dt = par[0], par[1], par[2], par[3]
    target = ca.fmax(ca.fmin(cmd[1], vehicle.max_steer), -vehicle.max_steer)  # the rack's end stops

    def inputs(t: Any) -> Any:
        return ca.vertcat(_speed_profile(act[1], cmd[0], accel, t), _steer_profile(act[0], target, tau, rate, t))

    x_next = rk4_timed(lambda z, t: full_rhs(vehicle, z, inputs(t)), x, dt, substeps)
    end = inputs(dt)
    act_next = ca.vertcat(end[1], end[0])
    return ca.Function("actuated_plant_step", [x, act, cmd, par], [x_next, act_next])


class Plant:
    """One maneuver's car: true state, actuators, command queue and sensors.

    Parameters
    ----------
    settings : PlantSettings
        What the car is.
    model : VehicleTrailer
        The controller's vehicle; the plant's vehicle is this with ``settings.vehicle`` on top.
    start : State
        True start configuration; the car stands still with the wheels straight.
    dt : float
        Sample time [s].
    """

    def __init__(self, settings: PlantSettings, model: VehicleTrailer, start: State, dt: float):
        self.settings = settings
        self.vehicle = settings.resolve_vehicle(model)
        check_state(self.vehicle, start)
        self.dt = float(dt)
        self.t = 0.0
        self.front_steer = 0.0
        self.rear_speed = 0.0
        self._x = start.as_array()
        self._rng = np.random.default_rng(case_seed(settings.seed, start))
        self._queue: deque[Command] = deque(Command(0.0, 0.0) for _ in range(settings.delay_steps))
        s = settings
        self._par = np.array([s.steer_time_constant, s.steer_rate_max, s.accel_max, self.dt])
        self._noise = np.array(
            [
                s.position_noise_std_m,
                s.position_noise_std_m,
                math.radians(s.yaw_noise_std_deg),
                math.radians(s.hitch_noise_std_deg),
            ]
        )
        self._bias = np.array([0.0, 0.0, 0.0, math.radians(s.hitch_bias_deg)])
        self._step = self._step_function()

    def _step_function(self) -> Any:
        """One sample of this plant, compiled once per process and vehicle (:func:`~hitchpark.native.native`)."""
        ideal = self.settings.kind == "ideal"
        return native(plant_function(self.vehicle) if ideal else actuated_plant_function(self.vehicle))

    def __getstate__(self) -> dict[str, Any]:
        return {k: v for k, v in self.__dict__.items() if k != "_step"}  # compiled code stays in its process

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._step = self._step_function()

    @property
    def state(self) -> State:
        """The true configuration."""
        return State.from_array(self._x)

    @property
    def configuration(self) -> np.ndarray:
        """The true configuration as an array (x, y, yaw, hitch), a copy: what the loop records each step."""
        return self._x.copy()

    def sense(self) -> Measurement:
        """The sensors' reading now: the configuration with noise and bias, the actuators' actual state."""
        noisy = self._x + self._bias + self._noise * self._rng.standard_normal(4)  # 4 draws always: one stream
        return Measurement(self.t, State.from_array(noisy), self.front_steer, self.rear_speed)

    def pending(self) -> tuple[Command, ...]:
        """Commands issued but not yet acted on, oldest first (the command delay)."""
        return tuple(self._queue)

    def stopped(self) -> bool:
        """At standstill with only stops in flight.

        The ideal car has no speed of its own: it moves at its command and stops the moment it is
        asked to, so once no motion is in flight it is at rest, and its actual speed reads zero
        (a controller that senses the speed must not see the last move's speed while standing).
        """
        if any(c.rear_speed != 0.0 for c in self._queue):
            return False
        if self.settings.kind == "ideal":
            self.rear_speed = 0.0
            return True
        return self.rear_speed == 0.0

    def apply(self, command: Command) -> Command | None:
        """Issue ``command`` and advance one sample.

        Returns the actual speed and steer at the start of the sample (just after the command
        acts: for the ideal plant the command itself), or None, with nothing moved, if the step
        would take the hitch past ``max_hitch`` (a jackknife is never applied). With a delay,
        the command acted on is the one issued ``delay_steps`` samples ago.
        """
        if not (math.isfinite(command.rear_speed) and math.isfinite(command.front_steer)):
            raise InputError(f"plant command must be finite, got {command}")
        self._queue.append(command)
        acted = self._queue[0]
        if self.settings.kind == "ideal":
            steer = clamp(acted.front_steer, -self.vehicle.max_steer, self.vehicle.max_steer)
            start = Command(acted.rear_speed, steer)
            x_next = np.asarray(self._step(self._x, [start.rear_speed, steer], self.dt))
            end = start
        else:
            start = Command(self.rear_speed, self.front_steer)
            cmd = [acted.rear_speed, acted.front_steer]
            out = self._step(self._x, [self.front_steer, self.rear_speed], cmd, self._par)
            x_next = np.asarray(out[0])
            act = np.asarray(out[1]).ravel()
            end = Command(float(act[1]), float(act[0]))
        x_next = x_next.ravel()
        if not abs(x_next[3]) <= self.vehicle.max_hitch:  # would jackknife (or NaN): not applied
            self._queue.pop()
            return None
        self._queue.popleft()
        self._x = x_next
        self.front_steer, self.rear_speed = end.front_steer, end.rear_speed
        self.t += self.dt
        return start
