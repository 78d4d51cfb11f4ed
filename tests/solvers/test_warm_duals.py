"""The warm start of fatrop's multipliers (solvers/fatrop_warm.cpp): the shift of a solution's multipliers,
the generated solver started from them, the controller that passes them on, and the build without it."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from hitchpark import VehicleTrailer
from hitchpark.checks import InputError
from hitchpark.control import NMPCSettings, make_nmpc
from hitchpark.maneuver import builtin_scenarios, park
from hitchpark.maneuver.scenario import builtin_scenario
from hitchpark.solvers.generated import GeneratedNLP
from hitchpark.solvers.registry import make_solver, takes_duals


def _recorded(kind: str, scenario: int, **nmpc):
    sc = builtin_scenarios()[scenario]
    settings = replace(sc.settings, nmpc=NMPCSettings(kind=kind, **nmpc))
    controller = make_nmpc(sc.vehicle, settings.nmpc)
    controller.recorder = []
    result = park(sc.vehicle, sc.start, sc.goal, settings, controller=controller, plant=sc.plant)
    return controller, controller.recorder, result


def _obstacle_transcription():
    sc = builtin_scenario("campsite")
    controller = make_nmpc(sc.vehicle, sc.settings.nmpc)
    controller.keep_clear(sc.scene, 0.2)
    return controller.transcription


def test_shifted_multipliers_move_each_stage_on_by_a_step_and_hold_the_last():
    """Multipliers numbered by their stage come back numbered by the next stage's, the last held; the rows on
    X_k (the obstacle OCP's lines) alike; a fraction of a step moves them that fraction of the way."""
    tr = _obstacle_transcription()
    N, nx, nu = tr.problem.horizon, tr.problem.n_x, tr.problem.n_u
    assert tr.layout.step_rows is not None and tr.layout.step_rows.shape[0] == N  # the lines: rows on X_1 ... X_N
    lam_x = np.zeros(tr.nlp["x"].numel())
    lam_x[tr.layout.states] = np.arange(N + 1)[:, None] + 0.1 * np.arange(nx)
    lam_x[tr.layout.inputs] = np.arange(N)[:, None] + 0.01 * np.arange(nu)
    lam_g = np.full(len(tr.lbg), -7.0)  # anything else (none here) keeps its value
    lam_g[tr.layout.dynamics] = np.arange(N + 1)[:, None]
    lam_g[tr.layout.step_rows] = np.arange(1, N + 1)[:, None]
    shifted_x, shifted_g = tr.shift_duals(lam_x, lam_g, 1.0)
    np.testing.assert_array_equal(shifted_x[tr.layout.states[1:-1]], lam_x[tr.layout.states[2:]])
    np.testing.assert_array_equal(shifted_x[tr.layout.states[-1]], lam_x[tr.layout.states[-1]])
    np.testing.assert_array_equal(shifted_x[tr.layout.states[0]], 0.0)  # X_0 is p: no bound there
    np.testing.assert_array_equal(shifted_x[tr.layout.inputs[:-1]], lam_x[tr.layout.inputs[1:]])
    np.testing.assert_array_equal(shifted_x[tr.layout.inputs[-1]], lam_x[tr.layout.inputs[-1]])
    np.testing.assert_array_equal(shifted_g[tr.layout.dynamics][:, 0], [*range(1, N + 1), N])
    np.testing.assert_array_equal(shifted_g[tr.layout.step_rows][:, 0], [*range(2, N + 1), N])
    third_x, third_g = tr.shift_duals(lam_x, lam_g, 1.0 / 3.0)
    np.testing.assert_allclose(third_g[tr.layout.dynamics][:-1, 0], np.arange(N) + 1.0 / 3.0)
    np.testing.assert_allclose(third_x[tr.layout.inputs][:-1, 0], np.arange(N - 1) + 1.0 / 3.0)
    # The inputs are left as they were; multipliers of another layout are refused.
    assert lam_g[tr.layout.dynamics][1, 0] == 1.0
    assert tr.shift_duals(lam_x[:-1], lam_g, 1.0) is None


@pytest.mark.slow
def test_fatrop_started_from_its_own_optimum_and_multipliers_ends_there_in_fewer_iterations(
    shared_jit_cache, full_recorded
):
    # The problems recorded uncompiled (they need no multipliers), as the solver tests' (tests/solvers/conftest.py),
    # and the solver under test compiled.
    controller, problems = full_recorded
    tr = controller.transcription
    solver = make_solver("fatrop_c", tr.nlp, list(tr.lbg == tr.ubg), transcription=tr)
    assert isinstance(solver, GeneratedNLP) and solver.warm_duals and takes_duals(solver)
    plain, warm = [], []
    for problem in problems[::8]:
        inputs = problem.inputs()
        optimum = solver(**inputs)
        assert solver.stats()["success"]
        again = dict(inputs, x0=optimum["x"])
        solver(**again)
        plain.append(solver.stats()["iter_count"])
        answer = solver(**again, lam_x0=optimum["lam_x"], lam_g0=optimum["lam_g"])
        assert solver.stats()["success"]
        warm.append(solver.stats()["iter_count"])
        assert answer["f"] == pytest.approx(optimum["f"], rel=1e-8, abs=1e-10)
        np.testing.assert_allclose(answer["x"][tr.layout.inputs[0]], optimum["x"][tr.layout.inputs[0]], atol=1e-6)
    assert len(plain) >= 5
    assert all(w <= p for w, p in zip(warm, plain, strict=True)), (warm, plain)
    assert sum(warm) < sum(plain)


@pytest.mark.slow
def test_the_shifted_multipliers_reach_the_optimum_of_fatrops_own_start_and_non_finite_ones_are_ignored(
    shared_jit_cache,
):
    """On the problems a closed loop posed (each with the last plan's multipliers, shifted): the same optimum
    as from fatrop's own start (whose least-squares equality multipliers the caller's replace). Multipliers
    with a NaN are not used: that solve is fatrop's own, to the iteration and the last bit."""
    controller, problems, _ = _recorded("full", 1)
    tr = controller.transcription
    solver = make_solver("fatrop_c", tr.nlp, list(tr.lbg == tr.ubg), transcription=tr)
    started = [p for p in problems if p.lam_x0 is not None][::6]
    assert len(started) >= 8
    for problem in started:
        own = solver(**problem.inputs())
        own_stats = solver.stats()
        warm = solver(**problem.inputs(duals=True))
        assert own_stats["success"] and solver.stats()["success"]
        assert warm["f"] == pytest.approx(own["f"], rel=1e-6, abs=1e-8)
        np.testing.assert_allclose(warm["x"][tr.layout.inputs[0]], own["x"][tr.layout.inputs[0]], atol=1e-5)
        broken = problem.lam_g0.copy()
        broken[len(broken) // 2] = np.nan
        ignored = solver(**problem.inputs(), lam_x0=problem.lam_x0, lam_g0=broken)
        assert solver.stats()["iter_count"] == own_stats["iter_count"]
        np.testing.assert_array_equal(ignored["x"], own["x"])


@pytest.mark.slow
def test_the_controller_passes_on_the_shifted_multipliers_and_parks_as_without(shared_jit_cache):
    """Every problem after the first of a stage starts from the multipliers of the last plan, of the
    transcription's sizes; the maneuver ends where the one without them does."""
    controller, problems, result = _recorded("paper", 0)
    _, off_problems, off_result = _recorded("paper", 0, warm_duals=False)
    assert takes_duals(controller.solver)
    assert result.success and off_result.success
    n_x, n_g = controller.transcription.nlp["x"].numel(), len(controller.transcription.lbg)
    started = [p for p in problems if p.lam_x0 is not None]
    assert len(started) > 0.9 * len(problems)
    assert all(p.lam_x0.shape == (n_x,) and p.lam_g0.shape == (n_g,) for p in started)
    assert all("lam_x0" in p.inputs(duals=True) and "lam_x0" not in p.inputs() for p in started)
    assert all(p.lam_x0 is None and p.lam_g0 is None for p in off_problems)
    last, off_last = result.stages[-1], off_result.stages[-1]
    assert last.distance_error_m == pytest.approx(off_last.distance_error_m, abs=1e-3)
    assert last.orientation_error_deg == pytest.approx(off_last.orientation_error_deg, abs=0.01)


def test_without_a_cpp_compiler_the_solver_is_fatrop_as_it_comes(jit_cache, monkeypatch):
    monkeypatch.setenv("CXX", "no-such-compiler-here")
    controller, problems, _ = _recorded("paper", 1, solver="fatrop_c")
    assert isinstance(controller.solver, GeneratedNLP) and not controller.solver.warm_duals
    assert not takes_duals(controller.solver)
    assert all(p.lam_x0 is None for p in problems)
    answer = controller.solver(**problems[3].inputs())
    assert controller.solver.stats()["success"] and "iter_count" not in controller.solver.stats()
    assert np.all(np.isfinite(answer["x"]))


def test_dual_settings_are_checked_and_default_by_kind():
    assert NMPCSettings(kind="paper").dual_floor == 1.0
    assert NMPCSettings(kind="full").dual_floor == 1e-9
    assert NMPCSettings(kind="full", dual_floor=0.5).dual_floor == 0.5
    assert NMPCSettings(kind="full").warm_duals is True
    with pytest.raises(InputError, match=r"nmpc\.dual_floor"):
        NMPCSettings(dual_floor=0.0)
    with pytest.raises(InputError, match=r"nmpc\.warm_duals"):
        NMPCSettings(warm_duals="yes")  # type: ignore[arg-type]


def test_a_controller_whose_solver_takes_no_multipliers_passes_none():
    controller = make_nmpc(VehicleTrailer(), NMPCSettings(kind="paper", solver="ipopt"))
    assert not takes_duals(controller.solver)
    controller.recorder = []
    for _ in range(3):
        assert controller.step(10.0, 3.5, 0.0, 0.0).ok
    assert len(controller.recorder) == 3 and all(p.lam_x0 is None for p in controller.recorder)
