"""The 3-stage process (Fig. 7, hitchpark.maneuver.process): records, NMPC use, stops, frames.

The four built-in scenarios are parked once per session (``make_reference.builtin_results``)
and shared; the few extra maneuvers here are the ones a property needs. Everything here is
the paper's process (its NMPC, ``PAPER``, on the ideal plant, ``IDEAL``), as the built-in
scenarios carry it, unless a test says otherwise.
"""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest
from make_reference import builtin_results

from hitchpark.control import FullNMPC, NMPCSettings, TrailerNMPC
from hitchpark.control.pure_pursuit import PurePursuitSettings, pure_pursuit_steer
from hitchpark.io import to_jsonable
from hitchpark.maneuver import (
    MANEUVER_COLUMNS,
    ManeuverResult,
    ManeuverSettings,
    ProcessSettings,
    Scenario,
    SuccessCriteria,
    builtin_scenarios,
    park,
)
from hitchpark.maneuver.scenario import BUILTIN_ORDER
from hitchpark.model import (
    IDEAL,
    Pose,
    VehicleTrailer,
    front_steer_from_virtual,
    rear_speed_from_trailer_speed,
    step_full,
    to_goal_frame,
    trailer_speed_from_rear_speed,
    virtual_steer_bounds,
    virtual_steer_from_front,
)
from hitchpark.model.simulate import State

COMMAND_COLUMNS = ("rear_speed", "front_steer", "trailer_speed", "virtual_steer")

#: The paper's process: its NMPC (Table 4); with the ideal plant (``IDEAL``) it is the paper's closed loop.
PAPER = ManeuverSettings(nmpc=NMPCSettings(kind="paper"))


@pytest.fixture(scope="module")
def results() -> dict[str, ManeuverResult]:
    return builtin_results()


@pytest.fixture(scope="module")
def scenarios() -> dict[str, Scenario]:
    return {sc.name: sc for sc in builtin_scenarios()}


def applied_rows(result: ManeuverResult, index: int) -> range:
    """Rows of stage ``index`` whose command was applied (not the state it ended in)."""
    st = result.stages[index]
    return range(st.first_row, st.first_row + st.steps)


def with_nmpc(settings: ManeuverSettings, **changes) -> ManeuverSettings:
    return replace(settings, nmpc=replace(settings.nmpc, **changes))


def moved(goal: Pose, state: State) -> State:
    """``state`` given in the parking frame of ``goal``, in world coordinates."""
    c, s = math.cos(goal.yaw), math.sin(goal.yaw)
    return State(
        goal.x + c * state.x - s * state.y, goal.y + s * state.x + c * state.y, state.yaw + goal.yaw, state.hitch
    )


# --- the record: rows, stages, plant consistency ------------------------------------------


@pytest.mark.parametrize("name", BUILTIN_ORDER)
def test_rows_replay_through_the_plant(name, results):
    """Row k's command, held for dt from row k's state with the full model, gives row k+1's state."""
    result = results[name]
    tr, dt = result.trajectory, result.settings.nmpc.dt
    states = tr.states()
    for k in range(len(tr) - 1):
        nxt = step_full(result.vehicle, states[k], tr["rear_speed"][k], tr["front_steer"][k], dt)
        np.testing.assert_allclose(nxt, states[k + 1], rtol=0, atol=1e-9, err_msg=f"row {k}")
    np.testing.assert_allclose(np.diff(tr["t"]), dt, rtol=0, atol=1e-9)
    assert tr["t"][0] == 0.0
    assert result.duration == pytest.approx(dt * sum(s.steps for s in result.stages), abs=1e-9)


@pytest.mark.parametrize("name", BUILTIN_ORDER)
def test_stages_tile_the_trajectory(name, results):
    result = results[name]
    tr = result.trajectory
    assert tr.names == MANEUVER_COLUMNS
    assert result.stages[0].first_row == 0
    for prev, nxt in zip(result.stages, result.stages[1:], strict=False):
        assert nxt.first_row == prev.last_row
    assert result.stages[-1].last_row == len(tr) - 1
    for index, st in enumerate(result.stages):
        assert st.last_row == st.first_row + st.steps
        assert np.all(tr["stage"][list(applied_rows(result, index))] == index)
        end = tr.states()[st.last_row]
        dist, orient = math.hypot(*to_goal_frame(result.goal, end[0], end[1], end[2])[:2]), end[2] - result.goal.yaw
        assert st.distance_error_m == pytest.approx(dist, abs=1e-12)
        assert math.radians(st.orientation_error_deg) == pytest.approx(math.remainder(orient, math.tau), abs=1e-12)
        assert math.radians(st.final_hitch_deg) == pytest.approx(end[3], abs=1e-15)
    assert tr["stage"][-1] == len(result.stages) - 1


@pytest.mark.parametrize("name", BUILTIN_ORDER)
def test_forward_rows_are_pure_pursuit(name, results):
    result = results[name]
    tr, fwd = result.trajectory, result.settings.forward
    rows = list(applied_rows(result, 1))
    assert result.stages[1].kind == "forward" and rows
    states = tr.states()
    for k in rows:
        hitch, steer = states[k][3], tr["front_steer"][k]
        assert tr["rear_speed"][k] == fwd.speed
        assert steer == pure_pursuit_steer(result.vehicle, result.goal, fwd, states[k])
        assert tr["trailer_speed"][k] == pytest.approx(
            trailer_speed_from_rear_speed(result.vehicle, hitch, fwd.speed, steer), abs=1e-12
        )
        assert tr["virtual_steer"][k] == pytest.approx(
            virtual_steer_from_front(result.vehicle, hitch, steer), abs=1e-12
        )
    assert np.all(np.isnan(tr["cost"][rows])) and np.all(np.isnan(tr["solve_ms"][rows]))


# --- the NMPC inside the maneuver: bounds (Eqs. 56-57) and inverse kinematics (Eqs. 44-45) ----


@pytest.mark.parametrize("name", BUILTIN_ORDER)
def test_reverse_rows_honour_the_nmpc_bounds(name, results):
    result = results[name]
    tr, vehicle, s = result.trajectory, result.vehicle, result.settings.nmpc
    rows = [k for i, st in enumerate(result.stages) if st.kind == "reverse" for k in applied_rows(result, i)]
    assert rows
    assert np.all(np.isfinite(tr["cost"][rows])) and np.all(np.isfinite(tr["solve_ms"][rows]))
    for k in rows:
        hitch, v_t, d_t = tr["hitch"][k], tr["trailer_speed"][k], tr["virtual_steer"][k]
        assert s.speed_min <= v_t <= s.speed_max
        assert abs(v_t) >= s.stop_speed  # a zero-speed answer ends the stage instead of being applied
        low, high = virtual_steer_bounds(vehicle, hitch, s.virtual_limit)
        assert low - 1e-9 <= d_t <= high + 1e-9, f"row {k}"
        assert tr["front_steer"][k] == pytest.approx(front_steer_from_virtual(vehicle, hitch, d_t), abs=1e-12)
        assert tr["rear_speed"][k] == pytest.approx(rear_speed_from_trailer_speed(vehicle, hitch, d_t, v_t), abs=1e-12)
        assert tr["rear_speed"][k] < 0.0


@pytest.mark.parametrize("name", BUILTIN_ORDER)
def test_reverse_stages_end_on_a_zero_speed_answer(name, results, scenarios):
    """Section 4.1: a reverse stage ends when the optimal V_T,0 is zero (|V_T,0| < stop_speed)."""
    result, sc = results[name], scenarios[name]
    stop_speed = sc.settings.nmpc.stop_speed
    reverse = [(i, st) for i, st in enumerate(result.stages) if st.kind == "reverse"]
    assert reverse and all(st.reason == "stopped" for _, st in reverse)
    for index, st in reverse:
        assert st.steps > 0
        assert abs(result.trajectory["trailer_speed"][st.last_row - 1]) >= stop_speed
        fresh = TrailerNMPC(sc.vehicle, sc.settings.nmpc)
        u = fresh.step(*result.trajectory.states()[st.last_row], sc.goal)
        assert u.ok, f"stage {index + 1}: {u.status}"
        assert abs(u.trailer_speed) < stop_speed
        assert u.stop
        assert u.rear_speed == 0.0


@pytest.mark.parametrize(("settings", "plant"), [(PAPER, IDEAL), (ManeuverSettings(), None)], ids=["paper", "full"])
@pytest.mark.parametrize("goal", [Pose(), Pose(5.0, -3.0, math.radians(30.0))])
def test_starting_at_the_goal_parks_at_once(goal, settings, plant):
    result = park(VehicleTrailer(), State(goal.x, goal.y, goal.yaw, 0.0), goal, settings, plant=plant)
    assert result.success and result.reason == "parked"
    assert len(result.stages) == 1
    only = result.stages[0]
    assert (only.kind, only.steps, only.reason) == ("reverse", 0, "stopped")
    assert only.distance_error_m == pytest.approx(0.0, abs=1e-12)
    assert len(result.trajectory) == 1 and result.duration == 0.0
    assert result.trajectory["rear_speed"][0] == 0.0


# --- ending early: the outcomes other than "parked" -------------------------------------------


def test_timeout(scenarios):
    sc = scenarios["parallel"]
    settings = replace(sc.settings, success=SuccessCriteria(max_time=5.0))
    result = park(sc.vehicle, sc.start, sc.goal, settings, plant=sc.plant)
    assert not result.success and result.reason == "timeout"
    assert len(result.stages) == 1 and result.stages[0].reason == "timeout"
    assert result.duration == pytest.approx(5.0, abs=1e-9)
    assert result.trajectory["rear_speed"][-1] == 0.0


def test_max_stages(scenarios, results):
    sc = scenarios["parallel"]
    settings = replace(sc.settings, success=SuccessCriteria(max_stages=1))
    result = park(sc.vehicle, sc.start, sc.goal, settings, plant=sc.plant)
    assert not result.success and result.reason == "max_stages"
    assert result.stages == results["parallel"].stages[:1]  # the same first stage, then no forward stage


def test_reverse_stage_stalls_after_max_steps(scenarios):
    sc = scenarios["parallel"]
    result = park(sc.vehicle, sc.start, sc.goal, with_nmpc(sc.settings, max_steps=5), plant=sc.plant)
    assert not result.success and result.reason == "stalled"
    assert [(s.kind, s.steps, s.reason) for s in result.stages] == [("reverse", 5, "stalled")]


@pytest.fixture(scope="module")
def forward_stalled(scenarios) -> ManeuverResult:
    """The parallel scenario with a forward stage allowed 1 m only."""
    sc = scenarios["parallel"]
    settings = replace(sc.settings, forward=PurePursuitSettings(max_distance=1.0))
    return park(sc.vehicle, sc.start, sc.goal, settings, plant=sc.plant)


def test_forward_stage_stalls_after_max_distance(forward_stalled, results):
    result = forward_stalled
    assert not result.success and result.reason == "stalled"
    assert [s.kind for s in result.stages] == ["reverse", "forward"]
    assert result.stages[1].reason == "stalled"
    assert result.stages[1].steps == 10  # 1 m at 1 m/s in steps of 0.1 s
    assert result.stages[0] == results["parallel"].stages[0]


def test_forward_stage_stops_at_exactly_max_distance(forward_stalled):
    assert forward_stalled.stages[1].steps == 10


def test_bad_inputs_are_rejected():
    with pytest.raises(ValueError, match="hitch"):
        park(VehicleTrailer(), State(10.0, 3.5, 0.0, math.radians(75.0)))
    with pytest.raises(ValueError, match="hitch_offset"):
        park(VehicleTrailer(hitch_offset=0.0), State(10.0, 3.5, 0.0, 0.0))
    with pytest.raises(ValueError, match="x must be finite"):
        park(VehicleTrailer(), State(math.nan, 3.5, 0.0, 0.0))


# --- the controller can fail: the maneuver stops safely ---------------------------------------


@pytest.mark.parametrize(
    ("nmpc", "plant"),
    [
        (NMPCSettings(kind="paper", solver="sqp", fallback_solver=None, solver_options={"max_iter": 0}), IDEAL),
        (NMPCSettings(solver="ipopt", fallback_solver=None, solver_options={"ipopt.max_iter": 0}), None),
    ],
    ids=["paper", "full"],
)
def test_solver_failure_stops_the_maneuver(nmpc, plant):
    """A reverse stage whose solver fails before it moved ends the maneuver, in either staged process."""
    settings = ManeuverSettings(nmpc=nmpc, process=ProcessSettings(kind="staged"))
    result = park(VehicleTrailer(), State(10.0, 3.5, 0.0, 0.0), settings=settings, plant=plant)
    assert not result.success
    assert result.reason == "solver" and result.detail
    assert result.stages[0].reason == f"solver: {result.detail}" and result.stages[0].steps == 0
    tr = result.trajectory
    assert len(tr) == 1
    assert tr["rear_speed"][-1] == 0.0 and tr["trailer_speed"][-1] == 0.0
    for col in COMMAND_COLUMNS:
        assert np.all(np.isfinite(tr[col]))


class Switch:
    """Shared by the wrapped solvers: after ``good`` successful calls of the primary, every call fails."""

    def __init__(self, good: int, mode: str):
        self.good, self.mode, self.calls = good, mode, 0

    @property
    def failing(self) -> bool:
        return self.calls > self.good


class FailingSolver:
    """Stands in for a CasADi nlpsol: delegates until the switch flips, then fails as ``mode`` says.

    ``"nan"`` answers a NaN decision vector while claiming success; ``"raise"`` raises
    RuntimeError, as CasADi does on an evaluation error.
    """

    def __init__(self, real, switch: Switch, primary: bool):
        self.real, self.switch, self.primary = real, switch, primary
        self._failed = False

    def __call__(self, **kwargs):
        if self.primary:
            self.switch.calls += 1
        self._failed = self.switch.failing
        if not self._failed:
            return self.real(**kwargs)
        if self.switch.mode == "raise":
            raise RuntimeError("injected evaluation error")
        return {"x": np.full(len(kwargs["x0"]), np.nan), "f": np.nan}

    def stats(self):
        return {"success": True, "return_status": "Solve_Succeeded"} if self._failed else self.real.stats()


@pytest.mark.parametrize(("mode", "status"), [("nan", "non-finite"), ("raise", "injected evaluation error")])
def test_injected_failure_mid_stage_stops_safely(mode, status, scenarios, results):
    sc = scenarios["parallel"]
    good = 20
    controller = TrailerNMPC(sc.vehicle, sc.settings.nmpc)
    switch = Switch(good, mode)
    controller.solver = FailingSolver(controller.solver, switch, primary=True)
    controller.fallback = FailingSolver(controller.fallback, switch, primary=False)
    result = park(sc.vehicle, sc.start, sc.goal, sc.settings, controller=controller, plant=sc.plant)

    assert not result.success
    assert result.reason == "solver" and status in result.detail
    assert len(result.stages) == 1  # the paper's process ends at the failure: no forward stage follows
    assert result.stages[0].steps == good and result.stages[0].reason == f"solver: {result.detail}"
    tr, ref = result.trajectory, results["parallel"].trajectory
    assert len(tr) == good + 1
    for col in (c for c in MANEUVER_COLUMNS if c != "solve_ms"):  # until the failure, nothing changed
        np.testing.assert_allclose(tr[col][:good], ref[col][:good], rtol=0, atol=1e-12, err_msg=col)
    np.testing.assert_allclose(tr.states()[-1], ref.states()[good], rtol=0, atol=1e-12)  # nothing applied after it
    assert tr["rear_speed"][-1] == 0.0
    assert tr["front_steer"][-1] == tr["front_steer"][good - 1]  # steer held
    for col in COMMAND_COLUMNS:
        assert np.all(np.isfinite(tr[col])), col
    assert np.all(np.abs(tr["front_steer"]) <= sc.vehicle.max_steer)


def test_full_process_hands_a_failed_reverse_stage_over_to_the_forward_stage():
    """In the full process a reverse stage that moved and then fails stops the car; a forward stage follows."""
    sc = next(s for s in builtin_scenarios() if s.name == "parallel")
    settings = ManeuverSettings(process=ProcessSettings(kind="staged"))  # the full-model NMPC, on the realistic car
    controller = FullNMPC(sc.vehicle, settings.nmpc)
    switch = Switch(20, "raise")
    controller.solver = FailingSolver(controller.solver, switch, primary=True)
    controller.fallback = FailingSolver(controller.fallback, switch, primary=False)
    result = park(sc.vehicle, sc.start, sc.goal, settings, controller=controller)

    assert not result.success
    assert result.reason == "solver" and "injected evaluation error" in result.detail
    failed = f"solver: {result.detail}"
    assert [(s.kind, s.reason) for s in result.stages] == [
        ("reverse", failed),
        ("forward", "repositioned"),
        ("reverse", failed),  # every solve fails now: this one cannot start, and that ends the maneuver
    ]
    assert result.stages[2].steps == 0
    tr, first = result.trajectory, result.stages[0]
    solved = [k for k in range(first.first_row, first.last_row) if np.isfinite(tr["solve_ms"][k])]
    assert solved and solved == list(range(solved[0], solved[-1] + 1))
    after = list(range(solved[-1] + 1, first.last_row))  # braking: stops only, the car at rest at the end
    assert after and np.all(tr["rear_speed_cmd"][after] == 0.0)
    assert tr["rear_speed"][first.last_row] == 0.0 and tr["rear_speed"][-1] == 0.0
    real = result.plant_vehicle
    assert np.all(np.abs(tr["front_steer"]) <= real.max_steer) and np.all(np.abs(tr["hitch"]) <= real.max_hitch)


# --- the same maneuver whatever the solver, transcription or world frame ----------------------


@pytest.mark.parametrize(
    "changes",
    [{"solver": "ipopt"}, {"transcription": "single_shooting", "solver": "sqp"}],
    ids=["ipopt", "single_shooting"],
)
def test_solver_and_transcription_do_not_change_the_maneuver(changes, scenarios, results):
    sc, base = scenarios["random"], results["random"]
    result = park(sc.vehicle, sc.start, sc.goal, with_nmpc(sc.settings, **changes), plant=sc.plant)
    assert result.success == base.success and result.reason == base.reason
    assert [s.kind for s in result.stages] == [s.kind for s in base.stages]
    for k, (got, ref) in enumerate(zip(result.stages, base.stages, strict=True)):
        assert abs(got.steps - ref.steps) <= 1, f"stage {k + 1}"
    got, ref = result.stages[0], base.stages[0]
    assert got.distance_error_m == pytest.approx(ref.distance_error_m, abs=1e-3)
    assert got.orientation_error_deg == pytest.approx(ref.orientation_error_deg, abs=0.01)
    assert got.final_hitch_deg == pytest.approx(ref.final_hitch_deg, abs=0.01)
    got, ref = result.stages[-1], base.stages[-1]
    assert got.distance_error_m == pytest.approx(ref.distance_error_m, abs=1e-4)
    assert got.orientation_error_deg == pytest.approx(ref.orientation_error_deg, abs=1e-3)
    assert got.final_hitch_deg == pytest.approx(ref.final_hitch_deg, abs=1e-2)


@pytest.mark.parametrize("name", BUILTIN_ORDER)
def test_goal_anywhere_in_the_world(name, scenarios, results):
    """The maneuver depends on the start relative to the goal only, not on the world frame."""
    sc, base = scenarios[name], results[name]
    goal = Pose(5.0, -3.0, math.radians(30.0))
    result = park(sc.vehicle, moved(goal, sc.start), goal, sc.settings, plant=sc.plant)
    assert result.success == base.success and result.reason == base.reason
    assert len(result.stages) == len(base.stages)
    for got, ref in zip(result.stages, base.stages, strict=True):
        assert (got.kind, got.steps, got.reason) == (ref.kind, ref.steps, ref.reason)
        assert got.distance_error_m == pytest.approx(ref.distance_error_m, abs=1e-6)
        assert got.orientation_error_deg == pytest.approx(ref.orientation_error_deg, abs=1e-5)
        assert got.final_hitch_deg == pytest.approx(ref.final_hitch_deg, abs=1e-5)
    tr, ref_tr = result.trajectory, base.trajectory
    gx, gy, gyaw = to_goal_frame(goal, tr["x_trailer"], tr["y_trailer"], tr["yaw_trailer"])
    np.testing.assert_allclose(gx, ref_tr["x_trailer"], rtol=0, atol=1e-6)
    np.testing.assert_allclose(gy, ref_tr["y_trailer"], rtol=0, atol=1e-6)
    np.testing.assert_allclose(np.cos(gyaw - ref_tr["yaw_trailer"]), 1.0, rtol=0, atol=1e-10)
    np.testing.assert_allclose(tr["front_steer"], ref_tr["front_steer"], rtol=0, atol=1e-6)
    np.testing.assert_allclose(tr["rear_speed"], ref_tr["rear_speed"], rtol=0, atol=1e-6)


def test_a_reused_controller_gives_the_same_maneuver(scenarios, results):
    first, second = scenarios["parallel_hitch"], scenarios["parallel"]
    controller = TrailerNMPC(second.vehicle, second.settings.nmpc)
    park(first.vehicle, first.start, first.goal, first.settings, controller=controller, plant=first.plant)
    again = park(second.vehicle, second.start, second.goal, second.settings, controller=controller, plant=second.plant)
    assert again.stages == results["parallel"].stages
    for col in MANEUVER_COLUMNS:
        if col != "solve_ms":
            np.testing.assert_array_equal(again.trajectory[col], results["parallel"].trajectory[col], err_msg=col)


# --- saving ----------------------------------------------------------------------------------


@pytest.mark.parametrize("name", BUILTIN_ORDER)
def test_json_round_trip(name, results):
    result = results[name]
    text = json.dumps(result.to_dict(), allow_nan=False)  # plain JSON: NaN only as null
    back = ManeuverResult.from_dict(json.loads(text))
    assert back.stages == result.stages
    assert (back.success, back.reason, back.name) == (result.success, result.reason, result.name)
    assert back.vehicle == result.vehicle
    assert back.settings == result.settings
    assert back.trajectory.names == result.trajectory.names
    for col in result.trajectory.names:
        np.testing.assert_array_equal(back.trajectory[col], result.trajectory[col], err_msg=col)
    for a, b in ((back.start, result.start), (back.goal, result.goal)):
        assert np.allclose(list(vars(a).values()), list(vars(b).values()), rtol=0, atol=1e-15)
    assert back.duration == result.duration
    assert back.to_dict()["stages"] == result.to_dict()["stages"]


# --- review fixes: limits, controller match, saved layouts ------------------------------------


def test_reverse_stage_stops_before_a_jackknife():
    """The NMPC does not know max_hitch; the plant step that would pass it is refused and the maneuver ends."""
    vehicle = VehicleTrailer(max_hitch=math.radians(30.0))
    result = park(vehicle, State(10.0, 3.5, 0.0, 0.0), settings=PAPER, plant=IDEAL)  # unlimited: 38 deg in stage 1
    assert not result.success and result.reason == "jackknife"
    assert result.stages[-1].reason == "jackknife"
    assert result.max_abs_hitch_deg <= 30.0
    assert result.max_abs_hitch_deg > 28.0  # stopped at the limit, one step short of passing it
    assert result.trajectory["rear_speed"][-1] == 0.0


def test_nmpc_refuses_a_hitch_beyond_the_limit(table4):
    step = TrailerNMPC(table4).step(5.0, 2.0, 0.0, math.radians(120.0))
    assert not step.ok and "max_hitch" in step.status
    assert step.rear_speed == 0.0 and math.isfinite(step.front_steer) and abs(step.front_steer) <= table4.max_steer


def test_a_controller_serves_any_goal_but_only_its_own_settings(table4, results):
    """The goal is a parameter of the step: a controller built with none parks at (5, 5) as at the origin."""
    start, goal = State(15.0, 8.5, 0.0, 0.0), Pose(5.0, 5.0, 0.0)  # the parallel scenario, moved by (5, 5)
    result = park(table4, start, goal, PAPER, controller=TrailerNMPC(table4, PAPER.nmpc), plant=IDEAL)
    assert [(s.kind, s.steps, s.reason) for s in result.stages] == [
        (s.kind, s.steps, s.reason) for s in results["parallel"].stages
    ]
    with pytest.raises(ValueError, match="controller"):  # another NMPC: the default (full) one
        park(table4, start, goal, controller=TrailerNMPC(table4))
    with pytest.raises(ValueError, match="controller"):  # other NMPC settings of the same kind
        park(table4, start, goal, PAPER, controller=TrailerNMPC(table4, NMPCSettings(kind="paper", horizon=8)))
    with pytest.raises(ValueError, match="controller"):  # another vehicle
        park(table4, start, goal, PAPER, controller=TrailerNMPC(VehicleTrailer(wheelbase=3.0), PAPER.nmpc))


def _saved(results) -> dict:
    return json.loads(json.dumps(to_jsonable(results["parallel"].to_dict())))


@pytest.mark.parametrize(
    ("spoil", "problem"),
    [
        (lambda d: d["stages"][0].update(first_row=10**9), "rows"),
        (lambda d: d["stages"][1].update(last_row=-3), "last_row"),
        (lambda d: d["stages"][0].update(kind="sideways"), "kind"),
        (lambda d: d["stages"].pop(), "stages end"),
        (lambda d: d["trajectory"].pop("hitch"), "hitch"),
        (lambda d: d.pop("goal"), "goal"),
        (lambda d: d.update(stages=[]), "no rows or no stages"),
    ],
)
def test_from_dict_rejects_a_broken_layout(results, spoil, problem):
    data = _saved(results)
    spoil(data)
    with pytest.raises(ValueError, match=problem):
        ManeuverResult.from_dict(data)
