"""The NMPC's settings: its horizon, weights and bounds (what is optimised) and the routes that solve it.

Per kind (the paper's trailer-only OCP or the full model's), :data:`KIND_DEFAULTS` gives the horizon, the
weights of Table 4 and the solver routes; :class:`NMPCSettings` checks every field and resolves what is left
None. The routes are names in the solver registry (:mod:`hitchpark.solvers`), which knows nothing of parking.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

from ..checks import InputError, check_choice, check_flag, check_int, check_mapping, check_range, shown
from ..solvers.registry import ROUTES, solver_names
from ..solvers.transcription import OCP

__all__ = ["KIND_DEFAULTS", "MAX_WEIGHT", "NMPC_KINDS", "SINGLE_SHOOTING_SOLVER", "NMPCSettings", "ParkingOCP"]


def _diag(name: str, values: Sequence[float], size: int, positive: bool) -> tuple[float, ...]:
    try:
        items = list(values) if not isinstance(values, str) else None
    except TypeError:
        items = None
    if items is None or len(items) != size:
        raise InputError(f"{name} must be a list of {size} numbers (the diagonal), got {values!r}")
    low_open = positive  # Q, P > 0 as Eq. (49) asks; R may have zeros (Table 4: R = diag(0, 0.1))
    return tuple(check_range(f"{name}[{i}]", v, 0.0, MAX_WEIGHT, low_open=low_open) for i, v in enumerate(items))


#: Largest weight accepted in Q, R, P: far past any useful ratio, short of ruining the NLP's scaling.
MAX_WEIGHT = 1e8


def _solver_options(value: Any, name: str = "nmpc.solver_options") -> dict[str, Any]:
    """CasADi ``nlpsol`` options: a table of names to numbers, strings, true/false, lists of those, or tables.

    Whether the solver knows them is for CasADi to say when the controller is built.
    """
    table = dict(check_mapping(name, value))
    for key, item in table.items():
        if isinstance(item, Mapping):
            table[key] = _solver_options(item, f"{name}.{key}")
            continue
        for leaf in item if isinstance(item, list | tuple) else [item]:
            if isinstance(leaf, float) and not math.isfinite(leaf):
                raise InputError(f"{name}.{key} must be finite, got {leaf}")
            if not isinstance(leaf, bool | int | float | str):
                raise InputError(
                    f"{name}.{key} must be a number, a string, true/false or a list of those, got {shown(item)}"
                )
    return table


#: Kinds of NMPC: the paper's trailer-only OCP (Eqs. 47-57) and the full-model OCP (:mod:`.full`).
NMPC_KINDS = ("full", "paper")

#: The route of a kind whose own needs stages, when the transcription is single shooting.
SINGLE_SHOOTING_SOLVER = "sqp"

#: Per kind: horizon and the diagonals of Q (stage), R (input), P (terminal); sizes are the kind's states/inputs.
KIND_DEFAULTS: dict[str, dict[str, Any]] = {
    # Table 4.
    "paper": {
        "horizon": 10,
        "Q": (1.0, 10.0, 10.0),
        "R": (0.0, 0.1),
        "P": (1.0, 10.0, 10.0),
        "solver": "riccati_c",
        "jit": False,
        "dual_floor": 1.0,
    },
    # (x, y, yaw, hitch, steer, speed), (steer rate, acceleration); chosen by measured success
    # (docs/explanation/realism.md).
    "full": {
        "horizon": 10,
        "prediction_dt": 0.3,
        "solver": "riccati_c",
        "jit": True,
        "dual_floor": 1e-9,
        "Q": (1.0, 10.0, 10.0, 0.5, 0.01, 0.01),
        "R": (0.05, 0.05),
        "P": (10.0, 100.0, 100.0, 5.0, 0.1, 0.1),
    },
}


@dataclass(frozen=True)
class NMPCSettings:
    """Settings of the reverse NMPC. ``kind="paper"`` gives the paper's Table 4 controller.

    Parameters
    ----------
    kind : str
        ``"full"`` (default): the full model with the hitch angle, the steer angle and the speed as
        states and the steer rate and acceleration as inputs, the steer, steer-rate, acceleration
        and jackknife limits on the whole horizon, the command delay predicted out. ``"paper"``: the
        trailer-only OCP of Eqs. (47)-(57), its inputs mapped to the vehicle by Eqs. (44)-(45).
    dt : float
        Sample time d_t [s] of the controller (and of the paper's prediction model, Eq. 48).
    prediction_dt : float or None
        Step of the full OCP's prediction [s] (None: ``dt``); a few coarse steps see seconds ahead,
        where the hitch angle's response to the steer plays out. The command is the plan's first
        ``dt`` (full kind). In open space the grid of steps stays put in time as the samples pass, the
        first step shortening by ``dt`` each (``RecedingHorizon._next_first_step``).
    horizon : int or None
        Prediction/control horizon N [steps]; None: the kind's default (10 for both).
    Q, P : tuple of floats or None
        Diagonals of the stage and terminal state weights, Eq. (49): on (x, y, yaw) for the paper's
        OCP [1/m^2, 1/m^2, 1/rad^2], on (x, y, yaw, hitch, steer, speed) for the full one. None: the kind's.
    R : tuple of floats or None
        Diagonal of the input weight: on (trailer speed, virtual steer) for the paper's OCP, on
        (steer rate, acceleration) for the full one. None: the kind's.
    speed_min, speed_max : float
        Speed bounds [m/s]; the NMPC only reverses. The paper's bound the trailer speed V_T, the full
        OCP's the rear-axle speed V_R.
    virtual_limit : float
        |delta_T| <= virtual_limit [rad]: [delta_T,lb2, delta_T,ub2] of Eq. (57) (paper kind).
    hitch_margin : float
        The full OCP keeps |hitch| <= max_hitch - hitch_margin over the whole horizon [rad] (full kind).
    stop_speed : float
        A reverse stage ends when the optimal speed falls below this [m/s] ("the trailer speed in the
        solution becomes zero", Section 4.1). The solver's own tolerance is ~1e-8, so 1e-3 m/s (1 mm per
        1 s) separates a real zero from the last fractional approach step, which is larger.
    max_steps : int
        A reverse stage that has not stopped after this many steps ends as stalled, unless the trailer still makes
        its way (0.25 m in the last 10 s, ``hitchpark.maneuver.loop.STALL_TRAVEL_M``): it then goes on.
    solver : str or None
        A registered route (:mod:`hitchpark.solvers`, compared by ``hitchpark bench``): ``"riccati_c"`` (hitchpark's
        own structure-exploiting interior point, :mod:`hitchpark.solvers.riccati`, compiled with the OCP; both kinds'
        default; fatrop_c where nothing compiles), ``"fatrop_c"`` (fatrop, the structure-exploiting interior
        point, generated to C with the OCP and compiled), ``"fatrop"`` (the same in-process), ``"sqp"``
        (CasADi sqpmethod with the qrqp QP solver, exact Hessian), ``"sqp_c"``, ``"sqp_bfgs"`` or
        ``"ipopt"`` (interior point, the reference). None: the kind's (``"sqp"`` with single shooting,
        which has no stages).
    fallback_solver : str or None
        Solver tried when the first one fails; only if both fail, and a retry from a cold start fails
        too, does the step command a stop. None (``"none"`` in a settings file): no second solver, the retry
        from a cold start at once (as the exported package does).
    relaxed_solver : str or None
        The route of the problems a structured ``solver`` cannot take: a stage's free-steer problem
        (standing still, the wheels' angle freed, :meth:`.FullNMPC.initial_steer`). A general route (not
        structured): ``"sqp_c"`` by default, a third to a half of IPOPT's time on these problems with
        the same steer; the fallback follows it when it fails. None: the fallback solver (IPOPT if that
        is structured too). Unused when ``solver`` is itself general or takes these problems itself
        (``riccati_c``, compiled: a component of X_0 freed is one it takes).
    transcription : str
        ``"multiple_shooting"`` (states and inputs are unknowns) or ``"single_shooting"`` (inputs only;
        paper kind only).
    solver_options : dict
        Extra options passed to CasADi's ``nlpsol`` on top of the defaults (part of equality).
    warm_duals : bool
        Start the solver from the previous plan's multipliers, shifted by a step as its primal warm start
        is (``fatrop_c``; fatrop as CasADi bundles it takes none, and the routes that take none ignore them).
        False: each solve from the solver's own multipliers.
    dual_floor : float or None
        The least bound multiplier of that start (an interior point needs every one positive). None: the
        kind's, measured on recorded problems (docs/history/speed-notebook.md): 1e-9 for the full kind, 1 for the
        paper's, whose long horizons took more iterations with less.
    obstacle_planes : int
        Among obstacles the full NMPC keeps every body clear of the scene over its horizon: this many
        separating lines per body and prediction step, from the segments of the scene nearest to its warm
        start (:mod:`.obstacles`). 0: the obstacles are left to the guard outside the NMPC. Paper kind: unused.
    jit : bool or None
        Compile the OCP's functions to C, cached on disk (:mod:`hitchpark.solvers.compiled`); about twice as fast a
        solve for the full kind. None: the kind's (full on, paper off). ``HITCHPARK_JIT=0`` or a
        machine without a C compiler runs uncompiled, with the same results to rounding.
    """

    kind: str = "full"
    dt: float = 0.1
    prediction_dt: float | None = None
    horizon: int | None = None
    Q: tuple[float, ...] | None = None
    R: tuple[float, ...] | None = None
    P: tuple[float, ...] | None = None
    speed_min: float = -1.0
    speed_max: float = 0.0
    virtual_limit: float = 0.5
    hitch_margin: float = math.radians(5.0)
    stop_speed: float = 1e-3
    max_steps: int = 1500
    solver: str | None = None
    fallback_solver: str | None = "ipopt"
    relaxed_solver: str | None = "sqp_c"
    transcription: str = "multiple_shooting"
    solver_options: dict[str, Any] = field(default_factory=dict, hash=False)
    warm_duals: bool = True
    dual_floor: float | None = None
    obstacle_planes: int = 3
    jit: bool | None = None

    def __post_init__(self) -> None:
        def put(name: str, value: Any) -> None:
            object.__setattr__(self, name, value)

        check_choice("nmpc.kind", self.kind, NMPC_KINDS)
        defaults = KIND_DEFAULTS[self.kind]
        n_x, n_u = len(defaults["Q"]), len(defaults["R"])
        put("dt", check_range("nmpc.dt", self.dt, 0.0, 1.0, low_open=True, unit="s"))
        if self.prediction_dt is None:
            put("prediction_dt", defaults.get("prediction_dt", self.dt))
        put("prediction_dt", check_range("nmpc.prediction_dt", self.prediction_dt, self.dt, 2.0, unit="s (>= dt)"))
        put("horizon", check_int("nmpc.horizon", defaults["horizon"] if self.horizon is None else self.horizon, 1, 500))
        put("max_steps", check_int("nmpc.max_steps", self.max_steps, 1, 1_000_000))
        put("obstacle_planes", check_int("nmpc.obstacle_planes", self.obstacle_planes, 0, 20))
        # Q, P > 0 as Eq. (49) asks for the pose; R may have zeros (Table 4: R = diag(0, 0.1)).
        put("Q", _diag("nmpc.Q", defaults["Q"] if self.Q is None else self.Q, n_x, positive=self.kind == "paper"))
        put("P", _diag("nmpc.P", defaults["P"] if self.P is None else self.P, n_x, positive=self.kind == "paper"))
        put("R", _diag("nmpc.R", defaults["R"] if self.R is None else self.R, n_u, positive=False))
        put("speed_min", check_range("nmpc.speed_min", self.speed_min, -10.0, 0.0, high_open=True, unit="m/s"))
        # The stage ends when the optimal speed is zero (Section 4.1): zero must be admissible.
        put("speed_max", check_range("nmpc.speed_max", self.speed_max, 0.0, 0.0, unit="m/s (the stop rule needs it)"))
        lim = check_range("nmpc.virtual_limit", self.virtual_limit, 0.0, math.pi / 2, low_open=True, high_open=True)
        put("virtual_limit", lim)
        put("hitch_margin", check_range("nmpc.hitch_margin", self.hitch_margin, 0.0, math.radians(30.0), unit="rad"))
        put("stop_speed", check_range("nmpc.stop_speed", self.stop_speed, 0.0, 0.1, low_open=True, unit="m/s"))
        if self.transcription not in ("multiple_shooting", "single_shooting"):
            raise InputError(
                f"nmpc.transcription must be 'multiple_shooting' or 'single_shooting', got {self.transcription!r}"
            )
        names = solver_names()
        if self.solver is not None and self.solver not in names:
            raise InputError(f"nmpc.solver must be one of {', '.join(names)}, got {self.solver!r}")
        single = self.transcription == "single_shooting"
        if self.solver is None:  # the kind's route, or the one for single shooting if that has no stages
            put(
                "solver",
                SINGLE_SHOOTING_SOLVER if single and ROUTES[defaults["solver"]].structured else defaults["solver"],
            )
        elif single and ROUTES[self.solver].structured:
            raise InputError(
                f"nmpc.solver {self.solver!r} needs nmpc.transcription 'multiple_shooting' (it exploits the "
                f"stage structure), got 'single_shooting'"
            )
        for name in ("fallback_solver", "relaxed_solver"):  # a settings file (TOML has no null) writes none
            if getattr(self, name) == "none":
                put(name, None)
        if self.fallback_solver is not None and self.fallback_solver not in names:
            raise InputError(
                f"nmpc.fallback_solver must be one of {', '.join(names)} or none, got {self.fallback_solver!r}"
            )
        if single and self.fallback_solver is not None and ROUTES[self.fallback_solver].structured:
            raise InputError(
                f"nmpc.fallback_solver {self.fallback_solver!r} needs nmpc.transcription 'multiple_shooting', "
                "got 'single_shooting'"
            )
        if self.relaxed_solver is not None and (
            self.relaxed_solver not in names or ROUTES[self.relaxed_solver].structured
        ):
            general = [name for name in names if not ROUTES[name].structured]
            raise InputError(
                f"nmpc.relaxed_solver must be a general route, one of {', '.join(general)} or none, "
                f"got {self.relaxed_solver!r}"
            )
        put("jit", check_flag("nmpc.jit", defaults["jit"] if self.jit is None else self.jit))
        put("solver_options", _solver_options(self.solver_options))
        put("warm_duals", check_flag("nmpc.warm_duals", self.warm_duals))
        floor = defaults["dual_floor"] if self.dual_floor is None else self.dual_floor
        put("dual_floor", check_range("nmpc.dual_floor", floor, 0.0, 1e3, low_open=True))


class ParkingOCP(OCP, Protocol):
    """An OCP of this package: what a transcription needs (:class:`~hitchpark.solvers.transcription.OCP`), its
    settings the NMPC's (the controllers read the routes and the sample from them)."""

    @property
    def settings(self) -> NMPCSettings: ...
